//! The renderer's output is pinned: frames of the default building (the walk, camera and options
//! of `indoorloc bench render`, plus a distorted lens, motion blur and haze) must stay within one
//! grey level, per channel and pixel, of reference frames rendered before the renderer was
//! optimised. Speed work may reorder arithmetic (a last-bit difference can move a rounding), but
//! must not change what an image shows.
//!
//! The references are PNGs in `tests/fixtures/render/`. After a deliberate change of the
//! renderer's output, write new ones with
//! `RENDER_REFERENCE_WRITE=1 cargo test --release -p synth --test render_reference`.

use geom::{Camera, Distortion, Pose};
use std::path::PathBuf;
use synth::dataset::{SynthConfig, build_world, rig_of};
use synth::render::{MotionBlur, RenderMode, RenderOptions, RenderScene, Renderer};
use synth::trajectory::{WalkConfig, camera_for, walk};
use synth::{Variant, World};

type R<T = ()> = Result<T, Box<dyn std::error::Error>>;

/// One reference frame: its file name and what to render.
struct Case {
    name: String,
    camera: Camera,
    pose: Pose,
    opts: RenderOptions,
}

/// The walk of `indoorloc bench render` (seed 1) in `world`, `frames` long, and its camera.
fn bench_walk(world: &World, frames: usize) -> R<(Vec<Pose>, Camera)> {
    let cfg = SynthConfig::default();
    let rig = rig_of(cfg.camera);
    let poses = walk(world, &WalkConfig::for_rig(rig.clone()), frames, cfg.seed)?
        .into_iter()
        .map(|f| f.pose)
        .collect();
    Ok((poses, camera_for(&rig, 160, 120, cfg.seed)?))
}

/// The frames of `world` (`tag` names its variant).
fn cases(world: &World, tag: &str) -> R<Vec<Case>> {
    let (poses, camera) = bench_walk(world, 160)?;
    let opts = |mode: RenderMode, seed: u64| RenderOptions {
        mode,
        seed,
        ..RenderOptions::default()
    };
    let mut out = Vec::new();
    if tag == "normal" {
        for k in [0, 40, 80, 120] {
            out.push(Case {
                name: format!("{tag}_textured_{k}"),
                camera,
                pose: poses[k],
                opts: opts(RenderMode::Textured, k as u64),
            });
        }
        for mode in [RenderMode::Shaded, RenderMode::Edges, RenderMode::Gradmag] {
            out.push(Case {
                name: format!("{tag}_{}_60", mode.name()),
                camera,
                pose: poses[60],
                opts: opts(mode, 60),
            });
        }
        let lens = Camera::new(
            160,
            120,
            110.0,
            110.0,
            79.5,
            59.5,
            Distortion::from_array([-0.25, 0.06, 0.001, -0.001, 0.0]),
        )?;
        out.push(Case {
            name: format!("{tag}_distorted_100"),
            camera: lens,
            pose: poses[100],
            opts: opts(RenderMode::Textured, 100),
        });
    } else {
        // Haze and motion blur (the averaging path of the finisher).
        out.push(Case {
            name: format!("{tag}_blurred_30"),
            camera,
            pose: poses[30],
            opts: RenderOptions {
                motion_blur: Some(MotionBlur {
                    previous: poses[27],
                    samples: 3,
                    shutter: 1.0,
                }),
                ..opts(RenderMode::Textured, 30)
            },
        });
    }
    Ok(out)
}

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/render")
}

#[test]
fn frames_match_the_references_within_one_level() -> R {
    let write = std::env::var_os("RENDER_REFERENCE_WRITE").is_some();
    if write {
        std::fs::create_dir_all(fixtures())?;
    }
    let mut renderer = Renderer::new();
    let mut report = Vec::new();
    for (variant, tag) in [(Variant::Normal, "normal"), (Variant::Disaster, "disaster")] {
        let cfg = SynthConfig {
            variant,
            ..SynthConfig::default()
        };
        let world = build_world(&cfg)?.0;
        let scene = RenderScene::new(&world)?;
        for case in cases(&world, tag)? {
            let img = &renderer
                .render(&scene, &case.camera, &case.pose, &case.opts, &[])?
                .rgb;
            let path = fixtures().join(format!("{}.png", case.name));
            if write {
                img.save(&path)?;
                continue;
            }
            let want = image::open(&path)?.to_rgb8();
            assert_eq!(want.dimensions(), img.dimensions(), "{}", case.name);
            let (mut worst, mut off) = (0u8, 0usize);
            for (a, b) in want.as_raw().iter().zip(img.as_raw()) {
                let d = a.abs_diff(*b);
                worst = worst.max(d);
                off += usize::from(d > 0);
            }
            report.push(format!(
                "{}: max difference {worst}, {off} channel values differ",
                case.name
            ));
            assert!(worst <= 1, "{}", report.join("\n"));
        }
    }
    println!("{}", report.join("\n"));
    Ok(())
}
