//! Renderer speed on one core: frames per second for every mode at 160x120 and 320x240, inside
//! a synthetic office block built here (three storeys of a 60 m corridor with rooms, furniture,
//! tiled ceilings and lamps; about 30k triangles).
//!
//! ```text
//! cargo run --release -p synth --example render_speed [-- FRAMES [PNG_DIR]]
//! ```
//! With `PNG_DIR`, writes one image per mode (and a distorted-lens and a shadowed one) there.
//! `RENDER_SPEED_WORLD=default` measures the procedural default building instead, along a
//! natural walk; `RENDER_SPEED_WORLD=bench` measures what `indoorloc bench render` renders (the
//! default dataset's world, forward rig, walk and camera, seed 1);
//! `RENDER_SPEED_ONLY=textured@160` (mode@width) measures one case only. Times are the
//! thread's CPU time where Linux reports it (a shared machine inflates wall time).

use geom::{Camera, Distortion, Pose};
use nalgebra::Point3;
use std::time::Instant;
use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};
use synth::world::{Light, Place, PlaceKind, Region};
use synth::{Material, Pattern, Triangle, World};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(2000);
    let png_dir = args.next();
    let t0 = Instant::now();
    // RENDER_SPEED_WORLD=default measures the procedural default building along a natural walk
    // instead of the office block built here.
    let which = std::env::var("RENDER_SPEED_WORLD").unwrap_or_default();
    let default_world = which == "default";
    // `indoorloc bench render`'s set-up (crates/lab/src/bench/mod.rs, `bench_render`).
    let bench = (which == "bench").then(synth::dataset::SynthConfig::default);
    let world = if let Some(cfg) = &bench {
        synth::dataset::build_world(cfg)?.0
    } else if default_world {
        synth::procedural::default_world(1, synth::Variant::Normal)
    } else {
        office()
    };
    let scene = RenderScene::new(&world)?;
    println!(
        "world: {} triangles, {} lights, {} materials; scene prepared in {:.0} ms",
        scene.triangle_count(),
        scene.light_count(),
        world.materials.len(),
        t0.elapsed().as_secs_f64() * 1e3
    );
    let poses: Vec<Pose> = if let Some(cfg) = &bench {
        let rig = synth::dataset::rig_of(cfg.camera);
        let walk_cfg = synth::trajectory::WalkConfig::for_rig(rig);
        synth::trajectory::walk(&world, &walk_cfg, frames, cfg.seed)?
            .into_iter()
            .map(|f| f.pose)
            .collect()
    } else if default_world {
        let cfg = synth::trajectory::WalkConfig::default();
        synth::trajectory::walk(&world, &cfg, frames, 1)?
            .into_iter()
            .map(|f| f.pose)
            .collect()
    } else {
        walk(frames)
    };
    for (w, h) in [(160u32, 120u32), (320, 240)] {
        let camera = match &bench {
            Some(cfg) => {
                synth::trajectory::camera_for(&synth::dataset::rig_of(cfg.camera), w, h, cfg.seed)?
            }
            None => Camera::from_hfov(w, h, 60f64.to_radians())?,
        };
        for mode in RenderMode::ALL {
            // RENDER_SPEED_ONLY=textured@160 (say) measures one case, for profiling.
            if let Ok(only) = std::env::var("RENDER_SPEED_ONLY")
                && only != format!("{}@{w}", mode.name())
            {
                continue;
            }
            let opts = RenderOptions {
                mode,
                ..RenderOptions::default()
            };
            let mut r = Renderer::new();
            r.render(&scene, &camera, &poses[0], &opts, &[])?;
            let mut sum = [0u64; 7];
            let start = Instant::now();
            let cpu0 = thread_cpu_ns();
            for (i, pose) in poses.iter().enumerate() {
                let o = RenderOptions {
                    seed: i as u64,
                    ..opts.clone()
                };
                r.render(&scene, &camera, pose, &o, &[])?;
                let s = r.stats();
                for (a, b) in sum.iter_mut().zip([
                    s.cells_in_view as u64,
                    s.cells_occluded as u64,
                    s.triangles_tested as u64,
                    s.triangles_drawn as u64,
                    s.raster_ns,
                    s.shade_ns,
                    s.lit_exactly as u64,
                ]) {
                    *a += b;
                }
            }
            let wall = start.elapsed().as_secs_f64();
            let cpu = thread_cpu_ns()
                .zip(cpu0)
                .map(|(b, a)| (b - a) as f64 * 1e-9);
            let n = poses.len() as f64;
            let secs = cpu.unwrap_or(wall);
            let per = |k: usize| sum[k] as f64 / n;
            println!(
                "{w}x{h} {:<9} {:>6.0} frames/s  {:>6.3} ms/frame (CPU time; wall {:.3} ms)  \
                 raster {:.3} ms, shade {:.3} ms; cells {:.0} in view, {:.0} hidden; \
                 triangles {:.0} set up, {:.0} drawn; pixels lit exactly {:.0}",
                mode.name(),
                n / secs,
                secs * 1e3 / n,
                wall * 1e3 / n,
                per(4) * 1e-6,
                per(5) * 1e-6,
                per(0),
                per(1),
                per(2),
                per(3),
                per(6),
            );
        }
    }
    if std::env::var("RENDER_SPEED_ONLY").is_ok() {
        return Ok(());
    }
    // Variants that cost more: a distorted lens, shadow rays.
    let lens = Camera::new(
        160,
        120,
        140.0,
        140.0,
        79.5,
        59.5,
        Distortion::from_array([-0.2, 0.05, 0.0, 0.0, 0.0]),
    )?;
    let plain = Camera::from_hfov(160, 120, 60f64.to_radians())?;
    for (label, camera, shadows) in [("distorted", lens, false), ("shadows", plain, true)] {
        let opts = RenderOptions {
            shadows,
            ..RenderOptions::default()
        };
        let mut r = Renderer::new();
        let n = if shadows { frames.min(200) } else { frames };
        let start = Instant::now();
        let cpu0 = thread_cpu_ns();
        for pose in &poses[..n] {
            r.render(&scene, &camera, pose, &opts, &[])?;
        }
        let wall = start.elapsed().as_secs_f64();
        let secs = thread_cpu_ns()
            .zip(cpu0)
            .map_or(wall, |(b, a)| (b - a) as f64 * 1e-9);
        println!(
            "160x120 textured, {label:<9} {:>7.0} frames/s  {:>6.3} ms/frame",
            n as f64 / secs,
            secs * 1e3 / n as f64
        );
    }
    if let Some(dir) = png_dir {
        std::fs::create_dir_all(&dir)?;
        let camera = Camera::from_hfov(320, 240, 60f64.to_radians())?;
        let pose = &poses[poses.len() / 7];
        let mut r = Renderer::new();
        for mode in RenderMode::ALL {
            let opts = RenderOptions {
                mode,
                ..RenderOptions::default()
            };
            let out = r.render(&scene, &camera, pose, &opts, &[])?;
            out.rgb.save(format!("{dir}/speed_{}.png", mode.name()))?;
        }
        let lens = lens.resized(320, 240);
        let out = r.render(&scene, &lens, pose, &RenderOptions::default(), &[])?;
        out.rgb.save(format!("{dir}/speed_distorted.png"))?;
        let opts = RenderOptions {
            shadows: true,
            ..RenderOptions::default()
        };
        let out = r.render(&scene, &camera, pose, &opts, &[])?;
        out.rgb.save(format!("{dir}/speed_shadows.png"))?;
        // Down the corridor: lamps fading into the distance.
        let corridor = geom::Pose3 {
            x: 1.0,
            y: -0.3,
            heading: 0.05,
        }
        .to_pose(geom::Mount::Forward, 1.6);
        for mode in [RenderMode::Textured, RenderMode::Shaded] {
            let opts = RenderOptions {
                mode,
                ..RenderOptions::default()
            };
            let out = r.render(&scene, &camera, &corridor, &opts, &[])?;
            out.rgb
                .save(format!("{dir}/speed_corridor_{}.png", mode.name()))?;
        }
        println!("images written to {dir}");
    }
    Ok(())
}

/// CPU time of this thread, nanoseconds (Linux; `None` elsewhere): the machine may be shared, and
/// wall-clock time would then count other processes' time.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// A walk along the corridors of every storey, turning to look into rooms now and then.
fn walk(frames: usize) -> Vec<Pose> {
    (0..frames)
        .map(|i| {
            let s = i as f64 / frames as f64;
            let storey = (i * 3 / frames.max(1)) as f64;
            let x = 2.0 + (s * 3.0).fract() * 56.0;
            let yaw = 0.9 * (i as f64 * 0.05).sin()
                + if (i / 150) % 2 == 1 {
                    std::f64::consts::PI
                } else {
                    0.0
                };
            let y = 0.4 * (i as f64 * 0.013).sin();
            // A level forward camera (OpenCV axes) with this heading, at head height.
            geom::Pose3 { x, y, heading: yaw }.to_pose(geom::Mount::Forward, storey * STOREY + 1.6)
        })
        .collect()
}

const STOREY: f64 = 3.5;
const LENGTH: f32 = 60.0;
const HALF: f32 = 1.25;
const ROOM_W: f32 = 5.0;
const ROOM_D: f32 = 5.0;
const HEIGHT: f32 = 3.0;

/// Adds a quad `a, b, c, d` (counter-clockwise seen from the front), with uv in metres along
/// `a → b` and `a → d`, anchored at the world origin (so patterns run on across quads).
fn quad(w: &mut World, q: [[f32; 3]; 4], material: u16, plane: u32) {
    add_quad(w, q, material, plane, false);
}

/// A quad whose texture starts at its corner `a` (posters, windows: one repeat covers them).
fn decal(w: &mut World, q: [[f32; 3]; 4], material: u16) {
    add_quad(w, q, material, 0, true);
}

fn add_quad(w: &mut World, q: [[f32; 3]; 4], material: u16, plane: u32, relative: bool) {
    let p = q.map(|v| Point3::new(v[0], v[1], v[2]));
    let eu = (p[1] - p[0]).normalize();
    let ev = (p[3] - p[0]).normalize();
    let o = if relative { p[0] } else { Point3::origin() };
    let uv = |v: &Point3<f32>| [(v - o).dot(&eu), (v - o).dot(&ev)];
    for [i, j, k] in [[0, 1, 2], [0, 2, 3]] {
        w.triangles.push(Triangle {
            v: [p[i], p[j], p[k]],
            uv: [uv(&p[i]), uv(&p[j]), uv(&p[k])],
            material,
            plane,
        });
    }
}

/// An axis-aligned closed box with outward faces.
fn cuboid(w: &mut World, lo: [f32; 3], hi: [f32; 3], material: u16) {
    let [x0, y0, z0] = lo;
    let [x1, y1, z1] = hi;
    let faces = [
        [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]], // bottom (−z)
        [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], // top (+z)
        [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]], // −y
        [[x1, y1, z0], [x0, y1, z0], [x0, y1, z1], [x1, y1, z1]], // +y
        [[x0, y1, z0], [x0, y0, z0], [x0, y0, z1], [x0, y1, z1]], // −x
        [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]], // +x
    ];
    for f in faces {
        quad(w, f, material, 0);
    }
}

/// A horizontal grid of quads facing up (`up`) or down, `cell` metres.
fn slab(
    w: &mut World,
    lo: [f32; 2],
    hi: [f32; 2],
    z: f32,
    cell: f32,
    up: bool,
    surface: (u16, u32),
) {
    let (material, plane) = surface;
    let nx = ((hi[0] - lo[0]) / cell).ceil() as usize;
    let ny = ((hi[1] - lo[1]) / cell).ceil() as usize;
    for i in 0..nx {
        for j in 0..ny {
            let x0 = lo[0] + i as f32 * cell;
            let y0 = lo[1] + j as f32 * cell;
            let x1 = (x0 + cell).min(hi[0]);
            let y1 = (y0 + cell).min(hi[1]);
            if up {
                quad(
                    w,
                    [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]],
                    material,
                    plane,
                );
            } else {
                quad(
                    w,
                    [[x0, y0, z], [x0, y1, z], [x1, y1, z], [x1, y0, z]],
                    material,
                    plane,
                );
            }
        }
    }
}

/// Three storeys of a corridor with rooms on both sides.
fn office() -> World {
    let mut w = World {
        name: "render_speed office".into(),
        ..World::default()
    };
    let mat =
        |w: &mut World, name: &str, color: [f32; 3], pattern: Pattern, seed: u64, emissive: f32| {
            w.add_material(Material {
                name: name.into(),
                color,
                pattern,
                seed,
                emissive,
                unlit: false,
            })
        };
    let wall = mat(&mut w, "wall", [0.85, 0.83, 0.78], Pattern::Plain, 1, 0.0);
    let wall2 = mat(
        &mut w,
        "wall room",
        [0.75, 0.8, 0.85],
        Pattern::Plain,
        2,
        0.0,
    );
    let floor = mat(
        &mut w,
        "floor",
        [0.45, 0.45, 0.43],
        Pattern::Tiles { size: 0.5 },
        3,
        0.0,
    );
    let carpet = mat(&mut w, "carpet", [0.3, 0.33, 0.4], Pattern::Carpet, 4, 0.0);
    let ceiling = mat(
        &mut w,
        "ceiling",
        [0.92, 0.92, 0.9],
        Pattern::Tiles { size: 0.6 },
        5,
        0.0,
    );
    let panel = mat(
        &mut w,
        "panel",
        [0.95, 0.95, 0.92],
        Pattern::LightPanel,
        6,
        1.0,
    );
    let wood = mat(&mut w, "desk", [0.6, 0.45, 0.3], Pattern::Wood, 7, 0.0);
    let fabric = mat(&mut w, "chair", [0.2, 0.25, 0.5], Pattern::Fabric, 8, 0.0);
    let door = mat(&mut w, "door", [0.55, 0.4, 0.28], Pattern::Wood, 9, 0.0);
    let window = mat(&mut w, "window", [0.8, 0.8, 0.8], Pattern::Window, 10, 0.0);
    let posters: Vec<u16> = (0..6)
        .map(|k| {
            mat(
                &mut w,
                "poster",
                [0.9, 0.9 - 0.1 * k as f32, 0.7],
                Pattern::Poster,
                20 + k,
                0.0,
            )
        })
        .collect();
    let board = mat(
        &mut w,
        "board",
        [0.6, 0.45, 0.3],
        Pattern::NoticeBoard,
        30,
        0.0,
    );
    for s in 0..3 {
        let z0 = s as f32 * STOREY as f32;
        let z1 = z0 + HEIGHT;
        let floor_plane = (s * 10 + 1) as u32;
        // Corridor floor and ceiling (fine grids, as generators tile them).
        slab(
            &mut w,
            [0.0, -HALF],
            [LENGTH, HALF],
            z0,
            1.0,
            true,
            (floor, floor_plane),
        );
        slab(
            &mut w,
            [0.0, -HALF],
            [LENGTH, HALF],
            z1,
            0.6,
            false,
            (ceiling, floor_plane + 1),
        );
        // End walls.
        quad(
            &mut w,
            [
                [0.0, -HALF, z0],
                [0.0, HALF, z0],
                [0.0, HALF, z1],
                [0.0, -HALF, z1],
            ],
            wall,
            floor_plane + 2,
        );
        quad(
            &mut w,
            [
                [LENGTH, HALF, z0],
                [LENGTH, -HALF, z0],
                [LENGTH, -HALF, z1],
                [LENGTH, HALF, z1],
            ],
            wall,
            floor_plane + 5,
        );
        let rooms = (LENGTH / ROOM_W) as usize;
        for side in [-1.0f32, 1.0] {
            let wall_plane = floor_plane + if side > 0.0 { 3 } else { 4 };
            for r in 0..rooms {
                let x0 = r as f32 * ROOM_W;
                let x1 = x0 + ROOM_W;
                let door0 = x0 + 1.0;
                let door1 = door0 + 1.0;
                // Corridor wall with a door opening: thick boxes around the opening.
                let (ya, yb) = if side > 0.0 {
                    (HALF, HALF + 0.1)
                } else {
                    (-HALF - 0.1, -HALF)
                };
                cuboid(&mut w, [x0, ya, z0], [door0, yb, z1], wall);
                cuboid(&mut w, [door1, ya, z0], [x1, yb, z1], wall);
                cuboid(&mut w, [door0, ya, z0 + 2.1], [door1, yb, z1], wall);
                // An open door leaf.
                let (d0, d1) = if side > 0.0 {
                    (HALF + 0.1, HALF + 0.95)
                } else {
                    (-HALF - 0.95, -HALF - 0.1)
                };
                cuboid(&mut w, [door0, d0, z0], [door0 + 0.04, d1, z0 + 2.05], door);
                // Poster and notice board on the corridor side.
                let yface = if side > 0.0 {
                    HALF - 0.01
                } else {
                    -HALF + 0.01
                };
                let px = x0 + 2.8;
                let pm = posters[(r + s * 3) % posters.len()];
                // Upright for a viewer in the corridor: u runs to the viewer's right
                // (up × normal).
                if side > 0.0 {
                    decal(
                        &mut w,
                        [
                            [px, yface, z0 + 1.2],
                            [px + 0.6, yface, z0 + 1.2],
                            [px + 0.6, yface, z0 + 2.05],
                            [px, yface, z0 + 2.05],
                        ],
                        pm,
                    );
                } else {
                    decal(
                        &mut w,
                        [
                            [px + 1.2, yface, z0 + 1.1],
                            [px, yface, z0 + 1.1],
                            [px, yface, z0 + 2.0],
                            [px + 1.2, yface, z0 + 2.0],
                        ],
                        board,
                    );
                }
                // The room: floor, ceiling, walls, window, furniture, lamps.
                let (ry0, ry1) = if side > 0.0 {
                    (HALF + 0.1, HALF + 0.1 + ROOM_D)
                } else {
                    (-HALF - 0.1 - ROOM_D, -HALF - 0.1)
                };
                slab(
                    &mut w,
                    [x0, ry0],
                    [x1, ry1],
                    z0,
                    1.0,
                    true,
                    (carpet, floor_plane),
                );
                slab(
                    &mut w,
                    [x0, ry0],
                    [x1, ry1],
                    z1,
                    0.6,
                    false,
                    (ceiling, floor_plane + 1),
                );
                cuboid(&mut w, [x1 - 0.05, ry0, z0], [x1 + 0.05, ry1, z1], wall2);
                let outer = if side > 0.0 { ry1 } else { ry0 };
                let face = if side > 0.0 {
                    [
                        [x0, outer, z0],
                        [x1, outer, z0],
                        [x1, outer, z1],
                        [x0, outer, z1],
                    ]
                } else {
                    [
                        [x1, outer, z0],
                        [x0, outer, z0],
                        [x0, outer, z1],
                        [x1, outer, z1],
                    ]
                };
                quad(&mut w, face, wall2, wall_plane + 2);
                let wy = outer - side * 0.01;
                let win = if side > 0.0 {
                    [
                        [x0 + 1.9, wy, z0 + 0.9],
                        [x0 + 3.1, wy, z0 + 0.9],
                        [x0 + 3.1, wy, z0 + 2.4],
                        [x0 + 1.9, wy, z0 + 2.4],
                    ]
                } else {
                    [
                        [x0 + 3.1, wy, z0 + 0.9],
                        [x0 + 1.9, wy, z0 + 0.9],
                        [x0 + 1.9, wy, z0 + 2.4],
                        [x0 + 3.1, wy, z0 + 2.4],
                    ]
                };
                decal(&mut w, win, window);
                for d in 0..3 {
                    let dx = x0 + 0.6 + d as f32 * 1.4;
                    let dy = (ry0 + ry1) / 2.0 + side * 0.8;
                    // Desk: top and four legs.
                    cuboid(
                        &mut w,
                        [dx, dy - 0.4, z0 + 0.72],
                        [dx + 1.2, dy + 0.4, z0 + 0.75],
                        wood,
                    );
                    for (lx, ly) in [(0.02, -0.38), (1.14, -0.38), (0.02, 0.34), (1.14, 0.34)] {
                        cuboid(
                            &mut w,
                            [dx + lx, dy + ly, z0],
                            [dx + lx + 0.04, dy + ly + 0.04, z0 + 0.72],
                            wood,
                        );
                    }
                    // Chair: seat, back, five legs.
                    let cy = dy - side * 0.7;
                    cuboid(
                        &mut w,
                        [dx + 0.4, cy - 0.22, z0 + 0.45],
                        [dx + 0.84, cy + 0.22, z0 + 0.5],
                        fabric,
                    );
                    cuboid(
                        &mut w,
                        [dx + 0.4, cy - side * 0.22 - 0.02, z0 + 0.5],
                        [dx + 0.84, cy - side * 0.22 + 0.02, z0 + 1.0],
                        fabric,
                    );
                    for k in 0..5 {
                        let a = k as f32 * 1.2566;
                        let (lx, ly) = (dx + 0.62 + 0.2 * a.cos(), cy + 0.2 * a.sin());
                        cuboid(
                            &mut w,
                            [lx - 0.02, ly - 0.02, z0],
                            [lx + 0.02, ly + 0.02, z0 + 0.45],
                            fabric,
                        );
                    }
                }
                for k in 0..2 {
                    let lx = x0 + 1.5 + 2.0 * k as f32;
                    let ly = (ry0 + ry1) / 2.0;
                    lamp(&mut w, panel, [lx, ly, z1]);
                }
                w.regions.push(Region {
                    min: [x0, ry0.min(ry1)],
                    max: [x1, ry1.max(ry0)],
                    floor_z: z0,
                    ceiling_z: z1,
                    place: Place {
                        building: 0,
                        storey: s as u8,
                        corridor: Some(s as u16),
                        kind: PlaceKind::Room,
                        axis: None,
                    },
                });
            }
        }
        for k in 0..20 {
            lamp(&mut w, panel, [1.5 + 3.0 * k as f32, 0.0, z1]);
        }
        w.regions.push(Region {
            min: [0.0, -HALF],
            max: [LENGTH, HALF],
            floor_z: z0,
            ceiling_z: z1,
            place: Place {
                building: 0,
                storey: s as u8,
                corridor: Some(s as u16),
                kind: PlaceKind::Corridor,
                axis: Some(0.0),
            },
        });
    }
    w
}

/// A 0.6 m ceiling panel facing down with its light 5 cm below.
fn lamp(w: &mut World, panel: u16, c: [f32; 3]) {
    let z = c[2] - 0.01;
    let (x0, x1, y0, y1) = (c[0] - 0.3, c[0] + 0.3, c[1] - 0.3, c[1] + 0.3);
    decal(
        w,
        [[x0, y0, z], [x0, y1, z], [x1, y1, z], [x1, y0, z]],
        panel,
    );
    w.lights.push(Light {
        position: Point3::new(c[0], c[1], c[2] - 0.05),
        intensity: 1.0,
        on: true,
        fixture: Some(panel),
    });
}
