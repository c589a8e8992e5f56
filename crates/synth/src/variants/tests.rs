//! Tests of the appearance variants and the crowd on the hand-built test world.

use super::*;
use crate::trajectory::test_world;

type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn off_fraction(world: &World) -> f64 {
    world.lights.iter().filter(|l| !l.on).count() as f64 / world.lights.len() as f64
}

#[test]
fn some_lights_off_switches_off_about_half_deterministically() {
    let mut fractions = Vec::new();
    for seed in 0..20 {
        let mut a = test_world::world();
        apply(&mut a, Variant::SomeLightsOff, seed);
        let f = off_fraction(&a);
        assert!((0.3..=0.7).contains(&f), "seed {seed}: {f}");
        let mut b = test_world::world();
        apply(&mut b, Variant::SomeLightsOff, seed);
        assert_eq!(a, b);
        fractions.push(f);
        // Each switched-off light's panel got the dark copy, each lit one kept the original.
        let panel = a.lights[0].fixture.unwrap_or(0);
        let off_copy = a
            .materials
            .iter()
            .position(|m| m.name == "light panel (off)")
            .map(|i| i as MaterialId);
        let copy = off_copy.unwrap_or(MaterialId::MAX);
        assert_eq!(a.materials[usize::from(copy)].emissive, 0.0);
        for l in &a.lights {
            let near = a
                .triangles
                .iter()
                .find(|t| {
                    let c = (t.v[0].coords + t.v[1].coords + t.v[2].coords) / 3.0;
                    (c - l.position.coords).norm() < 0.3
                })
                .map(|t| t.material);
            assert_eq!(near, Some(if l.on { panel } else { copy }));
        }
    }
    // Different seeds switch off different lights.
    let mut a = test_world::world();
    let mut b = test_world::world();
    apply(&mut a, Variant::SomeLightsOff, 1);
    apply(&mut b, Variant::SomeLightsOff, 2);
    assert_ne!(
        a.lights.iter().map(|l| l.on).collect::<Vec<_>>(),
        b.lights.iter().map(|l| l.on).collect::<Vec<_>>()
    );
    eprintln!("lights off: {fractions:.2?}");
}

#[test]
fn own_fixture_materials_are_darkened_in_place() {
    let mut world = test_world::world();
    // Give every panel its own material, as the procedural generator does.
    for i in 0..world.lights.len() {
        let Some(m) = world.lights[i].fixture else {
            continue;
        };
        let own = world.add_material(world.materials[usize::from(m)].clone());
        let p = world.lights[i].position;
        for t in &mut world.triangles {
            let c = (t.v[0].coords + t.v[1].coords + t.v[2].coords) / 3.0;
            if t.material == m && (c - p.coords).norm() < 0.3 {
                t.material = own;
            }
        }
        world.lights[i].fixture = Some(own);
    }
    let materials = world.materials.len();
    apply(&mut world, Variant::SomeLightsOff, 6);
    assert_eq!(world.materials.len(), materials);
    for l in &world.lights {
        let m = &world.materials[usize::from(l.fixture.unwrap_or(0))];
        assert_eq!(m.emissive, if l.on { 1.0 } else { 0.0 });
    }
    // Applying again darkens nothing twice.
    let once = world.clone();
    darken_fixtures(&mut world);
    assert_eq!(world, once);
}

#[test]
fn dim_daylight_and_disaster_change_light_and_air() {
    let base = test_world::world();
    let mut dim = base.clone();
    apply(&mut dim, Variant::Dim, 0);
    assert!(
        dim.lights
            .iter()
            .all(|l| l.on && (l.intensity - 0.3).abs() < 1e-6)
    );
    assert!(dim.atmosphere.ambient < base.atmosphere.ambient);
    assert!(dim.atmosphere.daylight <= 0.1);

    let mut day = base.clone();
    apply(&mut day, Variant::Daylight, 0);
    assert!(day.lights.iter().all(|l| !l.on));
    // All panels off: the shared panel material itself goes dark, no copy needed.
    assert_eq!(day.materials.len(), base.materials.len());
    let panel = usize::from(base.lights[0].fixture.unwrap_or(0));
    assert_eq!(day.materials[panel].emissive, 0.0);
    assert_eq!(day.atmosphere.daylight, 1.0);
    assert!(day.atmosphere.ambient > base.atmosphere.ambient);

    let mut disaster = base.clone();
    apply(&mut disaster, Variant::Disaster, 4);
    let f = off_fraction(&disaster);
    assert!((0.7..=0.9).contains(&f), "{f}");
    assert!((0.05..=0.1).contains(&disaster.atmosphere.haze));
    assert!(disaster.atmosphere.ambient < base.atmosphere.ambient);

    for v in [
        Variant::Normal,
        Variant::People,
        Variant::FurnitureMoved,
        Variant::PostersChanged,
    ] {
        let mut w = base.clone();
        apply(&mut w, v, 3);
        assert_eq!(w, base, "{v:?}");
    }
}

#[test]
fn texture_swap_changes_every_material_colour_and_seed() {
    let mut world = test_world::world();
    world.add_material(crate::world::Material::plain("black", [0.0, 0.0, 0.0]));
    world.add_material(crate::world::Material::plain("white", [1.0, 1.0, 1.0]));
    let base = world.clone();
    apply(&mut world, Variant::TextureSwap, 8);
    assert_eq!(world.triangles, base.triangles);
    for (a, b) in base.materials.iter().zip(&world.materials) {
        let moved = a
            .color
            .iter()
            .zip(b.color)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(moved >= 0.03, "{}: {:?} -> {:?}", a.name, a.color, b.color);
        assert!(b.color.iter().all(|c| (0.0..=1.0).contains(c)));
        assert_ne!(a.seed, b.seed);
        assert_eq!(a.pattern, b.pattern);
    }
    let mut again = base.clone();
    apply(&mut again, Variant::TextureSwap, 8);
    assert_eq!(again, world);
}

#[test]
fn randomized_materials_are_independent_per_material_and_follow_the_seed() {
    let mut world = test_world::world();
    for k in 0..12 {
        world.add_material(crate::world::Material::plain(format!("grey {k}"), [0.5; 3]));
    }
    let base = world.clone();
    randomize_materials(&mut world, 3);
    assert_eq!(world.triangles, base.triangles);
    assert_eq!(world.lights, base.lights);
    // Twelve materials of one colour before: twelve different colours after (a common
    // repaint would have kept them equal), each a valid colour with a new pattern seed.
    let greys: Vec<[f32; 3]> = world.materials[base.materials.len() - 12..]
        .iter()
        .map(|m| m.color)
        .collect();
    for (i, a) in greys.iter().enumerate() {
        assert!(a.iter().all(|c| (0.0..=1.0).contains(c)), "{a:?}");
        for b in &greys[i + 1..] {
            assert_ne!(a, b);
        }
    }
    for (a, b) in base.materials.iter().zip(&world.materials) {
        assert_ne!(a.seed, b.seed);
    }
    let mut again = base.clone();
    randomize_materials(&mut again, 3);
    assert_eq!(again, world);
    let mut other = base;
    randomize_materials(&mut other, 4);
    assert_ne!(other, world);
}

#[test]
fn randomized_lighting_varies_over_seeds_keeps_geometry_and_follows_the_seed() {
    let base = test_world::world();
    let mut fractions = Vec::new();
    for seed in 0..20 {
        let mut world = base.clone();
        randomize_lighting(&mut world, seed);
        // Geometry stays; a lamp switched off takes the unlit lamp material.
        let corners = |w: &World| -> Vec<_> { w.triangles.iter().map(|t| t.v).collect() };
        assert_eq!(corners(&world), corners(&base));
        assert_eq!(world.atmosphere.haze, base.atmosphere.haze, "no smoke");
        let f = off_fraction(&world);
        assert!((0.0..=0.85).contains(&f), "seed {seed}: {f}");
        fractions.push(f);
        for (a, b) in base.lights.iter().zip(&world.lights) {
            assert_eq!(a.position, b.position);
            let ratio = b.intensity / a.intensity;
            assert!(
                (0.5..=1.2).contains(&ratio),
                "seed {seed}: intensity x{ratio}"
            );
        }
        let ambient = world.atmosphere.ambient / base.atmosphere.ambient;
        assert!(
            (0.4..=1.2).contains(&ambient),
            "seed {seed}: ambient x{ambient}"
        );
        let mut again = base.clone();
        randomize_lighting(&mut again, seed);
        assert_eq!(again, world);
    }
    // Over twenty draws: some with every light on or nearly, some with most off.
    let (lo, hi) = fractions
        .iter()
        .fold((1.0f64, 0.0f64), |(a, b), &f| (a.min(f), b.max(f)));
    assert!(lo < 0.25 && hi > 0.5, "off fractions {lo}..{hi}");
}

#[test]
fn hsv_round_trip() {
    for c in [
        [0.2, 0.5, 0.9],
        [1.0, 0.0, 0.0],
        [0.3, 0.3, 0.3],
        [0.9, 0.8, 0.1],
    ] {
        let back = hsv_to_rgb(rgb_to_hsv(c));
        for k in 0..3 {
            assert!((back[k] - c[k]).abs() < 1e-5, "{c:?} -> {back:?}");
        }
    }
}

#[test]
fn crowd_walks_the_edges_and_moves_with_time() -> TestResult {
    let mut world = test_world::world();
    let base = world.clone();
    let materials = world.materials.len();
    let count = Crowd::suggested_count(&world);
    assert_eq!(count, 9);
    let crowd = Crowd::new(&mut world, count, 5);
    assert_eq!(crowd.len(), count);
    assert!(world.materials.len() >= materials + 10);
    let mut other = base.clone();
    assert!(Crowd::new(&mut other, count, 5) == crowd && other == world);
    // Corridors each get people at t = 0.
    let at0 = crowd.figures_at(&world, 0.0);
    let corridors: std::collections::BTreeSet<Option<u16>> = at0
        .iter()
        .filter_map(|f| world.place_at(&(f.position + nalgebra::Vector3::new(0.0, 0.0, 1.0))))
        .map(|p| p.corridor)
        .collect();
    assert!(corridors.len() >= 3, "{corridors:?}");
    for t in [0.0, 0.5, 7.3, 100.0, 1000.0, 12345.6] {
        let figs = crowd.figures_at(&world, t);
        assert_eq!(figs.len(), count);
        for f in &figs {
            let d = distance_to_edges(&world, &f.position);
            assert!(d <= 0.36, "t = {t}: {d} m off the graph");
        }
        let later = crowd.figures_at(&world, t + 1.0);
        for (a, b) in figs.iter().zip(&later) {
            let moved = (a.position - b.position).norm();
            // About 1.2 m in a second; less where the route turns or reverses within it.
            assert!(moved > 0.2 && moved < 1.5, "{moved}");
        }
        let tris = crowd.triangles_at(&world, t);
        assert_eq!(tris.len(), count * 72);
        assert!(tris.iter().all(|t| t.plane == 0 && t.area() > 0.0));
        // Figures are person-sized: 1.6–1.85 m tall, 0.42–0.48 m wide.
        let top = tris
            .iter()
            .flat_map(|t| t.v.iter().map(|v| v.z))
            .fold(f32::NEG_INFINITY, f32::max);
        assert!(top <= 3.5 + 1.85 + 1e-3);
    }
    // Boxes are closed and wound outwards: the signed volume of one person is positive.
    let tris = crowd.triangles_at(&world, 3.0);
    let vol: f32 = tris[..72]
        .iter()
        .map(|t| t.v[0].coords.dot(&t.v[1].coords.cross(&t.v[2].coords)) / 6.0)
        .sum();
    assert!(vol > 0.02 && vol < 0.2, "{vol}");
    // A camera standing where someone walks does not end up inside them.
    let f = crowd.figures_at(&world, 3.0)[0];
    let camera = f.position.cast::<f64>() + nalgebra::Vector3::new(0.0, 0.0, 1.5);
    let clear = crowd.triangles_clear_of(&world, 3.0, &camera, 0.3);
    assert_eq!(clear.len(), (count - 1) * 72);
    // No walk graph, no people (and no panic).
    let mut empty = World::default();
    assert!(Crowd::new(&mut empty, 5, 1).is_empty());
    Ok(())
}

fn distance_to_edges(world: &World, p: &Point3<f32>) -> f32 {
    world
        .walk
        .edges
        .iter()
        .map(|&[a, b]| {
            let (pa, pb) = (world.walk.nodes[a].p, world.walk.nodes[b].p);
            let ab = pb - pa;
            let u = ((p - pa).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            (p - (pa + ab * u)).norm()
        })
        .fold(f32::INFINITY, f32::min)
}
