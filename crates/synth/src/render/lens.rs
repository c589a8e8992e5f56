//! The pinhole raster behind a camera, and for a distorted lens the per-pixel map from output
//! pixels to positions on that raster (computed once per camera, then cached).

use crate::error::{Result, SynthError};
use geom::Camera;
use nalgebra::{Point2, Vector2};

/// Most pixels a raster may have (a larger camera is a mistake, not a render).
const MAX_PIXELS: usize = 1 << 26;

/// How far past the image (in multiples of its size) the raster of a strongly distorted lens
/// may reach; beyond it output pixels stay empty rather than the raster growing without bound.
const MAX_SPREAD: f64 = 1.5;

/// An undistorted pinhole camera the rasterizer draws into: `x = fx·X/Z + cx`, pixel centres at
/// integer coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RasterCam {
    /// Width, pixels.
    pub w: usize,
    /// Height, pixels.
    pub h: usize,
    /// Focal length along x, pixels.
    pub fx: f32,
    /// Focal length along y, pixels.
    pub fy: f32,
    /// Principal point x.
    pub cx: f32,
    /// Principal point y.
    pub cy: f32,
}

/// Where an output pixel of a distorted camera looks on the raster: the exact (fractional)
/// position, for interpolating depth and texture coordinates, and the nearest raster pixel, for
/// which triangle is seen there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LensSample {
    /// Raster x.
    pub sx: f32,
    /// Raster y.
    pub sy: f32,
    /// Index of the nearest raster pixel; `u32::MAX` where the lens model has no ray.
    pub idx: u32,
}

/// The raster and lens map of the camera last used.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lens {
    camera: Option<Camera>,
    /// The raster.
    pub raster: Option<RasterCam>,
    /// Per output pixel (row-major); empty for a lens without distortion, where output pixels
    /// are raster pixels.
    pub map: Vec<LensSample>,
}

impl Lens {
    /// Makes the raster and map fit `camera` (no work when it is the camera of the last call).
    pub fn update(&mut self, camera: &Camera) -> Result<RasterCam> {
        if let (Some(c), Some(r)) = (&self.camera, self.raster)
            && c == camera
        {
            return Ok(r);
        }
        camera.validate()?;
        let (w, h) = (camera.width as usize, camera.height as usize);
        if w.checked_mul(h).is_none_or(|n| n > MAX_PIXELS) {
            return Err(SynthError::Config(format!(
                "image size {w}x{h} is too large to render"
            )));
        }
        self.map.clear();
        let raster = if camera.dist.is_zero() {
            RasterCam {
                w,
                h,
                fx: camera.fx as f32,
                fy: camera.fy as f32,
                cx: camera.cx as f32,
                cy: camera.cy as f32,
            }
        } else {
            self.build_map(camera)?
        };
        self.camera = Some(*camera);
        self.raster = Some(raster);
        Ok(raster)
    }

    /// The pinhole positions of every output pixel, the raster that covers them, and the map.
    fn build_map(&mut self, camera: &Camera) -> Result<RasterCam> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut pos: Vec<Option<(f64, f64)>> = Vec::with_capacity(w * h);
        // Limits of the raster around the image, in pinhole pixels.
        let (lim_x0, lim_x1) = (-MAX_SPREAD * w as f64, (1.0 + MAX_SPREAD) * w as f64);
        let (lim_y0, lim_y1) = (-MAX_SPREAD * h as f64, (1.0 + MAX_SPREAD) * h as f64);
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for y in 0..h {
            for x in 0..w {
                let px = Point2::new(x as f64, y as f64);
                let n = camera.normalized(&px);
                let d = Vector2::new(
                    (px.x - camera.cx) / camera.fx,
                    (px.y - camera.cy) / camera.fy,
                );
                // The lens model must map the ray back onto the pixel (it may fold over or fail
                // to invert far outside a real lens's field).
                let back = camera.dist.apply(n);
                let ok = n.x.is_finite() && n.y.is_finite() && (back - d).norm() < 1e-6;
                let p = (camera.fx * n.x + camera.cx, camera.fy * n.y + camera.cy);
                let inside = p.0 >= lim_x0 && p.0 <= lim_x1 && p.1 >= lim_y0 && p.1 <= lim_y1;
                if ok && inside {
                    x0 = x0.min(p.0);
                    x1 = x1.max(p.0);
                    y0 = y0.min(p.1);
                    y1 = y1.max(p.1);
                    pos.push(Some(p));
                } else {
                    pos.push(None);
                }
            }
        }
        if x0 > x1 {
            // No pixel has a ray: an empty raster pixel keeps the renderer's loops trivial.
            self.map = vec![
                LensSample {
                    sx: 0.0,
                    sy: 0.0,
                    idx: u32::MAX,
                };
                w * h
            ];
            return Ok(RasterCam {
                w: 1,
                h: 1,
                fx: camera.fx as f32,
                fy: camera.fy as f32,
                cx: 0.0,
                cy: 0.0,
            });
        }
        // One pixel of margin so the nearest raster pixel of every sample exists.
        let ox = x0.floor() - 1.0;
        let oy = y0.floor() - 1.0;
        let rw = (x1.ceil() - ox) as usize + 2;
        let rh = (y1.ceil() - oy) as usize + 2;
        if rw.checked_mul(rh).is_none_or(|n| n > MAX_PIXELS) {
            return Err(SynthError::Config(format!(
                "the lens of a {w}x{h} camera needs too large a raster ({rw}x{rh})"
            )));
        }
        self.map = pos
            .iter()
            .map(|p| match p {
                Some((px, py)) => {
                    let sx = px - ox;
                    let sy = py - oy;
                    let ix = (sx + 0.5).floor() as usize;
                    let iy = (sy + 0.5).floor() as usize;
                    LensSample {
                        sx: sx as f32,
                        sy: sy as f32,
                        idx: (iy.min(rh - 1) * rw + ix.min(rw - 1)) as u32,
                    }
                }
                None => LensSample {
                    sx: 0.0,
                    sy: 0.0,
                    idx: u32::MAX,
                },
            })
            .collect();
        Ok(RasterCam {
            w: rw,
            h: rh,
            fx: camera.fx as f32,
            fy: camera.fy as f32,
            cx: (camera.cx - ox) as f32,
            cy: (camera.cy - oy) as f32,
        })
    }
}
