//! The software renderer: a CPU z-buffer rasterizer that renders a [`World`](crate::World) for
//! any [`geom::Camera`] (intrinsics and lens distortion) into RGB, depth (metres along the
//! optical axis) and dominant-plane ids.
//!
//! # Use
//! Prepare the world once ([`RenderScene::new`]), give each thread a [`Renderer`] (it owns every
//! buffer, so a frame allocates nothing once the first has sized them), and call
//! [`Renderer::render`] per frame. Multi-threading is over frames, by the caller (rayon);
//! a `Renderer` is single-threaded and `Send`.
//!
//! ```
//! use synth::render::{RenderOptions, RenderScene, Renderer};
//! let scene = RenderScene::new(&synth::World::default())?;
//! let camera = geom::Camera::from_hfov(160, 120, 1.0)?;
//! let mut renderer = Renderer::new();
//! let out = renderer.render(&scene, &camera, &geom::Pose::identity(), &RenderOptions::default(), &[])?;
//! assert_eq!(out.depth.len(), 160 * 120);
//! # Ok::<(), synth::SynthError>(())
//! ```
//!
//! # How a frame is made
//! 1. Visibility ([`raster`](self)): the scene's grid cells in the frustum, nearest first, each
//!    skipped when a coarse depth buffer shows it hidden; triangles clipped at the near plane
//!    (5 mm: cameras stand close to walls), snapped to 1/16 pixel and filled with integer edge
//!    functions under the top-left rule (no cracks, no pixel drawn twice along a shared edge).
//!    Only `1/z` (exact and perspective-correct: it is affine in screen space) and a triangle
//!    index are written.
//! 2. Shading, once per visible pixel (deferred): depth, `u/z` and `v/z` are evaluated from the
//!    triangle's screen-space planes, so texture coordinates are perspective-correct; textures
//!    are bilinear on a mip level picked from the pixel's texture footprint; light is Lambertian
//!    from the ≤ 8 nearest lamps of each 16x16 tile (lamps of the camera's storey), plus ambient,
//!    emissive surfaces and daylight through windows; haze fades towards its colour with
//!    distance.
//! 3. Finishing: motion-blur sub-frames averaged, vignetting, tone mapping to sRGB, sensor noise
//!    drawn from a hash of the seed and the pixel (same seed, same bytes).
//!
//! A distorted lens is rendered through an undistorted pinhole raster that covers the lens's
//! field of view: each output pixel looks up the triangle at its nearest raster pixel, then
//! evaluates that triangle's planes at its exact undistorted position, so depth and texture
//! coordinates stay exact (only triangle boundaries are resolved to the raster's pixel grid).
//! The map is computed once per camera and cached. A lens without distortion takes the direct
//! path: output pixels are raster pixels.
//!
//! # Back faces
//! Triangles are drawn from both sides, except those of closed, consistently oriented meshes with
//! positive volume (furniture boxes, thick walls), whose back faces can only be seen from inside
//! the solid. Open sheets, double-sided walls and inward-facing room boxes are never culled, since
//! a camera may stand on either side of them.
//!
//! # Limits
//! Without `shadows`, light passes through walls. Shadow rays ignore emissive triangles (lamp
//! fixtures) and this frame's extra triangles.

mod lens;
mod post;
mod raster;
mod scene;
mod shade;
pub mod texture;

pub use scene::RenderScene;

use crate::error::{Result, SynthError};
use crate::world::Triangle;
use geom::{Camera, Pose};
use lens::Lens;
use raster::{NONE, Raster, View};
use serde::{Deserialize, Serialize};
use shade::Shade;
use std::fmt;
use std::str::FromStr;

/// What a rendered image shows (the render types of the BIM-localization literature).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RenderMode {
    /// Flat "cartoon" colour per material ([`Material::color`](crate::Material)), lit by the
    /// same lamps as `textured` but without texture, noise or vignetting.
    Shaded,
    /// Photo-like: procedural textures, lamps, daylight, haze, sensor noise, vignetting, motion
    /// blur.
    #[default]
    Textured,
    /// Geometry edges (plane, crease and occlusion boundaries): white lines on black.
    Edges,
    /// Sobel gradient magnitude of the `textured` image, grey.
    Gradmag,
}

impl RenderMode {
    /// Every mode, in a fixed order.
    pub const ALL: [RenderMode; 4] = [
        RenderMode::Shaded,
        RenderMode::Textured,
        RenderMode::Edges,
        RenderMode::Gradmag,
    ];

    /// The command-line name.
    pub fn name(&self) -> &'static str {
        match self {
            RenderMode::Shaded => "shaded",
            RenderMode::Textured => "textured",
            RenderMode::Edges => "edges",
            RenderMode::Gradmag => "gradmag",
        }
    }
}

impl fmt::Display for RenderMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RenderMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        RenderMode::ALL
            .iter()
            .find(|m| m.name() == s)
            .copied()
            .ok_or_else(|| {
                format!("unknown render mode '{s}' (one of: shaded, textured, edges, gradmag)")
            })
    }
}

/// Motion blur: the frame averages sub-frames rendered along the camera's motion since the
/// previous frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionBlur {
    /// The pose of the previous frame.
    pub previous: Pose,
    /// Sub-frames (1–32); each costs a full render.
    pub samples: u32,
    /// Fraction (0–1) of the time between the frames that the shutter is open; the exposure
    /// ends at the current pose.
    pub shutter: f32,
}

/// How to render a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderOptions {
    /// What the image shows.
    pub mode: RenderMode,
    /// Test every lamp's light with a shadow ray (about ten times slower).
    pub shadows: bool,
    /// Sensor noise (`textured`, `gradmag`): standard deviation as a fraction of full scale.
    pub noise: f32,
    /// Vignetting (`textured`, `gradmag`): fraction of brightness lost at the image corners.
    pub vignetting: f32,
    /// Motion blur (`shaded`, `textured`, `gradmag`), if any.
    pub motion_blur: Option<MotionBlur>,
    /// Seed of the sensor noise: the same seed gives byte-identical images; give each frame of a
    /// sequence its own seed, or the noise freezes.
    pub seed: u64,
    /// Far clipping distance along the optical axis, metres.
    pub far: f32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            mode: RenderMode::Textured,
            shadows: false,
            noise: 0.01,
            vignetting: 0.25,
            motion_blur: None,
            seed: 0,
            far: 150.0,
        }
    }
}

impl RenderOptions {
    /// Checks that every number is usable.
    fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(SynthError::Config(format!("render option {what}")));
        if !(self.noise.is_finite() && self.noise >= 0.0) {
            return bad(&format!("noise = {} must be ≥ 0", self.noise));
        }
        if !(self.vignetting.is_finite() && (0.0..=1.0).contains(&self.vignetting)) {
            return bad(&format!("vignetting = {} must be in 0–1", self.vignetting));
        }
        if !(self.far.is_finite() && self.far > raster::NEAR) {
            return bad(&format!("far = {} must be > {} m", self.far, raster::NEAR));
        }
        if let Some(mb) = &self.motion_blur {
            if !(mb.shutter.is_finite() && (0.0..=1.0).contains(&mb.shutter)) {
                return bad(&format!("motion blur shutter = {} must be in 0–1", mb.shutter));
            }
            check_pose(&mb.previous, "previous pose of motion blur")?;
        }
        Ok(())
    }
}

/// One rendered frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderOutput {
    /// The image.
    pub rgb: image::RgbImage,
    /// Depth per pixel (row-major): z along the optical axis, metres; 0 where nothing is seen.
    pub depth: Vec<f32>,
    /// Dominant-plane id per pixel (row-major), [`PlaneId`](crate::world::PlaneId); 0 for none.
    pub plane: Vec<u32>,
}

/// Counters of the last frame, for tuning and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Non-empty grid cells in the view frustum.
    pub cells_in_view: u32,
    /// Of those, cells skipped as hidden behind what was already drawn.
    pub cells_occluded: u32,
    /// Triangles set up (after the grid's culling).
    pub triangles_tested: u32,
    /// Triangles that won at least one pixel when drawn.
    pub triangles_drawn: u32,
}

/// Renders frames, keeping every buffer between them (and the lens map of the last camera), so
/// a frame allocates nothing once the first one has sized the buffers. Single-threaded; give each
/// thread its own.
#[derive(Debug, Default)]
pub struct Renderer {
    lens: Lens,
    raster: Raster,
    shade: Shade,
    accum: Vec<[f32; 3]>,
    gray: Vec<f32>,
    out: RenderOutput,
}

impl Renderer {
    /// A renderer with empty buffers.
    pub fn new() -> Renderer {
        Renderer::default()
    }

    /// Counters of the last frame.
    pub fn stats(&self) -> FrameStats {
        self.raster.stats
    }

    /// Renders `scene` seen by `camera` at `pose` (camera-to-world), with `extra` triangles of
    /// this frame only (people walking) drawn on top of the scene's grid. Errors for an invalid
    /// camera, a non-finite pose or unusable options; never for what the scene contains.
    pub fn render(
        &mut self,
        scene: &RenderScene,
        camera: &Camera,
        pose: &Pose,
        opts: &RenderOptions,
        extra: &[Triangle],
    ) -> Result<&RenderOutput> {
        check_pose(pose, "camera pose")?;
        opts.validate()?;
        let cam = self.lens.update(camera)?;
        let (w, h) = (camera.width as usize, camera.height as usize);
        let n = w * h;
        if self.out.rgb.dimensions() != (camera.width, camera.height) {
            self.out.rgb = image::RgbImage::new(camera.width, camera.height);
        }
        self.out.depth.resize(n, 0.0);
        self.out.plane.resize(n, 0);
        self.accum.resize(n, [0.0; 3]);

        let mode = opts.mode;
        let blur = opts.motion_blur.filter(|_| mode != RenderMode::Edges);
        let subframes = blur.map_or(1, |b| b.samples.clamp(1, 32) as usize);
        for k in 0..subframes {
            let pose_k = match blur {
                Some(b) if subframes > 1 => {
                    let s = 1.0 - b.shutter as f64 * (subframes - 1 - k) as f64 / (subframes - 1) as f64;
                    b.previous.interpolate(pose, s)
                }
                _ => *pose,
            };
            let view = View::new(&pose_k, cam, opts.far);
            self.raster.draw(scene, &view, extra);
            self.shade.resolve(&self.raster, &self.lens, &view, w, h);
            if mode == RenderMode::Edges {
                break;
            }
            self.shade.choose_lights(scene, &view);
            self.shade.shade(
                scene,
                &mut self.raster,
                &self.lens,
                &view,
                mode,
                opts.shadows,
                &mut self.accum,
                k == 0,
            );
        }
        // Depth and planes of the current pose (the last sub-frame).
        for i in 0..n {
            let id = self.shade.vis[i];
            if id == NONE {
                self.out.depth[i] = 0.0;
                self.out.plane[i] = 0;
            } else {
                self.out.depth[i] = 1.0 / self.shade.w[i];
                self.out.plane[i] = self.raster.vis[id as usize].plane;
            }
        }
        let rgb: &mut [u8] = &mut self.out.rgb;
        let photo = post::Sensor {
            noise: opts.noise,
            vignetting: opts.vignetting,
            seed: opts.seed,
        };
        match mode {
            RenderMode::Shaded => {
                let clean = post::Sensor {
                    noise: 0.0,
                    vignetting: 0.0,
                    seed: 0,
                };
                post::finish(&self.accum, subframes, rgb, w, h, clean);
            }
            RenderMode::Textured => post::finish(&self.accum, subframes, rgb, w, h, photo),
            RenderMode::Gradmag => {
                post::finish(&self.accum, subframes, rgb, w, h, photo);
                post::gradmag(rgb, &mut self.gray, w, h);
            }
            RenderMode::Edges => post::edges(&self.shade, &self.raster.vis, &self.lens, rgb, w, h),
        }
        Ok(&self.out)
    }
}

/// Renders one frame with a fresh [`Renderer`] (convenient for one-off images; for many frames
/// keep a `Renderer`, which reuses its buffers and lens map).
pub fn render(
    scene: &RenderScene,
    camera: &Camera,
    pose: &Pose,
    opts: &RenderOptions,
) -> Result<RenderOutput> {
    let mut r = Renderer::new();
    r.render(scene, camera, pose, opts, &[])?;
    Ok(std::mem::take(&mut r.out))
}

/// A pose must be finite to render from.
fn check_pose(pose: &Pose, what: &str) -> Result<()> {
    let q = pose.rotation.quaternion().coords;
    if q.iter().chain(pose.translation.iter()).all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SynthError::Config(format!("{what} is not finite")))
    }
}
