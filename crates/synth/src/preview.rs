//! `indoorloc synth --preview`: one pose rendered in every mode under every appearance variant,
//! for a contact sheet, so a person can judge at a glance what the networks will be trained on.
//!
//! [`render`] gives the pictures as plain data, arranged in rows; the caller draws the sheet
//! (the command line with `report::contact_sheet`), so that `synth` needs no plotting.

use crate::dataset::{Sampler, SynthConfig, build_world, camera_of, rig_of};
use crate::error::{Result, SynthError};
use crate::render::{RenderMode, RenderOptions, RenderScene, Renderer};
use crate::trajectory::{self, WalkConfig};
use crate::variants::Crowd;
use crate::world::Variant;
use rayon::prelude::*;

/// Frames walked before the preview pose is taken, so the camera is well inside a corridor.
const PREVIEW_FRAME: usize = 20;

/// One picture of the preview.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// Caption: the variant and the render mode, `normal · textured`.
    pub label: String,
    /// The render.
    pub image: image::RgbImage,
}

/// The preview's pictures: one row per appearance variant ([`Variant::ALL`]'s order), one column
/// per render mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Preview {
    /// Title of the sheet: the building and the time of the pose.
    pub title: String,
    /// The rows, every one as long.
    pub rows: Vec<Vec<Tile>>,
}

impl Preview {
    /// Pictures per row: the number of render modes.
    pub fn columns(&self) -> usize {
        self.rows.first().map_or(0, Vec::len)
    }
}

/// Renders the preview: one row per variant, one column per render mode. The pose is a walk's
/// frame number `PREVIEW_FRAME`, or with [`Sampler::Near`] the path's first pose as it is (a
/// scan seen exactly as its own camera saw it).
pub fn render(cfg: &SynthConfig) -> Result<Preview> {
    let rig = rig_of(cfg.camera);
    let camera = camera_of(cfg, &rig)?;
    let normal = SynthConfig {
        variant: Variant::Normal,
        ..cfg.clone()
    };
    let (world, _) = build_world(&normal)?;
    let shot = match &cfg.sampler {
        Sampler::Near { poses, .. } => {
            trajectory::near_poses(&world, poses.get(..1).unwrap_or_default(), 1, 0.0, 0.0, 0)?
        }
        _ => {
            let walk_cfg = WalkConfig::for_rig(rig);
            trajectory::walk(&world, &walk_cfg, PREVIEW_FRAME + 1, cfg.seed)?
        }
    };
    let shot = shot
        .last()
        .ok_or_else(|| SynthError::Config("the walk for the preview is empty".into()))?
        .clone();
    let modes = [
        RenderMode::Shaded,
        RenderMode::Textured,
        RenderMode::Edges,
        RenderMode::Gradmag,
    ];
    let rows: Vec<Vec<Tile>> = Variant::ALL
        .par_iter()
        .map(|&variant| -> Result<Vec<Tile>> {
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
                    Ok(Tile {
                        label: format!("{} · {mode}", variant.name()),
                        image: out.rgb.clone(),
                    })
                })
                .collect()
        })
        .collect::<Result<_>>()?;
    let title = format!(
        "{} at t = {:.1} s: render modes × appearance variants",
        world.name, shot.t
    );
    Ok(Preview { title, rows })
}
