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
//! let pose = geom::Pose::identity();
//! let out = renderer.render(&scene, &camera, &pose, &RenderOptions::default(), &[])?;
//! assert_eq!(out.depth.len(), 160 * 120);
//! # Ok::<(), synth::SynthError>(())
//! ```
//!
//! # How a frame is made
//! 1. Visibility: the scene's grid cells in the frustum, nearest first, each
//!    skipped when a coarse depth buffer shows it hidden; triangles clipped at the near plane
//!    (5 mm: cameras stand close to walls), snapped to 1/16 pixel and filled with integer edge
//!    functions under the top-left rule (no cracks, no pixel drawn twice along a shared edge).
//!    Only `1/z` (exact and perspective-correct: it is affine in screen space) and a triangle
//!    index are written.
//! 2. Shading, once per visible pixel (deferred): depth, `u/z` and `v/z` are evaluated from the
//!    triangle's screen-space planes, so texture coordinates are perspective-correct. The mip
//!    level comes from the pixel's texture footprint (screen derivatives of u and v): a
//!    minified texture takes the nearest texel of that level (which already averages the
//!    footprint), a magnified one is bilinear. Light is Lambertian from the ≤ 8 lamps nearest
//!    to each 16x16 tile (lamps of the camera's storey), evaluated on a grid of every fourth
//!    pixel and interpolated over each surface, plus ambient, emissive surfaces (a fixture
//!    glows only while a lamp showing it is on) and daylight through windows; an unlit surface
//!    (a scan's photographs) shows its colour as it is, scaled only by the ambient level; haze
//!    fades towards its colour with distance.
//! 3. Finishing: motion-blur sub-frames averaged, vignetting, tone mapping (a soft shoulder)
//!    and sRGB encoding, sensor noise drawn from a hash of the seed and the pixel (same seed,
//!    same bytes).
//! 4. A scan (every triangle unlit) has gaps where its depth camera saw nothing; in the
//!    photo-like modes (`textured`, `shaded`) they take the colours around them (`fill`:
//!    push-pull), as a photo there would show something; depth stays 0 there.
//!
//! A distorted lens is rendered through an undistorted pinhole raster that covers the lens's
//! field of view: each output pixel looks up the triangle at its nearest raster pixel, then
//! evaluates that triangle's planes at its exact undistorted position, so depth and texture
//! coordinates stay exact (only triangle boundaries are resolved to the raster's pixel grid).
//! The map is computed once per camera and cached. A lens without distortion takes the direct
//! path: output pixels are raster pixels.
//!
//! # Speed
//! One thread, CPU time per frame, measured with `RENDER_SPEED_WORLD=bench cargo run --release
//! -p synth --example render_speed` (the scene, walk, camera and options of `indoorloc bench
//! render`: the default building, 48.8k triangles, 606 lamps) on a shared 2-core AMD EPYC VM
//! with AVX2, alternating with the build before the changes below in the same session: at
//! 160x120 `textured` takes 0.83 ms (1200 frames/s; 1.06 ms, 940 frames/s before), `shaded`
//! 0.67 ms (1490; 1350 before), `edges` 0.48 ms (2090; 1970 before), `gradmag` 0.98 ms (1025;
//! 880 before); at 320x240 `textured` takes 2.4 ms (3.3 ms before). Of a `textured` frame at
//! 160x120, visibility takes about 0.35 ms (culling about a thousand triangles for the hundred
//! that are seen, then filling spans); shading and finishing the rest, a third of that
//! fetching texels. Frames are independent, so throughput scales with threads.
//!
//! What makes it that fast: shading goes along each row in runs of pixels that see one
//! triangle, step by step over arrays (module `span`), so light, texture coordinates, levels of
//! detail, texel addresses, blends and radiance are vector code; the whole frame is also
//! compiled for AVX2 (eight lanes instead of SSE2's four) and that build is chosen at run time.
//! Both builds, and the one-pixel-at-a-time shader this replaced, do the same floating-point
//! operations in the same order, so images are the same (`tests/render_reference.rs` holds
//! frames rendered before the change, and a test compares the two builds).
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

mod fill;
mod lens;
mod post;
mod raster;
mod scene;
mod shade;
mod span;
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
                return bad(&format!(
                    "motion blur shutter = {} must be in 0–1",
                    mb.shutter
                ));
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
    /// Pixels whose light was computed exactly rather than interpolated from the light grid.
    pub lit_exactly: u32,
    /// Time spent on visibility (culling and rasterizing), nanoseconds.
    pub raster_ns: u64,
    /// Time spent on shading and finishing the image, nanoseconds.
    pub shade_ns: u64,
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
    finish_rows: (Vec<f32>, Vec<f32>, Vec<f32>, post::RowBytes),
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
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: `frame_avx2` requires only AVX2, which the running CPU was just found to
            // have.
            unsafe { self.frame_avx2(scene, cam, camera, pose, opts, extra) };
        } else {
            self.frame(scene, cam, camera, pose, opts, extra);
        }
        if scene.scan && matches!(opts.mode, RenderMode::Textured | RenderMode::Shaded) {
            fill::fill_empty(&mut self.out.rgb, &self.out.depth);
        }
        Ok(&self.out)
    }

    /// [`Renderer::frame`] compiled for AVX2: the loops of visibility, shading and finishing
    /// take eight pixels an instruction instead of four. Rust never fuses multiply-adds, so the
    /// operations, and the images, are the same as the portable build's.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn frame_avx2(
        &mut self,
        scene: &RenderScene,
        cam: lens::RasterCam,
        camera: &Camera,
        pose: &Pose,
        opts: &RenderOptions,
        extra: &[Triangle],
    ) {
        self.frame(scene, cam, camera, pose, opts, extra);
    }

    /// Renders a frame of valid inputs into `self.out` (the body of [`Renderer::render`], for
    /// any CPU; everything it calls per pixel is inlined into it, so that a build for wider
    /// vectors covers all of it).
    #[inline(always)]
    fn frame(
        &mut self,
        scene: &RenderScene,
        cam: lens::RasterCam,
        camera: &Camera,
        pose: &Pose,
        opts: &RenderOptions,
        extra: &[Triangle],
    ) {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let n = w * h;
        if self.out.rgb.dimensions() != (camera.width, camera.height) {
            self.out.rgb = image::RgbImage::new(camera.width, camera.height);
        }
        self.out.depth.resize(n, 0.0);
        self.out.plane.resize(n, 0);

        let mode = opts.mode;
        let blur = opts.motion_blur.filter(|_| mode != RenderMode::Edges);
        let subframes = blur.map_or(1, |b| b.samples.clamp(1, 32) as usize);
        if subframes > 1 {
            self.accum.resize(n, [0.0; 3]);
        }
        let start = std::time::Instant::now();
        let mut raster_ns = 0;
        let photo = post::Sensor {
            noise: opts.noise,
            vignetting: opts.vignetting,
            seed: opts.seed,
        };
        let clean = post::Sensor {
            noise: 0.0,
            vignetting: 0.0,
            seed: 0,
        };
        let sensor = if matches!(mode, RenderMode::Shaded) {
            clean
        } else {
            photo
        };
        for k in 0..subframes {
            let pose_k = match blur {
                Some(b) if subframes > 1 => {
                    let s = 1.0
                        - b.shutter as f64 * (subframes - 1 - k) as f64 / (subframes - 1) as f64;
                    b.previous.interpolate(pose, s)
                }
                _ => *pose,
            };
            let view = View::new(&pose_k, cam, opts.far);
            let t0 = std::time::Instant::now();
            self.raster.draw(scene, &view, extra);
            raster_ns += t0.elapsed().as_nanos() as u64;
            self.shade.resolve(&self.raster, &self.lens, w, h);
            if mode == RenderMode::Edges {
                break;
            }
            self.shade.choose_lights(scene, &view);
            let sink = if subframes == 1 {
                shade::Sink::Bytes(&mut self.out.rgb, sensor)
            } else {
                shade::Sink::Accum(&mut self.accum, k == 0)
            };
            self.shade.shade(
                scene,
                &mut self.raster,
                &self.lens,
                &view,
                mode,
                opts.shadows,
                sink,
            );
        }
        // Depth and planes of the current pose (the last sub-frame).
        // `1/z` is positive exactly where a triangle is seen, so depth is a loop without
        // lookups (which vectorizes), and only planes look up triangles.
        for (d, &wv) in self.out.depth.iter_mut().zip(&self.shade.w) {
            *d = if wv > 0.0 { 1.0 / wv } else { 0.0 };
        }
        for (p, &id) in self.out.plane.iter_mut().zip(&self.shade.vis) {
            *p = if id == NONE {
                0
            } else {
                self.raster.vis[id as usize].plane
            };
        }
        let rgb: &mut [u8] = &mut self.out.rgb;
        if subframes > 1 {
            post::finish(
                &self.accum,
                subframes,
                rgb,
                w,
                h,
                sensor,
                &mut self.finish_rows,
            );
        }
        match mode {
            RenderMode::Gradmag => post::gradmag(rgb, &mut self.gray, w, h),
            RenderMode::Edges => post::edges(&self.shade, &self.raster.vis, &self.lens, rgb, w, h),
            RenderMode::Shaded | RenderMode::Textured => {}
        }
        self.raster.stats.raster_ns = raster_ns;
        self.raster.stats.shade_ns = (start.elapsed().as_nanos() as u64).saturating_sub(raster_ns);
    }
}

/// The `gradmag` mode's gradient magnitude of any RGB image (a photo, a `textured` render): what
/// a network trained on `gradmag` renders must see of a real image.
pub fn gradmag_image(img: &image::RgbImage) -> image::RgbImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut out = img.clone();
    let mut gray = Vec::with_capacity(w * h);
    post::gradmag(&mut out, &mut gray, w, h);
    out
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
    if q.iter()
        .chain(pose.translation.iter())
        .all(|v| v.is_finite())
    {
        Ok(())
    } else {
        Err(SynthError::Config(format!("{what} is not finite")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::World;
    use crate::world::{Light, Material, Pattern, Plane};
    use geom::Distortion;
    use nalgebra::{Matrix3, Point2, Point3, Vector3};

    type R<T = ()> = std::result::Result<T, Box<dyn std::error::Error>>;

    /// A camera at `eye` looking at `target`, level (OpenCV axes: x right, y down, z forward).
    fn look_at(eye: [f64; 3], target: [f64; 3]) -> R<Pose> {
        let e = Vector3::from(eye);
        let f = (Vector3::from(target) - e).normalize();
        let up = if f.z.abs() > 0.99 {
            Vector3::y()
        } else {
            Vector3::z()
        };
        let x = f.cross(&up).normalize();
        let y = f.cross(&x);
        Ok(Pose::from_rt(&Matrix3::from_columns(&[x, y, f]), eye)?)
    }

    /// Adds a quad (counter-clockwise seen from the front) with uv in metres along its sides.
    fn quad(w: &mut World, q: [[f32; 3]; 4], material: u16, plane: u32) {
        let p = q.map(|v| Point3::new(v[0], v[1], v[2]));
        let eu = (p[1] - p[0]).normalize();
        let ev = (p[3] - p[0]).normalize();
        let uv = |v: &Point3<f32>| [(v - p[0]).dot(&eu), (v - p[0]).dot(&ev)];
        for [i, j, k] in [[0, 1, 2], [0, 2, 3]] {
            w.triangles.push(Triangle {
                v: [p[i], p[j], p[k]],
                uv: [uv(&p[i]), uv(&p[j]), uv(&p[k])],
                material,
                plane,
            });
        }
    }

    fn materials(w: &mut World) -> [u16; 3] {
        let wall = w.add_material(Material {
            pattern: Pattern::Brick,
            ..Material::plain("wall", [0.7, 0.4, 0.3])
        });
        let wall2 = w.add_material(Material::plain("wall2", [0.8, 0.8, 0.7]));
        let floor = w.add_material(Material {
            pattern: Pattern::Tiles { size: 0.5 },
            ..Material::plain("floor", [0.4, 0.4, 0.45])
        });
        [wall, wall2, floor]
    }

    /// Two walls meeting at the vertical edge x = y = 0 and the floor between them: wall x = 0
    /// (plane 1), wall y = 0 (plane 2), floor z = 0 (plane 3); corner point at the origin.
    fn corner_world() -> World {
        let mut w = World::default();
        let [wall, wall2, floor] = materials(&mut w);
        w.add_plane(Plane {
            normal: Vector3::x(),
            offset: 0.0,
        });
        w.add_plane(Plane {
            normal: Vector3::y(),
            offset: 0.0,
        });
        w.add_plane(Plane {
            normal: Vector3::z(),
            offset: 0.0,
        });
        quad(
            &mut w,
            [
                [0.0, 6.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 3.0],
                [0.0, 6.0, 3.0],
            ],
            wall,
            1,
        );
        quad(
            &mut w,
            [
                [0.0, 0.0, 0.0],
                [6.0, 0.0, 0.0],
                [6.0, 0.0, 3.0],
                [0.0, 0.0, 3.0],
            ],
            wall2,
            2,
        );
        quad(
            &mut w,
            [
                [0.0, 0.0, 0.0],
                [6.0, 0.0, 0.0],
                [6.0, 6.0, 0.0],
                [0.0, 6.0, 0.0],
            ],
            floor,
            3,
        );
        w.lights.push(Light {
            position: Point3::new(2.0, 2.0, 2.8),
            intensity: 1.0,
            on: true,
            fixture: None,
        });
        w
    }

    /// A closed room [0, 4] x [0, 5] x [0, 3] seen from inside (faces point inwards), with a lamp.
    fn box_world() -> World {
        let mut w = World::default();
        let [wall, wall2, floor] = materials(&mut w);
        let (x, y, z) = (4.0, 5.0, 3.0);
        quad(
            &mut w,
            [[0.0, 0.0, 0.0], [x, 0.0, 0.0], [x, y, 0.0], [0.0, y, 0.0]],
            floor,
            1,
        );
        quad(
            &mut w,
            [[0.0, 0.0, z], [0.0, y, z], [x, y, z], [x, 0.0, z]],
            wall2,
            2,
        );
        quad(
            &mut w,
            [[0.0, 0.0, 0.0], [0.0, y, 0.0], [0.0, y, z], [0.0, 0.0, z]],
            wall,
            3,
        );
        quad(
            &mut w,
            [[x, y, 0.0], [x, 0.0, 0.0], [x, 0.0, z], [x, y, z]],
            wall,
            4,
        );
        quad(
            &mut w,
            [[x, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, z], [x, 0.0, z]],
            wall2,
            5,
        );
        quad(
            &mut w,
            [[0.0, y, 0.0], [x, y, 0.0], [x, y, z], [0.0, y, z]],
            wall2,
            6,
        );
        w.lights.push(Light {
            position: Point3::new(2.0, 2.5, 2.9),
            intensity: 1.0,
            on: true,
            fixture: None,
        });
        w
    }

    fn cameras() -> R<Vec<(&'static str, Camera)>> {
        Ok(vec![
            (
                "pinhole",
                Camera::new(320, 240, 260.0, 262.0, 161.3, 118.7, Distortion::default())?,
            ),
            (
                "distorted",
                Camera::new(
                    320,
                    240,
                    260.0,
                    262.0,
                    161.3,
                    118.7,
                    Distortion::from_array([-0.2, 0.05, 0.0, 0.0, 0.0]),
                )?,
            ),
        ])
    }

    fn flat(mode: RenderMode) -> RenderOptions {
        RenderOptions {
            mode,
            noise: 0.0,
            vignetting: 0.0,
            ..RenderOptions::default()
        }
    }

    /// Acceptance: the rendered corner lies where `geom` projects it (≤ 1 px), and depth equals
    /// the analytic ray/plane depth (≤ 1 cm), for a pinhole and a distorted lens.
    #[test]
    fn render_geometry_corner_and_depth() -> R {
        let scene = RenderScene::new(&corner_world())?;
        let corner = Point3::new(0.0, 0.0, 0.0);
        let planes = [
            (1u32, Vector3::x(), 0.0),
            (2, Vector3::y(), 0.0),
            (3, Vector3::z(), 0.0),
        ];
        // The corner near the image centre, and far off it (where distortion moves it most).
        let views = [
            ([3.5, 4.0, 1.7], [0.0, 0.0, 0.4]),
            ([3.0, 4.5, 1.5], [2.2, 1.0, 1.7]),
            ([3.5, 3.0, 1.6], [0.8, -0.9, 1.8]),
            ([4.5, 2.5, 1.2], [0.4, 2.4, 1.2]),
        ];
        let mut worst_px: f64 = 0.0;
        let mut worst_depth: f64 = 0.0;
        for (name, camera) in cameras()? {
            for (v, (eye, target)) in views.iter().enumerate() {
                let pose = look_at(*eye, *target)?;
                let out = render(&scene, &camera, &pose, &flat(RenderMode::Textured))?;
                let tmp = std::env::temp_dir();
                out.rgb
                    .save(tmp.join(format!("render_corner_{name}_{v}.png")))?;
                let (w, h) = (camera.width as usize, camera.height as usize);
                // Pixel corners where all three plane ids meet within a 2x2 block.
                let (mut sx, mut sy, mut count) = (0.0, 0.0, 0);
                for y in 0..h - 1 {
                    for x in 0..w - 1 {
                        let ids = [
                            out.plane[y * w + x],
                            out.plane[y * w + x + 1],
                            out.plane[(y + 1) * w + x],
                            out.plane[(y + 1) * w + x + 1],
                        ];
                        if (1..=3).all(|p| ids.contains(&p)) {
                            sx += x as f64 + 0.5;
                            sy += y as f64 + 0.5;
                            count += 1;
                        }
                    }
                }
                assert!(
                    count > 0,
                    "{name} {v}: no pixel where the three planes meet"
                );
                let found = Point2::new(sx / count as f64, sy / count as f64);
                let expected = camera
                    .project_world(&pose, &corner)
                    .ok_or("corner behind camera")?;
                let pinhole = camera.undistort_pixel(&expected);
                let err_px = (found - expected).norm();
                println!(
                    "{name} view {v}: corner rendered at ({:.2}, {:.2}), geom projects \
                     ({:.2}, {:.2}) [{:.1} px from where a pinhole would put it]: \
                     error {err_px:.3} px",
                    found.x,
                    found.y,
                    expected.x,
                    expected.y,
                    (pinhole - expected).norm()
                );
                assert!(err_px <= 1.0, "{name} {v}: corner off by {err_px} px");
                worst_px = worst_px.max(err_px);

                // Depth against the analytic intersection of each pixel's ray with its plane.
                let r = pose.rotation_matrix();
                let c = pose.translation;
                let mut worst: f64 = 0.0;
                let mut checked = 0;
                for y in 1..h - 1 {
                    for x in 1..w - 1 {
                        let id = out.plane[y * w + x];
                        let Some(&(_, n, off)) = planes.iter().find(|p| p.0 == id) else {
                            continue;
                        };
                        // Skip pixels next to another surface: their nearest-pixel lookup may
                        // take the neighbour's triangle.
                        let near_other =
                            [(0isize, 1isize), (1, 0), (0, -1), (-1, 0)]
                                .iter()
                                .any(|(dx, dy)| {
                                    let j =
                                        (y as isize + dy) as usize * w + (x as isize + dx) as usize;
                                    out.plane[j] != id
                                });
                        if near_other {
                            continue;
                        }
                        let ray = r * camera
                            .unproject(&Point2::new(x as f64, y as f64), 1.0)
                            .coords;
                        let s = (off - n.dot(&c)) / n.dot(&ray);
                        let err = (out.depth[y * w + x] as f64 - s).abs();
                        worst = worst.max(err);
                        checked += 1;
                    }
                }
                println!(
                    "{name} view {v}: depth checked at {checked} pixels, worst error {worst:.2e} m"
                );
                assert!(
                    checked > w * h / 3,
                    "{name} {v}: only {checked} pixels checked"
                );
                assert!(worst < 0.01, "{name} {v}: depth off by {worst} m");
                worst_depth = worst_depth.max(worst);
            }
        }
        println!("worst corner error {worst_px:.3} px, worst depth error {worst_depth:.2e} m");
        Ok(())
    }

    #[test]
    fn render_same_seed_same_bytes() -> R {
        let scene = RenderScene::new(&box_world())?;
        let camera = Camera::from_hfov(160, 120, 1.1)?;
        let pose = look_at([1.0, 1.0, 1.5], [4.0, 4.0, 1.0])?;
        let opts = |seed| RenderOptions {
            seed,
            noise: 0.03,
            ..RenderOptions::default()
        };
        let a = render(&scene, &camera, &pose, &opts(7))?;
        let mut r = Renderer::new();
        // A reused renderer (after another frame) gives the same bytes as a fresh one.
        r.render(
            &scene,
            &camera,
            &look_at([2.0, 2.0, 1.0], [0.0, 0.0, 0.0])?,
            &opts(1),
            &[],
        )?;
        let b = r.render(&scene, &camera, &pose, &opts(7), &[])?.clone();
        assert_eq!(a, b);
        let c = render(&scene, &camera, &pose, &opts(8))?;
        let differing = a
            .rgb
            .iter()
            .zip(c.rgb.iter())
            .filter(|(x, y)| x != y)
            .count();
        assert!(differing > a.rgb.len() / 2, "only {differing} bytes differ");
        assert_eq!(a.depth, c.depth);
        Ok(())
    }

    #[test]
    fn render_every_mode_nontrivial() -> R {
        let scene = RenderScene::new(&corner_world())?;
        let camera = Camera::from_hfov(160, 120, 1.2)?;
        let pose = look_at([3.5, 4.0, 1.7], [0.0, 0.0, 0.4])?;
        for mode in RenderMode::ALL {
            let out = render(&scene, &camera, &pose, &flat(mode))?;
            let lo = out.rgb.iter().min().copied().unwrap_or(0);
            let hi = out.rgb.iter().max().copied().unwrap_or(0);
            assert!(hi > lo + 50, "{mode}: range {lo}..{hi}");
            out.rgb.save(format!(
                "{}/render_test_{mode}.png",
                std::env::temp_dir().display()
            ))?;
        }
        // Edges: a white line along the vertical edge where the walls meet.
        let out = render(&scene, &camera, &pose, &flat(RenderMode::Edges))?;
        for z in [0.5, 1.0, 1.5, 2.0] {
            let p = camera
                .project_world(&pose, &Point3::new(0.0, 0.0, z))
                .ok_or("behind")?;
            let (px, py) = (p.x.round() as i64, p.y.round() as i64);
            let white = (-1..=1).any(|dx| {
                let x = (px + dx).clamp(0, 159) as u32;
                out.rgb.get_pixel(x, py.clamp(0, 119) as u32).0[0] == 255
            });
            assert!(white, "no edge at the wall corner, z = {z}");
        }
        // Not everything is an edge.
        let white = out.rgb.pixels().filter(|p| p.0[0] == 255).count();
        assert!(white < 160 * 120 / 8, "{white} edge pixels");
        Ok(())
    }

    /// The gradient magnitude of a textured render is the gradmag render of the same shot, so a
    /// photo turned into gradient magnitude looks as the training renders did.
    #[test]
    fn gradmag_of_a_textured_render_is_the_gradmag_render() -> R {
        let scene = RenderScene::new(&corner_world())?;
        let camera = Camera::from_hfov(160, 120, 1.2)?;
        let pose = look_at([3.5, 4.0, 1.7], [0.0, 0.0, 0.4])?;
        let opts = |mode| RenderOptions {
            mode,
            seed: 3,
            noise: 0.03,
            ..RenderOptions::default()
        };
        let textured = render(&scene, &camera, &pose, &opts(RenderMode::Textured))?;
        let gradmag = render(&scene, &camera, &pose, &opts(RenderMode::Gradmag))?;
        assert_eq!(gradmag_image(&textured.rgb), gradmag.rgb);
        assert_ne!(textured.rgb, gradmag.rgb);
        Ok(())
    }

    #[test]
    fn render_inside_closed_box_sees_no_background() -> R {
        let scene = RenderScene::new(&box_world())?;
        let targets = [
            [4.0, 5.0, 1.0],
            [0.0, 0.0, 0.0],
            [2.0, 2.6, 3.0],
            [2.0, 2.6, 0.0],
            [4.0, 2.5, 1.5],
        ];
        for (name, camera) in cameras()? {
            for (k, t) in targets.iter().enumerate() {
                let pose = look_at([2.0, 2.5, 1.5], *t)?;
                let out = render(&scene, &camera, &pose, &flat(RenderMode::Shaded))?;
                let empty = out
                    .depth
                    .iter()
                    .filter(|&&d| d <= 0.0 || d.is_nan())
                    .count();
                assert_eq!(empty, 0, "{name}, view {k}: {empty} pixels see nothing");
            }
        }
        // Close to a wall: near-plane clipping keeps the wall, no background shows.
        let camera = Camera::from_hfov(160, 120, 1.5)?;
        let pose = look_at([0.03, 2.5, 1.5], [-1.0, 2.0, 1.0])?;
        let out = render(&scene, &camera, &pose, &flat(RenderMode::Textured))?;
        assert!(out.depth.iter().all(|&d| d > 0.0 && d < 0.2));
        Ok(())
    }

    /// A floor of many small triangles (shared vertices, irregular in-plane positions) shows no
    /// crack: every pixel below the horizon sees it.
    #[test]
    fn render_fine_mesh_has_no_cracks() -> R {
        let mut w = World::default();
        let m = w.add_material(Material::plain("floor", [0.5, 0.5, 0.5]));
        let n = 60;
        let jitter = |i: usize, j: usize| -> [f32; 2] {
            if i == 0 || j == 0 || i == n || j == n {
                return [0.0, 0.0];
            }
            let h = (i * 7919 + j * 104_729) % 1000;
            [
                (h % 37) as f32 * 0.004 - 0.07,
                (h % 41) as f32 * 0.004 - 0.08,
            ]
        };
        let v = |i: usize, j: usize| {
            let d = jitter(i, j);
            Point3::new(
                i as f32 * 0.5 - 15.0 + d[0],
                j as f32 * 0.5 - 15.0 + d[1],
                0.0,
            )
        };
        for i in 0..n {
            for j in 0..n {
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                for t in [[a, b, c], [a, c, d]] {
                    w.triangles.push(Triangle {
                        v: t,
                        uv: [[0.0; 2]; 3],
                        material: m,
                        plane: 1,
                    });
                }
            }
        }
        let scene = RenderScene::new(&w)?;
        let camera = Camera::from_hfov(200, 150, 1.3)?;
        for (eye, target) in [
            ([0.3, 0.2, 1.6], [5.0, 3.0, 0.0]),
            ([1.0, -2.0, 0.4], [2.0, 3.0, 0.2]),
        ] {
            let pose = look_at(eye, target)?;
            let out = render(&scene, &camera, &pose, &flat(RenderMode::Shaded))?;
            let mut holes = 0;
            for y in 0..150 {
                for x in 0..200 {
                    let ray = pose.rotation_matrix()
                        * camera
                            .unproject(&Point2::new(x as f64, y as f64), 1.0)
                            .coords;
                    // Rays that hit the floor well inside the mesh must find it.
                    if ray.z < -1e-3 {
                        let s = -eye[2] / ray.z;
                        let p = Vector3::from(eye) + ray * s;
                        if p.x.abs() < 14.0 && p.y.abs() < 14.0 && out.depth[y * 200 + x] <= 0.0 {
                            holes += 1;
                        }
                    }
                }
            }
            assert_eq!(holes, 0, "{holes} cracks");
        }
        Ok(())
    }

    #[test]
    fn render_degenerate_inputs_do_not_panic() -> R {
        let camera = Camera::from_hfov(64, 48, 1.2)?;
        let distorted = Camera::new(
            64,
            48,
            40.0,
            40.0,
            31.5,
            23.5,
            Distortion::from_array([-0.3, 0.08, 0.001, -0.001, 0.0]),
        )?;
        let pose = look_at([1.0, 1.0, 1.5], [3.0, 3.0, 1.0])?;
        // Empty world.
        let empty = RenderScene::new(&World::default())?;
        for mode in RenderMode::ALL {
            let out = render(&empty, &camera, &pose, &flat(mode))?;
            assert!(out.depth.iter().all(|&d| d == 0.0));
            assert!(out.plane.iter().all(|&p| p == 0));
        }
        // Zero-area and NaN triangles, a material id that does not exist, NaN uv.
        let mut w = box_world();
        let p = Point3::new(1.0, 1.0, 1.0);
        w.triangles.push(Triangle {
            v: [p, p, p],
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        });
        w.triangles.push(Triangle {
            v: [p, Point3::new(2.0, 2.0, 2.0), Point3::new(3.0, 3.0, 3.0)],
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        });
        w.triangles.push(Triangle {
            v: [
                p,
                Point3::new(f32::NAN, 2.0, 2.0),
                Point3::new(3.0, 1.0, 1.0),
            ],
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        });
        w.triangles.push(Triangle {
            v: [
                Point3::new(1.0, 3.0, 0.5),
                Point3::new(3.0, 3.0, 0.5),
                Point3::new(2.0, 3.0, 2.0),
            ],
            uv: [[f32::NAN, f32::INFINITY], [0.0; 2], [1e30, -1e30]],
            material: 999,
            plane: 7,
        });
        let scene = RenderScene::new(&w)?;
        assert_eq!(scene.dropped_triangles(), 3);
        let mut r = Renderer::new();
        for cam in [camera, distorted] {
            for mode in RenderMode::ALL {
                let opts = RenderOptions {
                    mode,
                    shadows: true,
                    ..RenderOptions::default()
                };
                r.render(
                    &scene,
                    &cam,
                    &pose,
                    &opts,
                    &w.triangles[w.triangles.len() - 4..],
                )?;
                // Camera inside a wall (on its plane), in a corner, and far outside.
                for eye in [
                    [0.0, 2.5, 1.5],
                    [0.0, 0.0, 0.0],
                    [4.0, 5.0, 3.0],
                    [1e6, -1e6, 5.0],
                ] {
                    let pose = look_at(eye, [2.0, 2.5, 1.0])?;
                    r.render(&scene, &cam, &pose, &opts, &[])?;
                }
            }
        }
        // A huge triangle crossing the near plane, with a vertex behind the camera.
        let mut w = World::default();
        let m = w.add_material(Material::plain("floor", [0.5, 0.5, 0.5]));
        w.triangles.push(Triangle {
            v: [
                Point3::new(-1e4, -1e4, 0.0),
                Point3::new(1e4, -1e4, 0.0),
                Point3::new(0.0, 1e4, 0.0),
            ],
            uv: [[0.0; 2]; 3],
            material: m,
            plane: 1,
        });
        let scene = RenderScene::new(&w)?;
        let pose = look_at([0.0, 0.0, 1.5], [0.0, 5.0, 0.0])?;
        let out = render(&scene, &camera, &pose, &flat(RenderMode::Textured))?;
        // Looking down at 17°, the bottom row sees the floor at depth ≈ 1.5 / sin(angle).
        assert!(out.depth[47 * 64..].iter().all(|&d| d > 0.5 && d < 10.0));
        // Bad options and poses are errors, not panics.
        let bad = RenderOptions {
            noise: f32::NAN,
            ..RenderOptions::default()
        };
        assert!(render(&scene, &camera, &pose, &bad).is_err());
        let mut nan_pose = pose;
        nan_pose.translation.x = f64::NAN;
        assert!(render(&scene, &camera, &nan_pose, &RenderOptions::default()).is_err());
        let mut bad_cam = camera;
        bad_cam.fx = -1.0;
        assert!(render(&scene, &bad_cam, &pose, &RenderOptions::default()).is_err());
        Ok(())
    }

    #[test]
    fn render_motion_blur_and_haze() -> R {
        let mut world = box_world();
        let scene = RenderScene::new(&world)?;
        let camera = Camera::from_hfov(96, 72, 1.2)?;
        let pose = look_at([1.0, 1.0, 1.5], [4.0, 4.0, 1.0])?;
        let sharp = render(&scene, &camera, &pose, &flat(RenderMode::Textured))?;
        let opts = RenderOptions {
            motion_blur: Some(MotionBlur {
                previous: look_at([1.0, 1.3, 1.5], [4.0, 3.0, 1.2])?,
                samples: 4,
                shutter: 1.0,
            }),
            ..flat(RenderMode::Textured)
        };
        let blurred = render(&scene, &camera, &pose, &opts)?;
        assert_ne!(sharp.rgb, blurred.rgb);
        // Depth belongs to the current pose.
        assert_eq!(sharp.depth, blurred.depth);
        world.atmosphere.haze = 0.5;
        world.atmosphere.haze_color = [0.9, 0.2, 0.2];
        let hazy = render(
            &RenderScene::new(&world)?,
            &camera,
            &pose,
            &flat(RenderMode::Textured),
        )?;
        let red = |img: &image::RgbImage| {
            img.pixels()
                .map(|p| p.0[0] as f64 - p.0[2] as f64)
                .sum::<f64>()
        };
        assert!(red(&hazy.rgb) > red(&sharp.rgb) + 1000.0);
        Ok(())
    }

    /// Extra triangles (people) are drawn without the grid and hide what is behind them; the
    /// renderer is `Send` and the scene `Sync`, as rayon over frames needs.
    #[test]
    fn render_extra_triangles_occlude() -> R {
        fn send_sync<S: Send, T: Send + Sync>() {}
        send_sync::<Renderer, RenderScene>();
        let world = box_world();
        let scene = RenderScene::new(&world)?;
        let camera = Camera::from_hfov(64, 48, 1.0)?;
        // Looking along +y from y = 0.5 at the far wall (y = 5).
        let pose = look_at([2.0, 0.5, 1.5], [2.0, 5.0, 1.5])?;
        let mut r = Renderer::new();
        let before = r
            .render(&scene, &camera, &pose, &flat(RenderMode::Shaded), &[])?
            .clone();
        let centre = 24 * 64 + 32;
        assert!(
            (before.depth[centre] - 4.5).abs() < 1e-3,
            "{}",
            before.depth[centre]
        );
        // A person-sized quad 2 m ahead, material 0, no plane.
        let mut person = World::default();
        quad(
            &mut person,
            [
                [1.7, 2.5, 0.0],
                [2.3, 2.5, 0.0],
                [2.3, 2.5, 1.8],
                [1.7, 2.5, 1.8],
            ],
            0,
            0,
        );
        let out = r.render(
            &scene,
            &camera,
            &pose,
            &flat(RenderMode::Shaded),
            &person.triangles,
        )?;
        assert!(
            (out.depth[centre] - 2.0).abs() < 1e-3,
            "{}",
            out.depth[centre]
        );
        assert_eq!(out.plane[centre], 0);
        assert_ne!(out.rgb, before.rgb);
        // The next frame without people no longer shows it.
        let after = r.render(&scene, &camera, &pose, &flat(RenderMode::Shaded), &[])?;
        assert_eq!(after.depth, before.depth);
        Ok(())
    }

    /// A world of one wall at x = 2 facing −x, from y = −3 to `y_max` and z = −2 to 4, showing
    /// an image of one colour, `unlit` (a scan) or lit.
    fn image_wall(texel: [u8; 3], y_max: f32, unlit: bool) -> World {
        let image = std::sync::Arc::new(image::RgbImage::from_pixel(2, 2, image::Rgb(texel)));
        let mut w = World::default();
        let m = w.add_material(Material {
            pattern: Pattern::Image(image),
            unlit,
            ..Material::plain("scan", [1.0; 3])
        });
        let corners = [
            [2.0, -3.0, -2.0],
            [2.0, -3.0, 4.0],
            [2.0, y_max, 4.0],
            [2.0, y_max, -2.0],
        ];
        quad(&mut w, corners, m, 0);
        w
    }

    /// An unlit surface (a scan's photograph) renders as its texture's colour under the default
    /// atmosphere, whatever lamp hangs before it; a lit twin does not. `Dim` halves its light
    /// (ambient 0.25 → 0.125), `SomeLightsOff` leaves it, and haze still veils it.
    #[test]
    fn render_unlit_surface_shows_its_texture_as_it_is() -> R {
        let texel = [200u8, 120, 60];
        let world_with = |unlit: bool| {
            // A wall at x = 2 facing the camera (its normal is −x), filling the view.
            let mut w = image_wall(texel, 3.0, unlit);
            w.lights.push(Light {
                position: Point3::new(1.0, 0.0, 1.0),
                intensity: 1.0,
                on: true,
                fixture: None,
            });
            w
        };
        let camera = Camera::from_hfov(32, 24, 1.0)?;
        let pose = look_at([0.0, 0.0, 1.0], [2.0, 0.0, 1.0])?;
        let shot = |w: &World| -> R<image::RgbImage> {
            let scene = RenderScene::new(w)?;
            Ok(render(&scene, &camera, &pose, &flat(RenderMode::Textured))?.rgb)
        };
        // Within the sensor's sRGB fit (1.2 levels) of `want` at every pixel.
        let near = |img: &image::RgbImage, want: [u8; 3]| {
            img.pixels()
                .all(|p| (0..3).all(|k| p.0[k].abs_diff(want[k]) <= 2))
        };
        let unlit = world_with(true);
        let img = shot(&unlit)?;
        assert!(near(&img, texel), "{:?}", img.get_pixel(16, 12));
        assert!(!near(&shot(&world_with(false))?, texel));

        let scaled = |f: f32| {
            texel.map(|c| scene::linear_to_srgb8(scene::srgb_to_linear(f32::from(c) / 255.0) * f))
        };
        let mut dim = unlit.clone();
        crate::variants::apply(&mut dim, crate::Variant::Dim, 1);
        let img = shot(&dim)?;
        assert!(near(&img, scaled(0.5)), "{:?}", img.get_pixel(16, 12));
        let mut off = unlit.clone();
        crate::variants::apply(&mut off, crate::Variant::SomeLightsOff, 1);
        assert!(near(&shot(&off)?, texel));
        let mut hazy = unlit;
        hazy.atmosphere.haze = 0.3;
        hazy.atmosphere.haze_color = [0.2, 0.2, 0.9];
        let img = shot(&hazy)?;
        assert!(img.get_pixel(16, 12).0[2] > texel[2] + 20);
        Ok(())
    }

    /// A scan's gap (nothing seen) takes the colour around it in the photo-like modes and keeps
    /// depth 0; a lit model's gap stays the background's black.
    #[test]
    fn render_a_scans_gaps_take_the_colours_around_them() -> R {
        let texel = [200u8, 120, 60];
        // Half a wall at x = 2 (the right half of the view): the left half sees nothing.
        let world_with = |unlit: bool| image_wall(texel, 0.0, unlit);
        let camera = Camera::from_hfov(32, 24, 1.0)?;
        let pose = look_at([0.0, 0.0, 1.0], [2.0, 0.0, 1.0])?;
        for unlit in [true, false] {
            let scene = RenderScene::new(&world_with(unlit))?;
            for mode in [RenderMode::Textured, RenderMode::Shaded] {
                let out = render(&scene, &camera, &pose, &flat(mode))?;
                let gaps: Vec<_> = out
                    .rgb
                    .pixels()
                    .zip(&out.depth)
                    .filter(|(_, d)| **d == 0.0)
                    .map(|(p, _)| p.0)
                    .collect();
                assert!(gaps.len() > 100, "{} gap pixels", gaps.len());
                let seen = out.rgb.get_pixel(28, 12).0;
                for p in gaps {
                    if unlit {
                        assert!(
                            (0..3).all(|k| p[k].abs_diff(seen[k]) <= 5),
                            "{p:?} {seen:?}"
                        );
                    } else {
                        assert_eq!(p, [0, 0, 0], "{mode:?}");
                    }
                }
            }
        }
        Ok(())
    }

    /// The AVX2 build of a frame and the portable one do the same operations in the same
    /// order, so they give the same images, depths and planes (the reference frames of
    /// `tests/render_reference.rs` check only the build the testing CPU runs).
    #[test]
    fn render_portable_build_agrees_with_the_dispatched_one() -> R {
        let mut world = box_world();
        world.atmosphere.haze = 0.1;
        let scene = RenderScene::new(&world)?;
        let pose = look_at([1.0, 1.0, 1.5], [4.0, 4.0, 1.0])?;
        let distorted = Camera::new(
            96,
            72,
            60.0,
            60.0,
            47.5,
            35.5,
            Distortion::from_array([-0.3, 0.08, 0.001, -0.001, 0.0]),
        )?;
        for camera in [Camera::from_hfov(96, 72, 1.2)?, distorted] {
            for mode in RenderMode::ALL {
                let opts = RenderOptions {
                    mode,
                    seed: 7,
                    ..RenderOptions::default()
                };
                let dispatched = Renderer::new()
                    .render(&scene, &camera, &pose, &opts, &[])?
                    .clone();
                let mut portable = Renderer::new();
                let cam = portable.lens.update(&camera)?;
                portable.frame(&scene, cam, &camera, &pose, &opts, &[]);
                assert!(portable.out == dispatched, "{mode}");
            }
        }
        Ok(())
    }

    #[test]
    fn render_mode_names_round_trip() {
        for m in RenderMode::ALL {
            assert_eq!(m.name().parse::<RenderMode>(), Ok(m));
            assert_eq!(m.to_string(), m.name());
        }
        assert!("wireframe".parse::<RenderMode>().is_err());
    }

    /// A camera passing through a doorway of the default building is lit like one a step
    /// before it: the doorway's low ceiling must not drop the rooms' lamps (it once rendered
    /// such frames a third darker, which a scene-cut detector took for cuts).
    #[test]
    fn doorways_are_lit_like_the_rooms_around_them() -> R {
        let world = crate::procedural::default_world(1, crate::Variant::Normal);
        let scene = RenderScene::new(&world)?;
        let camera = geom::Camera::from_hfov(160, 120, 1.2)?;
        let storey_ceiling = |floor: f32| {
            world
                .regions
                .iter()
                .filter(|r| (r.floor_z - floor).abs() < 0.05)
                .fold(0f32, |c, r| c.max(r.ceiling_z))
        };
        let mut doorways = 0;
        let mut renderer = Renderer::new();
        let mut mean = |pose: &Pose| -> R<f64> {
            let img = renderer.render(&scene, &camera, pose, &RenderOptions::default(), &[])?;
            let raw = img.rgb.as_raw();
            Ok(raw.iter().map(|&c| f64::from(c)).sum::<f64>() / raw.len() as f64)
        };
        for r in world
            .regions
            .iter()
            .filter(|r| r.ceiling_z < storey_ceiling(r.floor_z) - 0.3)
        {
            // Through the doorway: along its short side.
            let c = [(r.min[0] + r.max[0]) / 2.0, (r.min[1] + r.max[1]) / 2.0];
            let (dx, dy) = (r.max[0] - r.min[0], r.max[1] - r.min[1]);
            let dir = if dx < dy { [1.0, 0.0] } else { [0.0, 1.0] };
            let z = f64::from(r.floor_z) + 1.3;
            let at = |back: f64| {
                [
                    f64::from(c[0]) - back * dir[0],
                    f64::from(c[1]) - back * dir[1],
                    z,
                ]
            };
            let ahead = |back: f64| [at(back)[0] + 3.0 * dir[0], at(back)[1] + 3.0 * dir[1], z];
            let inside = mean(&look_at(at(0.0), ahead(0.0))?)?;
            let before = mean(&look_at(at(0.6), ahead(0.6))?)?;
            assert!(
                inside > 0.85 * before,
                "doorway at {c:?}: {inside:.1} against {before:.1} a step before"
            );
            doorways += 1;
            if doorways == 6 {
                break;
            }
        }
        assert!(doorways > 0, "the default building has no doorway regions");
        Ok(())
    }
}
