//! Uniform random poses in free space: the second sampler, for training sets that cover every
//! place and heading evenly rather than along walked routes.

use super::{PosedFrame, Rig, config, direction_of, pick_weighted, rng, stream, uniform};
use crate::error::Result;
use crate::world::{Region, Triangle, World};
use geom::{Mount, Pose, Pose3};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::Rng;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Distance kept from the sides of a region where it is wide enough, metres.
const SIDE_MARGIN: f64 = 0.3;
/// Distance kept from any triangle (furniture inside a region), metres.
const CLEARANCE: f64 = 0.2;
/// Draws per pose before taking the candidate with the most clearance.
const TRIES: usize = 40;
/// Cell of the triangle grid, metres.
const CELL: f64 = 1.0;

pub(super) fn sample(world: &World, rig: &Rig, n: usize, seed: u64) -> Result<Vec<PosedFrame>> {
    let areas: Vec<f64> = world
        .regions
        .iter()
        .map(|r| {
            let a = f64::from(r.max[0] - r.min[0]) * f64::from(r.max[1] - r.min[1]);
            let tall = r.ceiling_z > r.floor_z;
            if a.is_finite() && a > 0.0 && tall {
                a
            } else {
                0.0
            }
        })
        .collect();
    if !areas.iter().any(|a| *a > 0.0) {
        return Err(config(format!(
            "world '{}' has no labelled regions of free space to sample poses in",
            world.name
        )));
    }
    let grid = TriangleGrid::new(&world.triangles);
    let mut r = rng(seed, stream::RANDOM);
    let mount = rig.mount();
    let [h_lo, h_hi] = rig.height_range().map(f64::from);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let ri = pick_weighted(&mut r, &areas).unwrap_or(0);
        let region = &world.regions[ri];
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for _ in 0..TRIES {
            let c = candidate(region, h_lo, h_hi, &mut r);
            let clear = grid.clearance(&world.triangles, &c, CLEARANCE);
            if best.is_none_or(|(b, _)| clear > b) {
                best = Some((clear, c));
            }
            if clear >= CLEARANCE {
                break;
            }
        }
        let c = best.map_or_else(Vector3::zeros, |b| b.1);
        let heading = uniform(&mut r, -PI, PI);
        let level = Pose3 {
            x: c.x,
            y: c.y,
            heading,
        }
        .to_pose(mount, c.z);
        let pose = match mount {
            Mount::Forward => {
                let pitch = (4f64.to_radians() * normal(&mut r))
                    .clamp(-12f64.to_radians(), 12f64.to_radians());
                let roll = (2f64.to_radians() * normal(&mut r))
                    .clamp(-6f64.to_radians(), 6f64.to_radians());
                let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch)
                    * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
                Pose::new(level.rotation * tilt, level.translation)
            }
            Mount::Ceiling => level,
        };
        let place = region.place.clone();
        let direction = direction_of(&place, pose.to_pose3(mount).heading);
        out.push(PosedFrame {
            t: i as f64,
            pose,
            place: Some(place),
            direction,
        });
    }
    Ok(out)
}

/// A camera centre inside `region`: uniform over its floor (away from the sides where it is
/// wide enough), at a height from the rig's range, kept 0.1 m under the ceiling.
fn candidate(region: &Region, h_lo: f64, h_hi: f64, r: &mut impl Rng) -> Vector3<f64> {
    let axis = |lo: f32, hi: f32, r: &mut dyn FnMut() -> f64| {
        let (lo, hi) = (f64::from(lo), f64::from(hi));
        let m = if hi - lo > 4.0 * SIDE_MARGIN {
            SIDE_MARGIN
        } else {
            (hi - lo) / 4.0
        };
        lo + m + (hi - lo - 2.0 * m) * r()
    };
    let mut draw = || r.random::<f64>();
    let x = axis(region.min[0], region.max[0], &mut draw);
    let y = axis(region.min[1], region.max[1], &mut draw);
    let floor = f64::from(region.floor_z);
    let room = (f64::from(region.ceiling_z) - floor - 0.1).max(0.0);
    let h = (h_lo + (h_hi - h_lo) * draw()).min(room);
    Vector3::new(x, y, floor + h)
}

/// A standard normal draw (Box–Muller).
pub(super) fn normal(r: &mut impl Rng) -> f64 {
    let u1 = r.random::<f64>().max(1e-12);
    let u2 = r.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// Triangles binned by floor-plan cell, to find those near a point without scanning all.
pub(super) struct TriangleGrid {
    cells: HashMap<(i64, i64), Vec<u32>>,
    /// Triangles spanning too many cells to bin (a huge floor): always checked.
    big: Vec<u32>,
}

impl TriangleGrid {
    pub(super) fn new(tris: &[Triangle]) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        let mut big = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            let (lo, hi) = bounds(t);
            let (x0, y0) = (cell(lo.x), cell(lo.y));
            let (x1, y1) = (cell(hi.x), cell(hi.y));
            if (x1 - x0 + 1).saturating_mul(y1 - y0 + 1) > 256 {
                big.push(i as u32);
                continue;
            }
            for cx in x0..=x1 {
                for cy in y0..=y1 {
                    cells.entry((cx, cy)).or_default().push(i as u32);
                }
            }
        }
        Self { cells, big }
    }

    /// Distance from `p` to the nearest triangle, up to `limit` (returned when nothing is
    /// nearer).
    pub(super) fn clearance(&self, tris: &[Triangle], p: &Vector3<f64>, limit: f64) -> f64 {
        let mut best = limit;
        let mut check = |i: u32| {
            if let Some(t) = tris.get(i as usize) {
                best = best.min(point_triangle_distance(p, t));
            }
        };
        for &i in &self.big {
            check(i);
        }
        let (x0, x1) = (cell(p.x - limit), cell(p.x + limit));
        let (y0, y1) = (cell(p.y - limit), cell(p.y + limit));
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                if let Some(list) = self.cells.get(&(cx, cy)) {
                    for &i in list {
                        check(i);
                    }
                }
            }
        }
        best
    }
}

fn cell(x: f64) -> i64 {
    (x / CELL).floor().clamp(-1e9, 1e9) as i64
}

fn bounds(t: &Triangle) -> (Vector3<f64>, Vector3<f64>) {
    let v = t.v.map(|p| p.coords.cast::<f64>());
    (v[0].inf(&v[1]).inf(&v[2]), v[0].sup(&v[1]).sup(&v[2]))
}

/// Distance from `p` to triangle `t` (closest point by Voronoi regions, after Ericson,
/// "Real-Time Collision Detection", 5.1.5).
fn point_triangle_distance(p: &Vector3<f64>, t: &Triangle) -> f64 {
    let [a, b, c] = t.v.map(|q: Point3<f32>| q.coords.cast::<f64>());
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (p - a).norm();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (p - b).norm();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).norm();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (p - c).norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).norm();
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 {
        return (p - a).norm();
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_triangle_distance_hand_checked() {
        let t = Triangle {
            v: [
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        };
        // Above the face, beyond a vertex, beside an edge.
        let cases = [
            (Vector3::new(0.2, 0.2, 0.5), 0.5),
            (Vector3::new(-1.0, 0.0, 0.0), 1.0),
            (Vector3::new(0.5, -2.0, 0.0), 2.0),
            (Vector3::new(1.0, 1.0, 0.0), 0.5f64.sqrt()),
        ];
        for (p, d) in cases {
            assert!((point_triangle_distance(&p, &t) - d).abs() < 1e-9, "{p:?}");
        }
    }
}
