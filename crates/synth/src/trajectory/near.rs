//! Poses near a given camera path: the sampler for scans, whose free space is only
//! known where their own camera went (a scan has no walk graph to speak of, and uniform poses
//! over its box would mostly look at holes in the mesh).

use super::random::TriangleGrid;
use super::{PosedFrame, config, direction_of, rng, stream};
use crate::error::Result;
use crate::world::World;
use geom::{Mount, Pose};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::Rng;

/// A drawn camera centre is drawn again while it lies nearer than this to the mesh, metres: a
/// camera inside a surface sees its back faces culled, so through it.
const CLEARANCE: f64 = 0.1;
/// Draws of a centre before taking the one with the most clearance.
const TRIES: usize = 40;

/// `n` camera poses near `around` (camera-to-world poses in the world frame, e.g. a scanned
/// dataset's own path mapped into it): pose `i` starts from pose `i · len / n` of `around`, so
/// the draws spread evenly along the path in its order (every pose used when `n ≥ len`, and
/// with no spread the path itself; a uniform pick left a third of the poses unused when `n`
/// equals their number, and the consecutive frames of a sequence far apart), moves its
/// centre by a vector drawn uniformly from the ball of radius `radius_m`, and turns it by a
/// rotation drawn uniformly from the ball of rotation vectors of angle `angle_deg` (about an
/// axis through the camera centre). A centre within 0.1 m of a triangle is drawn again, up to
/// 40 times, then the clearest is kept. Deterministic per `seed`; `t` is the frame index, as
/// for [`super::random_poses`]. The place is the region the camera is in; the direction label
/// reads the pose as a forward camera's.
///
/// Errors: [`crate::SynthError::Config`] for `n == 0`, no poses, or a radius or angle that is
/// negative, not finite, or (the angle) over 180°.
pub fn near_poses(
    world: &World,
    around: &[Pose],
    n: usize,
    radius_m: f64,
    angle_deg: f64,
    seed: u64,
) -> Result<Vec<PosedFrame>> {
    if n == 0 || around.is_empty() {
        return Err(config(format!(
            "poses near a path: need at least one pose to draw and one to draw near (got {n} \
             and {})",
            around.len()
        )));
    }
    if !(radius_m.is_finite() && radius_m >= 0.0) {
        return Err(config(format!(
            "poses near a path: radius {radius_m} m must be a non-negative number"
        )));
    }
    if !(angle_deg.is_finite() && (0.0..=180.0).contains(&angle_deg)) {
        return Err(config(format!(
            "poses near a path: angle {angle_deg}° must be within 0° and 180°"
        )));
    }
    let grid = TriangleGrid::new(&world.triangles);
    let mut r = rng(seed, stream::NEAR);
    let angle = angle_deg.to_radians();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let base = &around[i * around.len() / n];
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for _ in 0..if radius_m > 0.0 { TRIES } else { 1 } {
            let c = base.translation + in_ball(&mut r, radius_m);
            let clear = grid.clearance(&world.triangles, &c, CLEARANCE);
            if best.is_none_or(|(b, _)| clear > b) {
                best = Some((clear, c));
            }
            if clear >= CLEARANCE {
                break;
            }
        }
        let centre = best.map_or(base.translation, |b| b.1);
        let turn = UnitQuaternion::from_scaled_axis(in_ball(&mut r, angle));
        let pose = Pose::new(base.rotation * turn, centre);
        let at = Point3::from(centre.cast::<f32>());
        let place = world.place_at(&at).cloned();
        let direction = place
            .as_ref()
            .and_then(|p| direction_of(p, pose.to_pose3(Mount::Forward).heading));
        out.push(PosedFrame {
            t: i as f64,
            pose,
            place,
            direction,
        });
    }
    Ok(out)
}

/// A vector drawn uniformly from the ball of radius `radius`: a uniform direction (normalised
/// Gaussian) at a length `radius · u^(1/3)`, which spreads the draws evenly over the volume.
fn in_ball(r: &mut impl Rng, radius: f64) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| super::random::normal(r));
        let len = v.norm();
        if len > 1e-9 {
            return v / len * radius * r.random::<f64>().cbrt();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::test_world;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    #[test]
    fn near_poses_stay_within_radius_and_angle_of_the_path() -> TestResult {
        let world = test_world::world();
        // A level forward camera in the ground-floor corridor, and one turned about.
        let path: Vec<Pose> = [(2.0, 0.0), (6.0, std::f64::consts::PI)]
            .iter()
            .map(|&(x, heading)| geom::Pose3 { x, y: 0.0, heading }.to_pose(Mount::Forward, 1.5))
            .collect();
        let frames = near_poses(&world, &path, 400, 0.3, 10.0, 7)?;
        assert_eq!(frames.len(), 400);
        let mut used = [0usize; 2];
        let mut far = 0usize;
        for f in &frames {
            let (k, d) = path
                .iter()
                .enumerate()
                .map(|(k, p)| (k, (f.pose.translation - p.translation).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .ok_or("no path")?;
            assert!(d <= 0.3 + 1e-9, "{d}");
            far += usize::from(d > 0.2);
            used[k] += 1;
            let turn = path[k].rotation.angle_to(&f.pose.rotation).to_degrees();
            assert!(turn <= 10.0 + 1e-9, "{turn}");
            assert!(f.place.is_some());
        }
        // Both poses are drawn from; uniform in the ball puts 70 % of draws beyond 2/3 of it.
        assert!(used.iter().all(|&u| u > 150), "{used:?}");
        assert!(far > 200, "{far}");
        assert_eq!(frames, near_poses(&world, &path, 400, 0.3, 10.0, 7)?);
        assert_ne!(frames, near_poses(&world, &path, 400, 0.3, 10.0, 8)?);
        // No spread: the path itself, in its order.
        let exact = near_poses(&world, &path[..1], 3, 0.0, 0.0, 1)?;
        assert!(exact.iter().all(|f| f.pose == path[0]));
        let both = near_poses(&world, &path, 2, 0.0, 0.0, 1)?;
        assert!(both.iter().zip(&path).all(|(f, p)| f.pose == *p));
        Ok(())
    }

    #[test]
    fn near_poses_refuse_bad_settings() {
        let world = test_world::world();
        let path = [Pose::identity()];
        assert!(near_poses(&world, &path, 0, 0.3, 10.0, 1).is_err());
        assert!(near_poses(&world, &[], 5, 0.3, 10.0, 1).is_err());
        assert!(near_poses(&world, &path, 5, -0.1, 10.0, 1).is_err());
        assert!(near_poses(&world, &path, 5, f64::NAN, 10.0, 1).is_err());
        assert!(near_poses(&world, &path, 5, 0.3, 200.0, 1).is_err());
    }
}
