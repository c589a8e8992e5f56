//! Tests of walks, random poses, scene cuts and cameras on the hand-built test world.

use super::test_world::{self, CORRIDOR_A, ROOM};
use super::*;
use crate::world::WalkGraph;
use geom::rotation::wrap_angle;
use nalgebra::{Point3, Vector3};

type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// Horizontal distance from the camera to the nearest walk-graph edge whose floor, at the
/// camera's foot point, lies `height` (± tol) below the camera.
fn edge_distance(world: &World, c: &Vector3<f64>, height: [f64; 2], tol: f64) -> f64 {
    let mut best = f64::INFINITY;
    for &[a, b] in &world.walk.edges {
        let pa = world.walk.nodes[a].p.coords.cast::<f64>();
        let pb = world.walk.nodes[b].p.coords.cast::<f64>();
        let ab = (pb - pa).xy();
        let len2 = ab.norm_squared();
        let u = if len2 > 0.0 {
            ((c.xy() - pa.xy()).dot(&ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let foot = pa + (pb - pa) * u;
        let h = c.z - foot.z;
        if h < height[0] - tol || h > height[1] + tol {
            continue;
        }
        best = best.min((c.xy() - foot.xy()).norm());
    }
    best
}

fn xy_steps(frames: &[PosedFrame]) -> Vec<f64> {
    frames
        .windows(2)
        .map(|w| (w[1].pose.translation - w[0].pose.translation).xy().norm())
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn headings(frames: &[PosedFrame], mount: Mount) -> Vec<f64> {
    frames
        .iter()
        .map(|f| f.pose.to_pose3(mount).heading)
        .collect()
}

#[test]
fn forward_walk_stays_on_edges_at_head_height_and_looks_level() -> TestResult {
    let world = test_world::world();
    let cfg = WalkConfig::default();
    for seed in 0..4 {
        let frames = walk(&world, &cfg, 3000, seed)?;
        assert_eq!(frames.len(), 3000);
        let mut worst: f64 = 0.0;
        for f in &frames {
            // Corners at the ends of stairs blend the slope in, up to ~0.1 m off the edges' z.
            let d = edge_distance(&world, &f.pose.translation, [1.2, 1.8], 0.12);
            worst = worst.max(d);
            let fz = f.pose.forward().z;
            assert!(fz.abs() < 15f64.to_radians().sin(), "pitch {fz}");
        }
        assert!(worst <= 0.3, "seed {seed}: {worst:.3} m off the edges");
        eprintln!("forward seed {seed}: max {worst:.3} m off the edges");
    }
    Ok(())
}

#[test]
fn ceiling_walk_looks_up_at_robot_height() -> TestResult {
    let world = test_world::world();
    let cfg = WalkConfig::for_rig(Rig::ceiling());
    let frames = walk(&world, &cfg, 2000, 7)?;
    for f in &frames {
        assert!(f.pose.forward().z > 0.9999, "{:?}", f.pose.forward());
        let d = edge_distance(&world, &f.pose.translation, [0.3, 0.3], 0.12);
        assert!(d <= 0.3, "{d}");
    }
    // 5 Hz: 0.2 s apart.
    assert!((frames[1].t - frames[0].t - 0.2).abs() < 1e-12);
    // Heading is the image-up axis and turns at the rig's rate.
    let h = headings(&frames, Mount::Ceiling);
    let rate = h
        .windows(2)
        .map(|w| wrap_angle(w[1] - w[0]).abs() * cfg.fps)
        .fold(0.0, f64::max);
    assert!(rate.to_degrees() <= 45.0 * 1.001, "{}", rate.to_degrees());
    Ok(())
}

#[test]
fn speed_yaw_rate_and_pauses_are_natural() -> TestResult {
    let world = test_world::world();
    let cfg = WalkConfig::default();
    for seed in [1, 2, 3] {
        let frames = walk(&world, &cfg, 4000, seed)?;
        let steps = xy_steps(&frames);
        let speeds: Vec<f64> = steps.iter().map(|s| s * cfg.fps).collect();
        let moving: Vec<f64> = speeds.iter().copied().filter(|v| *v > 0.05).collect();
        let med = median(moving.clone());
        let max = moving.iter().copied().fold(0.0, f64::max);
        assert!((0.5..=1.5).contains(&med), "median speed {med}");
        // Lateral drift and sway add a few per cent to the path speed.
        assert!(max <= 1.5 * 1.1, "max speed {max}");
        let yaw_rate = headings(&frames, Mount::Forward)
            .windows(2)
            .map(|w| wrap_angle(w[1] - w[0]).abs() * cfg.fps)
            .fold(0.0, f64::max)
            .to_degrees();
        assert!(yaw_rate <= 90.0 * 1.001, "yaw rate {yaw_rate}°/s");
        // Pauses: at least a second standing still.
        let mut pauses = 0;
        let mut run = 0;
        for s in &steps {
            if *s < 0.002 {
                run += 1;
                if run == 10 {
                    pauses += 1;
                }
            } else {
                run = 0;
            }
        }
        assert!(pauses >= 2, "{pauses} pauses");
        // Camera height above the floor stays in the rig's range (bob included) off the stairs.
        for f in &frames {
            let place = f.place.as_ref().ok_or("no place")?;
            if place.kind == PlaceKind::Stairwell {
                continue;
            }
            let h = f.pose.translation.z - 3.5 * f64::from(place.storey);
            assert!((1.2..=1.8).contains(&h), "height {h} at t = {}", f.t);
        }
        eprintln!(
            "seed {seed}: median speed {med:.2} m/s, max {max:.2} m/s, max yaw rate \
             {yaw_rate:.1}°/s, {pauses} pauses in {:.0} s",
            frames.len() as f64 / cfg.fps
        );
    }
    Ok(())
}

#[test]
fn head_bobs_at_step_frequency() -> TestResult {
    let world = test_world::world();
    let frames = walk(&world, &WalkConfig::default(), 600, 5)?;
    // Count rises and falls of the camera height on straight, level stretches: with a steady
    // pace the bob shows as alternating signs of dz at about 2 × 1.8 Hz.
    let dz: Vec<f64> = frames
        .windows(2)
        .map(|w| w[1].pose.translation.z - w[0].pose.translation.z)
        .collect();
    let amp = frames
        .iter()
        .filter(|f| {
            f.place
                .as_ref()
                .is_some_and(|p| p.storey == 0 && p.kind == PlaceKind::Corridor)
        })
        .map(|f| f.pose.translation.z)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        });
    assert!(amp.1 - amp.0 > 0.015 && amp.1 - amp.0 < 0.08, "{amp:?}");
    assert!(dz.iter().any(|d| *d > 0.001) && dz.iter().any(|d| *d < -0.001));
    Ok(())
}

#[test]
fn walks_are_deterministic_per_seed() -> TestResult {
    let world = test_world::world();
    let cfg = WalkConfig::default();
    let a = walk(&world, &cfg, 500, 42)?;
    let b = walk(&world, &cfg, 500, 42)?;
    let c = walk(&world, &cfg, 500, 43)?;
    assert_eq!(a, b);
    assert_ne!(a, c);
    Ok(())
}

#[test]
fn long_walks_visit_every_storey_rooms_and_both_directions() -> TestResult {
    let world = test_world::world();
    // The test world has a single room: make entering it likely enough to see in 10 minutes.
    let cfg = WalkConfig {
        room_probability: 0.3,
        ..WalkConfig::default()
    };
    for seed in [10, 11] {
        let frames = walk(&world, &cfg, 6000, seed)?;
        let storeys: std::collections::BTreeSet<u8> = frames
            .iter()
            .filter_map(|f| f.place.as_ref().map(|p| p.storey))
            .collect();
        assert_eq!(storeys.len(), 2, "{storeys:?}");
        let room = &world.regions[ROOM].place;
        assert!(frames.iter().any(|f| f.place.as_ref() == Some(room)));
        // Labels match the heading, and both directions along corridor A occur.
        let corridor = &world.regions[CORRIDOR_A].place;
        let mut seen = [false; 2];
        for f in &frames {
            let Some(p) = &f.place else { continue };
            let heading = f.pose.to_pose3(Mount::Forward).heading;
            match p.kind {
                PlaceKind::Corridor => {
                    let axis = f64::from(p.axis.ok_or("corridor without axis")?);
                    let along = (heading - axis).cos();
                    let want = if along > 0.75 {
                        Direction::Forward
                    } else if along < -0.75 {
                        Direction::Backward
                    } else if along.abs() < 0.65 {
                        Direction::Across
                    } else {
                        // within a few degrees of 45°: either label is fair
                        continue;
                    };
                    assert_eq!(f.direction, Some(want));
                }
                _ => assert_eq!(f.direction, None),
            }
            if p == corridor {
                match f.direction {
                    Some(Direction::Forward) => seen[0] = true,
                    Some(Direction::Backward) => seen[1] = true,
                    Some(Direction::Across) | None => {}
                }
            }
        }
        assert_eq!(seen, [true, true]);
        // Every frame has a place (regions plus the graph's fallback cover the walk).
        assert!(frames.iter().all(|f| f.place.is_some()));
    }
    Ok(())
}

#[test]
fn direction_flips_when_walking_back() -> TestResult {
    // A single corridor: the walker must turn round at its ends.
    let mut world = test_world::world();
    world.walk = WalkGraph {
        nodes: world.walk.nodes[1..=5].to_vec(),
        edges: vec![[0, 1], [1, 2], [2, 3], [3, 4]],
    };
    let frames = walk(&world, &WalkConfig::default(), 1200, 3)?;
    let mut flips = 0;
    for w in frames.windows(2) {
        if let (Some(a), Some(b)) = (w[0].direction, w[1].direction)
            && a != b
        {
            flips += 1;
        }
    }
    assert!(flips >= 2, "{flips} flips in 120 s along a 20 m corridor");
    Ok(())
}

#[test]
fn bad_inputs_are_config_errors() {
    let world = test_world::world();
    let cfg = WalkConfig::default();
    assert!(matches!(
        walk(&world, &cfg, 0, 1),
        Err(SynthError::Config(_))
    ));
    assert!(matches!(
        walk(&World::default(), &cfg, 10, 1),
        Err(SynthError::Config(_))
    ));
    let mut no_edges = world.clone();
    no_edges.walk.edges.clear();
    assert!(matches!(
        walk(&no_edges, &cfg, 10, 1),
        Err(SynthError::Config(_))
    ));
    let mut bad_edge = world.clone();
    bad_edge.walk.edges.push([0, 99]);
    assert!(matches!(
        walk(&bad_edge, &cfg, 10, 1),
        Err(SynthError::Config(_))
    ));
    let slow = WalkConfig {
        speed_mps: [1.0, 0.5],
        ..cfg.clone()
    };
    assert!(matches!(
        walk(&world, &slow, 10, 1),
        Err(SynthError::Config(_))
    ));
    assert!(random_poses(&world, &Rig::forward(), 0, 1).is_err());
    assert!(random_poses(&World::default(), &Rig::forward(), 5, 1).is_err());
    assert!(with_cuts(&world, &cfg, 0, [10, 20], 1).is_err());
    assert!(with_cuts(&world, &cfg, 3, [20, 10], 1).is_err());
}

#[test]
fn random_poses_lie_in_their_regions() -> TestResult {
    let world = test_world::world();
    for rig in [Rig::forward(), Rig::ceiling()] {
        let frames = random_poses(&world, &rig, 500, 9)?;
        assert_eq!(frames, random_poses(&world, &rig, 500, 9)?);
        let [lo, hi] = rig.height_range().map(f64::from);
        let mut by_region = vec![0usize; world.regions.len()];
        for f in &frames {
            let c = f.pose.translation.cast::<f32>();
            let p = Point3::from(c);
            let place = f.place.as_ref().ok_or("no place")?;
            let region = world
                .regions
                .iter()
                .position(|r| r.contains(&p) && &r.place == place)
                .ok_or("pose outside its region")?;
            by_region[region] += 1;
            let h = f.pose.translation.z - f64::from(world.regions[region].floor_z);
            assert!(h >= lo - 1e-6 && h <= hi + 1e-6, "{h}");
            match rig.mount() {
                Mount::Forward => assert!(f.pose.forward().z.abs() < 15f64.to_radians().sin()),
                Mount::Ceiling => assert!(f.pose.forward().z > 0.9999),
            }
        }
        // Every region is sampled, the biggest (corridor A, 44 m²) more than the room (16 m²).
        assert!(by_region.iter().all(|&k| k > 0), "{by_region:?}");
        assert!(by_region[CORRIDOR_A] > by_region[ROOM]);
        let h = headings(&frames, rig.mount());
        assert!(h.iter().any(|x| *x > 2.0) && h.iter().any(|x| *x < -2.0));
    }
    Ok(())
}

#[test]
fn cuts_jump_far_and_steps_between_are_small() -> TestResult {
    let world = test_world::world();
    for rig in [Rig::forward(), Rig::ceiling()] {
        let cfg = WalkConfig::for_rig(rig);
        let (frames, cuts) = with_cuts(&world, &cfg, 6, [40, 120], 5)?;
        assert_eq!(cuts.len(), 5);
        assert!(
            cuts.windows(2)
                .all(|w| w[1] - w[0] >= 40 && w[1] - w[0] <= 120)
        );
        assert!(cuts[0] >= 40 && frames.len() - cuts[4] >= 40);
        for (i, w) in frames.windows(2).enumerate() {
            let jump = (w[1].pose.translation - w[0].pose.translation).norm();
            let storey = |f: &PosedFrame| f.place.as_ref().map(|p| (p.building, p.storey));
            if cuts.contains(&(i + 1)) {
                assert!(
                    jump > 3.0 || storey(&w[0]) != storey(&w[1]),
                    "cut at {} jumps only {jump:.2} m",
                    i + 1
                );
            } else {
                assert!(jump < 0.5, "step {jump:.2} m at {}", i + 1);
            }
            // Time runs on uniformly across cuts.
            assert!((w[1].t - w[0].t - 1.0 / cfg.fps).abs() < 1e-9);
        }
    }
    Ok(())
}

#[test]
fn camera_fov_is_drawn_from_the_rig_range() -> TestResult {
    let mut fovs = Vec::new();
    for seed in 0..50 {
        let cam = camera_for(&Rig::forward(), 320, 240, seed)?;
        let f = cam.hfov().to_degrees();
        assert!((50.0..=70.0).contains(&f), "{f}");
        fovs.push(f);
    }
    assert!(fovs.iter().any(|f| *f < 55.0) && fovs.iter().any(|f| *f > 65.0));
    assert_eq!(
        camera_for(&Rig::forward(), 320, 240, 3)?,
        camera_for(&Rig::forward(), 320, 240, 3)?
    );
    let up = camera_for(&Rig::ceiling(), 160, 120, 0)?;
    assert!((up.hfov().to_degrees() - 90.0).abs() < 1e-9);
    assert!(camera_for(&Rig::forward(), 0, 240, 0).is_err());
    Ok(())
}

#[test]
fn direction_labels_follow_the_axis() {
    let place = Place {
        building: 0,
        storey: 0,
        corridor: Some(1),
        kind: PlaceKind::Corridor,
        axis: Some(std::f32::consts::FRAC_PI_2),
    };
    let axis = std::f64::consts::FRAC_PI_2;
    assert_eq!(direction_of(&place, axis + 0.7), Some(Direction::Forward));
    assert_eq!(direction_of(&place, axis - 0.7), Some(Direction::Forward));
    assert_eq!(
        direction_of(&place, axis + std::f64::consts::PI - 0.7),
        Some(Direction::Backward)
    );
    assert_eq!(direction_of(&place, -axis), Some(Direction::Backward));
    // square on to either wall, and past 45° on either side of it
    assert_eq!(direction_of(&place, 0.0), Some(Direction::Across));
    assert_eq!(
        direction_of(&place, std::f64::consts::PI),
        Some(Direction::Across)
    );
    assert_eq!(direction_of(&place, axis + 0.9), Some(Direction::Across));
    assert_eq!(direction_of(&place, axis - 2.3), Some(Direction::Across));
    let room = Place {
        kind: PlaceKind::Room,
        ..place
    };
    assert_eq!(direction_of(&room, 1.0), None);
}

#[test]
fn corners_are_rounded_within_a_fifth_of_a_metre() {
    use super::path::Path;
    let pts = [
        (Vector3::new(0.0, 0.0, 0.0), 0),
        (Vector3::new(5.0, 0.0, 0.0), 0),
        (Vector3::new(5.0, 5.0, 0.0), 0),
        (Vector3::new(5.0, 0.0, 0.0), 0),
    ];
    let path = Path::new(&pts, 1.5, 1.0);
    // 5 + 5 + 5 m less what the rounded corner saves.
    assert!(path.total > 14.5 && path.total < 15.0, "{}", path.total);
    assert_eq!(path.uturns.len(), 1);
    let mut worst: f64 = 0.0;
    let mut s = 0.0;
    while s <= path.total {
        let p = path.at(s).p;
        // Distance to the L of the first two edges (the way back lies on the second).
        let d1 = if p.x <= 5.0 { p.y.abs() } else { f64::INFINITY };
        let d2 = if p.y >= 0.0 {
            (p.x - 5.0).abs()
        } else {
            f64::INFINITY
        };
        worst = worst.max(d1.min(d2));
        s += 0.01;
    }
    assert!(worst <= 0.2 + 1e-9, "{worst}");
    // A speed limit lies at the corner and a stop at the dead end.
    assert!(path.speed_limit(4.0, 0.8, 4.0) < 1.5);
    assert!(path.speed_limit(path.uturns[0] - 1e-6, 0.8, 4.0) < 0.01);
}

#[test]
fn walker_never_stalls_on_short_sharp_zigzags() -> TestResult {
    // Short edges (0.5–1.5 m) with 100–140° turns: the look-ahead point lies far off the
    // current edge's direction, which must not stop the walker for good.
    let mut world = test_world::world();
    let mut nodes = Vec::new();
    let mut p = Point3::new(0.0f32, 0.0, 0.0);
    let mut heading = 0.0f32;
    for k in 0..40 {
        nodes.push(crate::world::WalkNode {
            p,
            region: CORRIDOR_A,
        });
        let len = 0.5 + (k % 3) as f32 * 0.5;
        let turn = [100.0f32, -120.0, 140.0, -100.0][k % 4].to_radians();
        heading += turn;
        p += nalgebra::Vector3::new(heading.cos(), heading.sin(), 0.0) * len;
    }
    let edges = (1..nodes.len()).map(|i| [i - 1, i]).collect();
    world.walk = WalkGraph { nodes, edges };
    for rig in [Rig::forward(), Rig::ceiling()] {
        let cfg = WalkConfig {
            pause_probability: 0.0,
            ..WalkConfig::for_rig(rig)
        };
        let frames = walk(&world, &cfg, 1500, 1)?;
        let mut run = 0;
        let mut longest = 0;
        for s in xy_steps(&frames) {
            run = if s < 1e-4 { run + 1 } else { 0 };
            longest = longest.max(run);
        }
        // Turning round at a dead end at 45°/s takes 4 s; nothing should take longer.
        assert!(
            longest as f64 / cfg.fps < 6.0,
            "stood still {longest} frames"
        );
    }
    Ok(())
}
