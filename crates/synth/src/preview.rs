//! `indoorloc synth --preview`: one pose rendered in every mode under every appearance variant,
//! as a contact sheet, so a person can judge at a glance what the networks will be trained on.

use crate::dataset::{SynthConfig, build_world, rig_of};
use crate::error::{Result, SynthError};
use crate::render::{RenderMode, RenderOptions, RenderScene, Renderer};
use crate::trajectory::{self, WalkConfig};
use crate::variants::Crowd;
use crate::world::Variant;
use rayon::prelude::*;

/// Frames walked before the preview pose is taken, so the camera is well inside a corridor.
const PREVIEW_FRAME: usize = 20;

/// PNG bytes of the contact sheet: one row per variant, one column per render mode.
pub fn contact_sheet(cfg: &SynthConfig) -> Result<Vec<u8>> {
    let rig = rig_of(cfg.camera);
    let camera = trajectory::camera_for(&rig, cfg.width, cfg.height, cfg.seed)?;
    let normal = SynthConfig {
        variant: Variant::Normal,
        ..cfg.clone()
    };
    let (world, _) = build_world(&normal)?;
    let walk_cfg = WalkConfig::for_rig(rig);
    let walk = trajectory::walk(&world, &walk_cfg, PREVIEW_FRAME + 1, cfg.seed)?;
    let shot = walk
        .last()
        .ok_or_else(|| SynthError::Config("the walk for the preview is empty".into()))?
        .clone();
    let modes = [
        RenderMode::Shaded,
        RenderMode::Textured,
        RenderMode::Edges,
        RenderMode::Gradmag,
    ];
    let rows: Vec<Vec<report::Tile>> = Variant::ALL
        .par_iter()
        .map(|&variant| -> Result<Vec<report::Tile>> {
            let (mut world, _) = build_world(&SynthConfig {
                variant,
                ..cfg.clone()
            })?;
            let crowd = (variant == Variant::People).then(|| Crowd::new(&mut world, 12, cfg.seed));
            let extra = crowd
                .as_ref()
                .map(|c| {
                    c.triangles_clear_of(
                        &world,
                        shot.t,
                        &nalgebra::Point3::from(shot.pose.position()),
                        crate::dataset::PERSON_CLEARANCE_M,
                    )
                })
                .unwrap_or_default();
            let scene = RenderScene::new(&world)?;
            let mut renderer = Renderer::new();
            modes
                .iter()
                .map(|&mode| {
                    let opts = RenderOptions {
                        mode,
                        seed: cfg.seed,
                        ..RenderOptions::default()
                    };
                    let out = renderer.render(&scene, &camera, &shot.pose, &opts, &extra)?;
                    Ok(report::Tile {
                        label: format!("{} · {mode}", variant.name()),
                        image: out.rgb.clone(),
                    })
                })
                .collect()
        })
        .collect::<Result<_>>()?;
    let tiles: Vec<report::Tile> = rows.into_iter().flatten().collect();
    let title = format!(
        "{} at t = {:.1} s: render modes × appearance variants",
        world.name, shot.t
    );
    report::contact_sheet(&title, &tiles, modes.len())
        .map_err(|e| SynthError::Config(format!("contact sheet: {e}")))
}
