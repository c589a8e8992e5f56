//! Tests of the default building.

use super::*;
use crate::world::{Pattern, PlaceKind, Triangle};
use nalgebra::Point3;
use std::collections::{HashMap, HashSet};

type TestResult = Result<(), String>;

fn ensure(ok: bool, msg: impl FnOnce() -> String) -> TestResult {
    if ok { Ok(()) } else { Err(msg()) }
}

/// Triangles of the building's shell: walls and floors (plane-id'd, not ceilings, which lose
/// tiles in a disaster).
fn shell(world: &World) -> Vec<&Triangle> {
    world
        .triangles
        .iter()
        .filter(|t| t.plane != 0 && t.normal().z > -0.5)
        .collect()
}

#[test]
fn same_seed_same_world_other_seed_other_decoration() -> TestResult {
    let a = default_world(7, Variant::Normal);
    let b = default_world(7, Variant::Normal);
    ensure(a == b, || "same seed gave different worlds".into())?;
    let c = default_world(8, Variant::Normal);
    ensure(a.materials != c.materials, || {
        "other seed, same materials".into()
    })?;
    ensure(a.triangles != c.triangles, || {
        "other seed, same triangles".into()
    })?;
    ensure(a.name == "default building (seed 7)", || a.name.clone())
}

#[test]
fn layout_is_identical_across_variants() -> TestResult {
    let normal = default_world(5, Variant::Normal);
    for v in Variant::ALL {
        let w = default_world(5, v);
        let structural = matches!(
            v,
            Variant::FurnitureMoved | Variant::PostersChanged | Variant::Disaster
        );
        if !structural {
            ensure(w == normal, || {
                format!("{v:?} should give the normal geometry")
            })?;
            continue;
        }
        ensure(w != normal, || format!("{v:?} changed nothing"))?;
        ensure(w.planes == normal.planes, || {
            format!("{v:?}: planes differ")
        })?;
        ensure(w.regions == normal.regions, || {
            format!("{v:?}: regions differ")
        })?;
        ensure(w.walk == normal.walk, || {
            format!("{v:?}: walk graph differs")
        })?;
        ensure(w.lights == normal.lights, || {
            format!("{v:?}: lights differ")
        })?;
        ensure(w.materials.len() == normal.materials.len(), || {
            format!("{v:?}: material count differs")
        })?;
        let (a, b) = (shell(&w), shell(&normal));
        ensure(a.len() == b.len(), || {
            format!("{v:?}: {} vs {} shell triangles", a.len(), b.len())
        })?;
        for (x, y) in a.iter().zip(&b) {
            ensure(x.v == y.v && x.plane == y.plane && x.uv == y.uv, || {
                format!("{v:?}: shell differs: {x:?} vs {y:?}")
            })?;
        }
    }
    Ok(())
}

#[test]
fn posters_changed_changes_content_only() -> TestResult {
    let a = default_world(5, Variant::Normal);
    let b = default_world(5, Variant::PostersChanged);
    ensure(a.triangles == b.triangles, || {
        "posters changed moved geometry".into()
    })?;
    let changed = a
        .materials
        .iter()
        .zip(&b.materials)
        .filter(|(x, y)| x != y)
        .all(|(x, _)| {
            matches!(
                x.pattern,
                Pattern::Poster | Pattern::NoticeBoard | Pattern::Sign
            )
        });
    ensure(changed, || "posters changed altered other materials".into())?;
    ensure(a.materials != b.materials, || {
        "posters changed changed no poster".into()
    })
}

#[test]
fn counts_are_plausible() -> TestResult {
    let w = default_world(1, Variant::Normal);
    let plan = plan::build(&DefaultWorldConfig::default(), 1);
    let mut storeys = HashSet::new();
    for r in &w.regions {
        storeys.insert((r.place.building, r.place.storey));
    }
    ensure(storeys.len() == 6, || format!("storeys {storeys:?}"))?;
    for shape in [
        plan::Shape::Straight,
        plan::Shape::L,
        plan::Shape::C,
        plan::Shape::Bridge,
    ] {
        ensure(plan.corridors.iter().any(|c| c.shape == shape), || {
            format!("no {shape:?} corridor")
        })?;
    }
    let kinds: HashSet<_> = w
        .regions
        .iter()
        .map(|r| format!("{:?}", r.place.kind))
        .collect();
    ensure(kinds.len() == 5, || format!("kinds {kinds:?}"))?;
    let bridge = w
        .regions
        .iter()
        .filter(|r| r.place.kind == PlaceKind::Bridge);
    ensure(
        bridge.clone().count() >= 2 && bridge.clone().all(|r| r.place.storey == 1),
        || "bridge".into(),
    )?;
    let count = |p: fn(&Pattern) -> bool| -> usize {
        let ids: HashSet<usize> = w
            .materials
            .iter()
            .enumerate()
            .filter(|(_, m)| p(&m.pattern))
            .map(|(i, _)| i)
            .collect();
        w.triangles
            .iter()
            .filter(|t| ids.contains(&usize::from(t.material)))
            .count()
            / 2
    };
    let posters = count(|p| matches!(p, Pattern::Poster));
    let boards = count(|p| matches!(p, Pattern::NoticeBoard));
    let signs = count(|p| matches!(p, Pattern::Sign));
    let windows = count(|p| matches!(p, Pattern::Window));
    let vents = count(|p| matches!(p, Pattern::Vent));
    let panels = count(|p| matches!(p, Pattern::LightPanel));
    println!(
        "posters {posters}, notice boards {boards}, signs {signs}, windows {windows}, vents {vents}, light panels {panels}"
    );
    ensure(
        posters >= 60 && boards >= 10 && signs >= 60 && windows >= 80 && vents >= 40,
        || "too few wall or ceiling items".into(),
    )?;
    ensure(w.lights.len() >= 200 && panels >= 200, || {
        format!("{} lights", w.lights.len())
    })?;
    for l in &w.lights {
        let fixture = l.fixture.and_then(|m| w.materials.get(usize::from(m)));
        ensure(
            fixture.is_some_and(|m| m.emissive > 0.0 && m.pattern == Pattern::LightPanel),
            || format!("light {l:?}"),
        )?;
        ensure(w.place_at(&l.position).is_some(), || {
            format!("light outside free space: {l:?}")
        })?;
    }
    // Every light has its own fixture material.
    let fixtures: HashSet<_> = w.lights.iter().map(|l| l.fixture).collect();
    ensure(fixtures.len() == w.lights.len(), || {
        "lights share fixtures".into()
    })?;
    let n = w.triangles.len();
    ensure((15_000..=90_000).contains(&n), || format!("{n} triangles"))
}

#[test]
fn labels_are_sane() -> TestResult {
    let w = default_world(2, Variant::Normal);
    let mut corridor_home: HashMap<u16, HashSet<(u8, u8)>> = HashMap::new();
    for r in &w.regions {
        let p = &r.place;
        ensure(
            r.min[0] < r.max[0] && r.min[1] < r.max[1] && r.floor_z < r.ceiling_z,
            || format!("{r:?}"),
        )?;
        ensure(p.building < 2 && p.storey < 3, || format!("{p:?}"))?;
        let ok = match p.kind {
            PlaceKind::Corridor | PlaceKind::Bridge => p.corridor.is_some() && p.axis.is_some(),
            PlaceKind::Room => p.corridor.is_some() && p.axis.is_none(),
            PlaceKind::Stairwell | PlaceKind::Lobby => p.corridor.is_none() && p.axis.is_none(),
        };
        ensure(ok, || format!("{p:?}"))?;
        if let (Some(c), PlaceKind::Corridor) = (p.corridor, p.kind) {
            corridor_home
                .entry(c)
                .or_default()
                .insert((p.building, p.storey));
        }
    }
    ensure(corridor_home.values().all(|s| s.len() == 1), || {
        format!("corridor ids reused: {corridor_home:?}")
    })?;
    // Rooms name a corridor of their own building and storey.
    for r in w.regions.iter().filter(|r| r.place.kind == PlaceKind::Room) {
        let home = r.place.corridor.and_then(|c| corridor_home.get(&c));
        ensure(
            home.is_some_and(|h| h.contains(&(r.place.building, r.place.storey))),
            || format!("{:?}", r.place),
        )?;
    }
    // Regions of a storey do not overlap.
    for (i, a) in w.regions.iter().enumerate() {
        for b in &w.regions[i + 1..] {
            let overlap = a.min[0] < b.max[0]
                && b.min[0] < a.max[0]
                && a.min[1] < b.max[1]
                && b.min[1] < a.max[1];
            let z = a.floor_z < b.ceiling_z && b.floor_z < a.ceiling_z;
            ensure(!(overlap && z), || format!("regions overlap: {a:?} {b:?}"))?;
        }
    }
    Ok(())
}

#[test]
fn building0_storeys_1_and_2_share_a_corridor() -> TestResult {
    // Everything inside the corridor (its walls' faces, posters, signs, ceiling, fixtures,
    // furniture), away from the east end where the bridge leaves storey 1, is the same on both
    // storeys, one storey apart.
    let w = default_world(12, Variant::Normal);
    let inside = |t: &Triangle, z0: f32| {
        t.v.iter().all(|v| {
            v.x > 0.0
                && v.x < 38.0
                && v.y > 7.79
                && v.y < 10.21
                && v.z > z0 - 0.01
                && v.z < z0 + 2.95
        })
    };
    let key = |t: &Triangle, z0: f32| {
        let m = w.materials.get(usize::from(t.material)).map(|m| {
            (
                m.name.clone(),
                format!("{:?}", m.pattern),
                m.seed,
                m.color.map(f32::to_bits),
            )
        });
        let v = t.v.map(|v| {
            [
                (v.x * 1000.0).round() as i64,
                (v.y * 1000.0).round() as i64,
                ((v.z - z0) * 1000.0).round() as i64,
            ]
        });
        (v, m)
    };
    let collect = |z0: f32| {
        let mut k: Vec<_> = w
            .triangles
            .iter()
            .filter(|t| inside(t, z0))
            .map(|t| key(t, z0))
            .collect();
        k.sort_by(|a, b| format!("{a:?}").cmp(&format!("{b:?}")));
        k
    };
    let (s1, s2) = (collect(3.5), collect(7.0));
    ensure(s1.len() > 400, || {
        format!("{} triangles in the corridor", s1.len())
    })?;
    ensure(s1 == s2, || {
        format!(
            "the corridors differ ({} vs {} triangles)",
            s1.len(),
            s2.len()
        )
    })?;
    // The rooms off them do not.
    let room = |z0: f32| {
        w.triangles
            .iter()
            .filter(|t| {
                t.v.iter()
                    .all(|v| v.y < 7.6 && v.z > z0 - 0.01 && v.z < z0 + 2.95)
            })
            .map(|t| key(t, z0))
            .collect::<Vec<_>>()
    };
    ensure(room(3.5) != room(7.0), || {
        "the rooms are the same too".into()
    })
}

/// Distance from `p` to triangle `t` (closest point by Ericson's method).
fn point_triangle_distance(p: &Point3<f32>, t: &Triangle) -> f32 {
    let [a, b, c] = t.v;
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
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (p - (a + ab * v + ac * w)).norm()
}

#[test]
fn walk_graph_is_connected_labelled_and_clear_of_walls() -> TestResult {
    // A few seeds: room sizes, doors and open doors change with the seed.
    for seed in [3, 17, 1234] {
        check_walk(&default_world(seed, Variant::Normal))
            .map_err(|e| format!("seed {seed}: {e}"))?;
    }
    Ok(())
}

fn check_walk(w: &World) -> TestResult {
    let g = &w.walk;
    ensure(g.nodes.len() > 300, || format!("{} nodes", g.nodes.len()))?;
    // Connected.
    let adj = g.adjacency();
    let mut seen = vec![false; g.nodes.len()];
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        if std::mem::replace(&mut seen[i], true) {
            continue;
        }
        stack.extend(adj[i].iter().copied().filter(|&j| !seen[j]));
    }
    let unreached: Vec<_> = seen
        .iter()
        .zip(&g.nodes)
        .filter(|(s, _)| !**s)
        .map(|(_, n)| n.p)
        .collect();
    ensure(unreached.is_empty(), || {
        format!(
            "{} nodes unreachable: {:?}",
            unreached.len(),
            &unreached[..unreached.len().min(8)]
        )
    })?;
    // Reaches every storey of both buildings and the bridge.
    let places: HashSet<_> = g
        .nodes
        .iter()
        .filter_map(|n| w.regions.get(n.region))
        .map(|r| (r.place.building, r.place.storey, r.place.kind))
        .collect();
    for b in 0..2 {
        for s in 0..3 {
            ensure(places.contains(&(b, s, PlaceKind::Stairwell)), || {
                format!("no stair nodes in {b}/{s}")
            })?;
            ensure(places.contains(&(b, s, PlaceKind::Room)), || {
                format!("no room nodes in {b}/{s}")
            })?;
        }
    }
    ensure(places.iter().any(|p| p.2 == PlaceKind::Bridge), || {
        "no bridge nodes".into()
    })?;
    // Every node lies in its region, clear of walls.
    let walls: Vec<&Triangle> = w
        .triangles
        .iter()
        .filter(|t| t.plane != 0 && t.normal().z.abs() < 0.5)
        .collect();
    for (i, n) in g.nodes.iter().enumerate() {
        let r = w
            .regions
            .get(n.region)
            .ok_or_else(|| format!("node {i}: no region"))?;
        ensure(r.contains(&n.p), || {
            format!("node {i} at {:?} not in its region {r:?}", n.p)
        })?;
        let lo = n.p.z + 0.05;
        let hi = n.p.z + 1.8;
        for t in &walls {
            let (zmin, zmax) =
                t.v.iter()
                    .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(v.z), b.max(v.z)));
            if zmax < lo || zmin > hi {
                continue;
            }
            // Distance at the node's height band: use the point at mid band.
            let probe = Point3::new(n.p.x, n.p.y, (lo.max(zmin) + hi.min(zmax)) / 2.0);
            let d = point_triangle_distance(&probe, t);
            ensure(d >= 0.3, || {
                format!("node {i} at {:?} is {d:.2} m from a wall {:?}", n.p, t.v)
            })?;
        }
    }
    // Edges are short enough to be walked as straight lines.
    for &[a, b] in &g.edges {
        let d = (g.nodes[a].p - g.nodes[b].p).norm();
        ensure(d > 0.05 && d <= walk::MAX_EDGE + 1e-3, || {
            format!("edge {a}-{b} is {d:.2} m")
        })?;
    }
    Ok(())
}

#[test]
fn furniture_keeps_off_the_walk_graph() -> TestResult {
    for variant in [Variant::Normal, Variant::FurnitureMoved, Variant::Disaster] {
        let cfg = DefaultWorldConfig::default();
        let plan = plan::build(&cfg, 4);
        let mut world = World::default();
        let mats = materials::Materials::create(&mut world, 4);
        world.regions = walk::regions(&plan);
        world.walk = walk::graph(&plan, &world.regions);
        let seed = rng::hash(&[
            4,
            rng::text("furniture"),
            u64::from(variant == Variant::FurnitureMoved),
        ]);
        let mut total = 0;
        for level in &plan.levels {
            let runs = grid::Grid::new(level).wall_runs(level);
            let cx = decor::Context {
                seed: 4,
                posters_changed: false,
                disaster: false,
                level,
                runs: &runs,
                mats: &mats,
                door_height: cfg.door_height,
            };
            let decor = decor::decorate(&mut world, &cx);
            let segments = walk::floor_segments(&world.walk, level);
            let nodes: Vec<Point2<f32>> = world
                .walk
                .nodes
                .iter()
                .filter(|n| (n.p.z - level.floor_z).abs() < 1e-3)
                .map(|n| n.p.xy())
                .collect();
            let site = furniture::Site {
                level,
                runs: &runs,
                decor: &decor,
                segments: &segments,
                nodes: &nodes,
            };
            let placed = furniture::furnish(&site, &mats, seed, variant == Variant::Disaster);
            total += placed.len();
            for p in &placed {
                for s in &segments {
                    let hit = furniture::segment_hits(
                        s,
                        &p.foot.grow(if p.fallen {
                            0.0
                        } else {
                            furniture::CLEARANCE - 0.01
                        }),
                    );
                    ensure(!hit || p.fallen, || {
                        format!("{variant:?}: furniture at {:?} blocks edge {s:?}", p.foot)
                    })?;
                }
                for n in &nodes {
                    let r = p.foot.grow(0.3);
                    ensure(
                        !(n.x > r.u0 && n.x < r.u1 && n.y > r.v0 && n.y < r.v1),
                        || format!("{variant:?}: furniture on node {n:?}"),
                    )?;
                }
            }
        }
        println!("{variant:?}: {total} pieces of furniture");
        ensure(total > 150, || format!("{variant:?}: only {total} pieces"))?;
    }
    Ok(())
}

#[test]
fn triangles_are_sound_and_on_their_planes() -> TestResult {
    for variant in [Variant::Normal, Variant::Disaster] {
        let w = default_world(9, variant);
        for t in &w.triangles {
            let n = t.normal();
            ensure(n.norm() > 0.5, || format!("degenerate triangle {t:?}"))?;
            ensure(usize::from(t.material) < w.materials.len(), || {
                format!("material {}", t.material)
            })?;
            ensure(t.uv.iter().flatten().all(|x| x.is_finite()), || {
                format!("uv {t:?}")
            })?;
            if t.plane == 0 {
                continue;
            }
            let plane = w
                .planes
                .get(t.plane as usize - 1)
                .ok_or_else(|| format!("plane {}", t.plane))?;
            ensure((n - plane.normal).norm() < 1e-3, || {
                format!("triangle faces {n:?}, its plane {:?}", plane.normal)
            })?;
            for v in &t.v {
                let d = plane.normal.dot(&v.coords) - plane.offset;
                ensure(d.abs() < 1e-3, || {
                    format!("vertex {v:?} is {d} off its plane")
                })?;
            }
        }
        ensure(w.planes.len() > 100, || {
            format!("{} planes", w.planes.len())
        })?;
    }
    Ok(())
}

#[test]
fn faces_look_into_free_space() -> TestResult {
    // A point just in front of every wall and floor face lies in free space (a region); just
    // behind, for walls, it does not lie in the same region.
    let w = default_world(6, Variant::Normal);
    for t in w.triangles.iter().filter(|t| t.plane != 0) {
        let c = Point3::from((t.v[0].coords + t.v[1].coords + t.v[2].coords) / 3.0);
        let front = c + t.normal() * 0.05;
        ensure(w.place_at(&front).is_some(), || {
            format!(
                "face at {c:?} looking {:?} does not look into free space",
                t.normal()
            )
        })?;
    }
    Ok(())
}

#[test]
fn settings_are_clamped_and_honoured() -> TestResult {
    let cfg = DefaultWorldConfig {
        storey_height: f32::NAN,
        ceiling_height: 10.0,
        door_height: 0.5,
        open_doors: 2.0,
        furniture: false,
    };
    let w = default_world_with(&cfg, 1, Variant::Normal);
    let z = w.regions.iter().map(|r| r.floor_z).fold(0.0f32, f32::max);
    ensure((z - 7.0).abs() < 1e-4, || format!("top floor at {z}"))?;
    let plain = default_world_with(
        &DefaultWorldConfig {
            furniture: false,
            ..DefaultWorldConfig::default()
        },
        1,
        Variant::Normal,
    );
    let full = default_world(1, Variant::Normal);
    ensure(plain.triangles.len() < full.triangles.len(), || {
        "furniture: false kept furniture".into()
    })
}

/// The default world has every part a study relies on, and the disaster variant changes its
/// geometry (statistics printed for a person).
#[test]
fn build_time_and_statistics() -> TestResult {
    let t = std::time::Instant::now();
    let w = default_world(0, Variant::Normal);
    let ms = t.elapsed().as_secs_f64() * 1000.0;
    let t = std::time::Instant::now();
    let d = default_world(0, Variant::Disaster);
    let ms_d = t.elapsed().as_secs_f64() * 1000.0;
    let (lo, hi) = w.bounds().unwrap_or((Point3::origin(), Point3::origin()));
    println!(
        "default world: {} triangles, {} materials, {} planes, {} lights, {} regions, {} walk nodes, {} edges; \
         bounds {:?}–{:?}; built in {ms:.1} ms (disaster: {} triangles, {ms_d:.1} ms; debug builds are slower)",
        w.triangles.len(),
        w.materials.len(),
        w.planes.len(),
        w.lights.len(),
        w.regions.len(),
        w.walk.nodes.len(),
        w.walk.edges.len(),
        lo,
        hi,
        d.triangles.len()
    );
    ensure(
        !w.triangles.is_empty()
            && !w.materials.is_empty()
            && !w.lights.is_empty()
            && !w.regions.is_empty()
            && w.walk.nodes.len() > 1
            && !w.walk.edges.is_empty(),
        || "the default world lacks triangles, materials, lights, regions or a walk graph".into(),
    )?;
    // Three storeys of 3.5 m.
    ensure(hi.z - lo.z >= 7.0, || {
        format!("bounds {lo:?}–{hi:?} span under three storeys")
    })?;
    ensure(d.triangles.len() != w.triangles.len(), || {
        "the disaster variant left the geometry as it was".into()
    })
}

/// Debug aid: a top-down plan of each storey (triangles coloured by material, walls dark,
/// the walk graph in red) written to the temporary folder.
#[test]
#[ignore = "a picture for a person to look at, checks nothing; run with --ignored"]
fn floor_plans_to_png() -> TestResult {
    let w = default_world(0, Variant::Normal);
    let scale = 20.0;
    let (lo, hi) = w.bounds().ok_or("empty world")?;
    let (width, height) = (
        ((hi.x - lo.x) * scale) as u32 + 20,
        ((hi.y - lo.y) * scale) as u32 + 20,
    );
    let px = |x: f32, y: f32| ((x - lo.x) * scale + 10.0, (hi.y - y) * scale + 10.0);
    for storey in 0..3 {
        let z0 = storey as f32 * 3.5;
        let mut img = image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
        let mut tris: Vec<&Triangle> = w
            .triangles
            .iter()
            .filter(|t| t.v.iter().all(|v| v.z >= z0 - 0.25 && v.z <= z0 + 3.45))
            .collect();
        // Ceilings would hide everything: leave out faces looking down.
        tris.retain(|t| t.normal().z > -0.3);
        tris.sort_by(|a, b| {
            let za = a.v.iter().map(|v| v.z).fold(f32::MIN, f32::max);
            let zb = b.v.iter().map(|v| v.z).fold(f32::MIN, f32::max);
            za.total_cmp(&zb)
        });
        let color = |t: &Triangle, k: f32| {
            let c = w
                .materials
                .get(usize::from(t.material))
                .map_or([1.0, 0.0, 1.0], |m| m.color);
            image::Rgb(c.map(|x| (x * k * 255.0).clamp(0.0, 255.0) as u8))
        };
        for t in &tris {
            let p: Vec<(f32, f32)> = t.v.iter().map(|v| px(v.x, v.y)).collect();
            if t.normal().z.abs() > 0.3 {
                fill(&mut img, &p, color(t, 1.0));
            } else {
                let c = if t.plane != 0 {
                    image::Rgb([30, 30, 30])
                } else {
                    color(t, 0.6)
                };
                for k in 0..3 {
                    line(&mut img, p[k], p[(k + 1) % 3], c);
                }
            }
        }
        let on = |i: usize| {
            w.walk
                .nodes
                .get(i)
                .filter(|n| n.p.z >= z0 - 1e-3 && n.p.z < z0 + 3.5 - 1e-3)
        };
        for &[a, b] in &w.walk.edges {
            if let (Some(p), Some(q)) = (on(a), on(b)) {
                line(
                    &mut img,
                    px(p.p.x, p.p.y),
                    px(q.p.x, q.p.y),
                    image::Rgb([220, 0, 0]),
                );
            }
        }
        for n in w
            .walk
            .nodes
            .iter()
            .filter(|n| n.p.z >= z0 - 1e-3 && n.p.z < z0 + 3.5 - 1e-3)
        {
            let (x, y) = px(n.p.x, n.p.y);
            fill(
                &mut img,
                &[(x - 2.0, y - 2.0), (x + 2.0, y - 2.0), (x + 2.0, y + 2.0)],
                image::Rgb([200, 0, 0]),
            );
            fill(
                &mut img,
                &[(x - 2.0, y - 2.0), (x + 2.0, y + 2.0), (x - 2.0, y + 2.0)],
                image::Rgb([200, 0, 0]),
            );
        }
        let path = std::env::temp_dir().join(format!("indoorloc_floorplan_storey{storey}.png"));
        img.save(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        println!("floor plan written to {}", path.display());
    }
    Ok(())
}

/// Debug aid: a side view (looking along −x) of building 0's stair shaft, walls left out.
#[test]
#[ignore = "a picture for a person to look at, checks nothing; run with --ignored"]
fn stair_section_to_png() -> TestResult {
    let w = default_world(0, Variant::Normal);
    let (x0, x1, y0, y1) = (20.0, 22.8, 10.2, 16.6);
    let scale = 60.0;
    let (width, height) = (((y1 - y0) * scale) as u32 + 20, (11.0 * scale) as u32 + 20);
    let px = |y: f32, z: f32| ((y - y0) * scale + 10.0, (10.5 - z) * scale + 10.0);
    let mut img = image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    let mut tris: Vec<&Triangle> = w
        .triangles
        .iter()
        .filter(|t| {
            t.v.iter().all(|v| {
                v.x >= x0 - 0.01 && v.x <= x1 + 0.01 && v.y >= y0 - 0.01 && v.y <= y1 + 0.01
            })
        })
        .filter(|t| t.normal().x > -0.5 && (t.plane == 0 || t.normal().z.abs() > 0.5))
        .collect();
    tris.sort_by(|a, b| {
        let xa = a.v.iter().map(|v| v.x).fold(f32::MIN, f32::max);
        let xb = b.v.iter().map(|v| v.x).fold(f32::MIN, f32::max);
        xa.total_cmp(&xb)
    });
    for t in &tris {
        let c = w
            .materials
            .get(usize::from(t.material))
            .map_or([1.0, 0.0, 1.0], |m| m.color);
        // Darker when seen edge-on or from below, so steps stand out.
        let k = 0.5 + 0.5 * t.normal().x.abs().max(t.normal().z.max(0.0));
        let rgb = image::Rgb(c.map(|x| (x * k * 255.0).clamp(0.0, 255.0) as u8));
        let p: Vec<(f32, f32)> = t.v.iter().map(|v| px(v.y, v.z)).collect();
        fill(&mut img, &p, rgb);
        for k in 0..3 {
            line(&mut img, p[k], p[(k + 1) % 3], image::Rgb([40, 40, 40]));
        }
    }
    for &[a, b] in &w.walk.edges {
        let (p, q) = (&w.walk.nodes[a].p, &w.walk.nodes[b].p);
        let inside = |p: &Point3<f32>| p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;
        if inside(p) && inside(q) {
            line(
                &mut img,
                px(p.y, p.z),
                px(q.y, q.z),
                image::Rgb([220, 0, 0]),
            );
        }
    }
    let path = std::env::temp_dir().join("indoorloc_stair_section.png");
    img.save(&path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    println!("stair section written to {}", path.display());
    Ok(())
}

fn fill(img: &mut image::RgbImage, p: &[(f32, f32)], c: image::Rgb<u8>) {
    let (x0, x1) = (
        p.iter().map(|q| q.0).fold(f32::MAX, f32::min),
        p.iter().map(|q| q.0).fold(f32::MIN, f32::max),
    );
    let (y0, y1) = (
        p.iter().map(|q| q.1).fold(f32::MAX, f32::min),
        p.iter().map(|q| q.1).fold(f32::MIN, f32::max),
    );
    let edge = |a: (f32, f32), b: (f32, f32), x: f32, y: f32| {
        (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0)
    };
    for y in y0.floor().max(0.0) as u32..=(y1.ceil() as u32).min(img.height().saturating_sub(1)) {
        for x in x0.floor().max(0.0) as u32..=(x1.ceil() as u32).min(img.width().saturating_sub(1))
        {
            let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
            let e = [
                edge(p[0], p[1], fx, fy),
                edge(p[1], p[2], fx, fy),
                edge(p[2], p[0], fx, fy),
            ];
            if e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0) {
                img.put_pixel(x, y, c);
            }
        }
    }
}

fn line(img: &mut image::RgbImage, a: (f32, f32), b: (f32, f32), c: image::Rgb<u8>) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
    for i in 0..=n {
        let t = i as f32 / n as f32;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        if x >= 0.0 && y >= 0.0 && (x as u32) < img.width() && (y as u32) < img.height() {
            img.put_pixel(x as u32, y as u32, c);
        }
    }
}
