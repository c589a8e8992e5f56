//! Image views: how a photo becomes a network input.
//!
//! Each localisation method sees the image its own way (a 160x120 grey CLAHE view for ceiling
//! cameras, 256x256 RGB in [-1, 1] for 6-DoF regression, ...). A [`ViewSpec`] describes a view as
//! a list of [`Op`]s; it is serialisable and has a one-line text form (grammar in [`spec`]'s
//! module doc, e.g. `gray,resize=160x120,clahe=2.0/8`), so every checkpoint stores the exact view
//! it was trained on. [`ViewSpec::apply`] turns a decoded image into a [`View`]: CHW `f32`.
//!
//! # Entry points
//! - [`ViewSpec::preset`] / [`ViewSpec::resolve`] / `"…".parse::<ViewSpec>()`, then
//!   [`ViewSpec::apply`] (or [`ViewSpec::apply_with`] with a reusable [`Scratch`]).
//! - [`gray_clahe_view`] / [`gray_clahe_view_into`]: the hot ceiling-camera view without
//!   allocations (beyond the output) and without a full-size grey image.
//! - The single ops, kornia-style (`&src, &mut dst` of the output size, sizes checked first):
//!   [`rgb_to_gray`], [`resize_gray`], [`resize_rgb`], [`clahe`], [`equalize`], [`grad_mag`],
//!   [`canny`].
//!
//! # Conventions
//! - Ops before `norm` work on 8-bit images ([`image::GrayImage`] / [`image::RgbImage`]).
//! - The tensor is `x / 255` without `norm`; `norm=pm1` gives `x / 127.5 - 1`; mean/std gives
//!   `(x / 255 - mean) / std`.
//! - OpenCV parity: grey conversion, `INTER_AREA` downscaling, CLAHE and `equalizeHist` are
//!   bit-identical to opencv-python 5.0 (checked against fixtures made by OpenCV, see
//!   `tests/data/clahe/README.md`). Canny follows OpenCV's algorithm (every pixel agrees with
//!   `cv2.Canny` on the fixtures); bilinear upscaling does not promise OpenCV's pixels.
//! - Decoding is not part of a view. JPEG decoders differ by a few levels on some pixels
//!   (the `image` crate vs OpenCV's libjpeg-turbo), so views of JPEGs are bit-identical to
//!   OpenCV's only when both start from the same decoded pixels. Inputs other than 8-bit grey or
//!   RGB go through [`image::DynamicImage::to_rgb8`] (alpha dropped as OpenCV's `imread` does;
//!   16-bit values are scaled by the `image` crate, not shifted by 8 as in OpenCV).
//! - Speed: the hot loops are written so that the compiler vectorises them, and the area resize
//!   and CLAHE are also compiled for AVX2 and chosen at run time (the only `unsafe` here is that
//!   call, after `is_x86_feature_detected!`). Both builds do the same integer and `f32`
//!   operations in the same order (Rust never fuses multiply-adds), so they give the same pixels;
//!   tests compare them.

mod canny;
mod clahe;
mod equalize;
mod gradient;
mod gray;
mod normalize;
#[cfg(test)]
mod parity_tests;
mod resize;
mod round;
pub mod spec;

use std::borrow::Cow;

use image::{DynamicImage, GrayImage, RgbImage};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{ImgprocError, Result};

pub use canny::canny;
pub use clahe::{MAX_TILES, clahe};
pub use equalize::equalize;
pub use gradient::{Kernel, grad_mag};
pub use gray::{B_WEIGHT, G_WEIGHT, GRAY_SHIFT, R_WEIGHT, gray_of, rgb_to_gray};
pub use normalize::{IMAGENET_MEAN, IMAGENET_STD, Norm, View};
pub use resize::{resize_gray, resize_rgb};
pub use spec::{MAX_SIZE, Op, PRESET_NAMES, ViewSpec};

use clahe::{ClaheScratch, clahe_with};
use gray::GrayRows;
use resize::{AreaScratch, area_resize, is_downscale, resize_gray_with, resize_rgb_with};

/// Reusable working memory for views: resize tables and accumulators, CLAHE tables, the
/// intermediate small image. One per thread; reusing it makes [`gray_clahe_view_into`]
/// allocation-free after the first call for a given size.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    area: AreaScratch,
    clahe: ClaheScratch,
    row: Vec<u8>,
    small: GrayImage,
    full: GrayImage,
}

impl Scratch {
    /// Empty scratch space; buffers grow on first use.
    pub fn new() -> Self {
        Self::default()
    }
}

/// Makes `img` `w x h` without allocating when it already is.
fn ensure_size(img: &mut GrayImage, (w, h): (u32, u32)) {
    if img.dimensions() != (w, h) {
        *img = GrayImage::new(w, h);
    }
}

/// Grey conversion fused with the resize to the size of `dst`: bit-identical to `rgb_to_gray`
/// then `resize_gray`, but when downscaling the grey image is made one row at a time.
fn gray_resize_with(rgb: &RgbImage, dst: &mut GrayImage, scratch: &mut Scratch) -> Result<()> {
    let ((sw, sh), (dw, dh)) = (rgb.dimensions(), dst.dimensions());
    if sw == 0 || sh == 0 || dw == 0 || dh == 0 {
        return Err(ImgprocError::Size(format!(
            "gray+resize {sw}x{sh} -> {dw}x{dh}: sizes must be non-zero"
        )));
    }
    if (sw, sh) != (dw, dh) && is_downscale(sw, sh, dw, dh) {
        let mut rows = GrayRows::new(rgb, &mut scratch.row);
        area_resize(
            &mut rows,
            (sw as usize, sh as usize),
            1,
            dst,
            (dw as usize, dh as usize),
            &mut scratch.area,
        );
        return Ok(());
    }
    ensure_size(&mut scratch.full, (sw, sh));
    rgb_to_gray(rgb, &mut scratch.full)?;
    resize_gray_with(&scratch.full, dst, &mut scratch.area)
}

/// The ceiling-camera view into `dst`: grey (OpenCV 5 BT.601) → resize to the size of `dst`
/// (`INTER_AREA`) → CLAHE(`clip`, `tiles` x `tiles`); bit-identical to OpenCV's
/// `cvtColor` → `resize` → `createCLAHE().apply()` and allocation-free once `scratch` has seen
/// this size.
pub fn gray_clahe_view_into(
    rgb: &RgbImage,
    dst: &mut GrayImage,
    clip: f32,
    tiles: u32,
    scratch: &mut Scratch,
) -> Result<()> {
    clahe::check_params(clip, tiles)?;
    let mut small = std::mem::take(&mut scratch.small);
    ensure_size(&mut small, dst.dimensions());
    let result = gray_resize_with(rgb, &mut small, scratch)
        .and_then(|()| clahe_with(&small, dst, clip, tiles, &mut scratch.clahe));
    scratch.small = small;
    result
}

/// [`gray_clahe_view_into`] returning a new `width x height` image.
pub fn gray_clahe_view(
    rgb: &RgbImage,
    width: u32,
    height: u32,
    clip: f32,
    tiles: u32,
    scratch: &mut Scratch,
) -> Result<GrayImage> {
    if width == 0 || height == 0 {
        return Err(ImgprocError::Size(format!(
            "gray+clahe view {width}x{height}: sizes must be non-zero"
        )));
    }
    let mut out = GrayImage::new(width, height);
    gray_clahe_view_into(rgb, &mut out, clip, tiles, scratch)?;
    Ok(out)
}

/// The image between ops: grey or RGB, borrowed from the caller until an op changes it.
enum Work<'a> {
    Gray(Cow<'a, GrayImage>),
    Rgb(Cow<'a, RgbImage>),
}

impl Work<'_> {
    fn dimensions(&self) -> (u32, u32) {
        match self {
            Work::Gray(g) => g.dimensions(),
            Work::Rgb(c) => c.dimensions(),
        }
    }
}

/// Top-left corner of a `cw x ch` crop of a `w x h` image.
fn crop_origin(
    (w, h): (u32, u32),
    (cw, ch): (u32, u32),
    random: Option<&mut ChaCha8Rng>,
) -> Result<(u32, u32)> {
    if cw > w || ch > h || cw == 0 || ch == 0 {
        return Err(ImgprocError::Size(format!(
            "crop {cw}x{ch} does not fit in a {w}x{h} image"
        )));
    }
    Ok(match random {
        Some(rng) => (rng.random_range(0..=w - cw), rng.random_range(0..=h - ch)),
        None => ((w - cw) / 2, (h - ch) / 2),
    })
}

impl ViewSpec {
    /// Applies the spec to a decoded image. `seed` drives the random ops (`random-crop`); the
    /// same seed gives the same view.
    pub fn apply(&self, img: &DynamicImage, seed: u64) -> Result<View> {
        self.apply_with(img, seed, &mut Scratch::new())
    }

    /// [`ViewSpec::apply`] with reusable working memory.
    pub fn apply_with(&self, img: &DynamicImage, seed: u64, scratch: &mut Scratch) -> Result<View> {
        // A grey source stays grey when the spec converts to grey anyway: OpenCV's grey of
        // (v, v, v) is v, so skipping the round trip through RGB changes no pixel.
        let work = match img {
            DynamicImage::ImageLuma8(g) if self.channels() == 1 => Work::Gray(Cow::Borrowed(g)),
            DynamicImage::ImageRgb8(c) => Work::Rgb(Cow::Borrowed(c)),
            other => Work::Rgb(Cow::Owned(other.to_rgb8())),
        };
        self.run(work, seed, scratch)
    }

    /// Applies the spec to an RGB image (no conversion of the input).
    pub fn apply_rgb(&self, img: &RgbImage, seed: u64, scratch: &mut Scratch) -> Result<View> {
        self.run(Work::Rgb(Cow::Borrowed(img)), seed, scratch)
    }

    fn run(&self, mut work: Work<'_>, seed: u64, scratch: &mut Scratch) -> Result<View> {
        self.validate()?;
        let mut rng = None;
        let mut i = 0;
        while i < self.ops.len() {
            let op = &self.ops[i];
            i += 1;
            work = match (op, work) {
                (Op::Resize { width, height }, Work::Gray(g)) => {
                    let mut out = GrayImage::new(*width, *height);
                    resize_gray_with(&g, &mut out, &mut scratch.area)?;
                    Work::Gray(Cow::Owned(out))
                }
                (Op::Resize { width, height }, Work::Rgb(c)) => {
                    let mut out = RgbImage::new(*width, *height);
                    resize_rgb_with(&c, &mut out, &mut scratch.area)?;
                    Work::Rgb(Cow::Owned(out))
                }
                (Op::CenterCrop { width, height } | Op::RandomCrop { width, height }, w) => {
                    let random = match op {
                        Op::RandomCrop { .. } => {
                            Some(rng.get_or_insert_with(|| ChaCha8Rng::seed_from_u64(seed)))
                        }
                        _ => None,
                    };
                    let (x, y) = crop_origin(w.dimensions(), (*width, *height), random)?;
                    match w {
                        Work::Gray(g) => Work::Gray(Cow::Owned(
                            image::imageops::crop_imm(g.as_ref(), x, y, *width, *height).to_image(),
                        )),
                        Work::Rgb(c) => Work::Rgb(Cow::Owned(
                            image::imageops::crop_imm(c.as_ref(), x, y, *width, *height).to_image(),
                        )),
                    }
                }
                (Op::Gray, Work::Rgb(c)) => {
                    // Fuse with a following resize: no full-size grey image.
                    let size = match self.ops.get(i) {
                        Some(Op::Resize { width, height }) => {
                            i += 1;
                            (*width, *height)
                        }
                        _ => c.dimensions(),
                    };
                    let mut out = GrayImage::new(size.0, size.1);
                    if size == c.dimensions() {
                        rgb_to_gray(&c, &mut out)?;
                    } else {
                        gray_resize_with(&c, &mut out, scratch)?;
                    }
                    Work::Gray(Cow::Owned(out))
                }
                (Op::Gray, w @ Work::Gray(_)) => w,
                (Op::Clahe { clip, tiles }, Work::Gray(g)) => {
                    let mut out = GrayImage::new(g.width(), g.height());
                    clahe_with(&g, &mut out, *clip, *tiles, &mut scratch.clahe)?;
                    Work::Gray(Cow::Owned(out))
                }
                (Op::Equalize, Work::Gray(g)) => {
                    let mut out = GrayImage::new(g.width(), g.height());
                    equalize(&g, &mut out)?;
                    Work::Gray(Cow::Owned(out))
                }
                (Op::GradMag { kernel }, Work::Gray(g)) => {
                    let mut out = GrayImage::new(g.width(), g.height());
                    grad_mag(&g, &mut out, *kernel)?;
                    Work::Gray(Cow::Owned(out))
                }
                (Op::Canny { low, high }, Work::Gray(g)) => {
                    let mut out = GrayImage::new(g.width(), g.height());
                    canny(&g, &mut out, *low, *high)?;
                    Work::Gray(Cow::Owned(out))
                }
                (Op::Normalize(_), w) => w, // applied by the tensor conversion below
                (op, Work::Rgb(_)) => {
                    return Err(ImgprocError::Param(format!(
                        "{op:?} needs a grey image; put `gray` before it"
                    )));
                }
            };
        }
        let norm = self.norm();
        match work {
            Work::Gray(g) => View::from_u8(g.as_raw(), 1, g.dimensions(), norm),
            Work::Rgb(c) => View::from_u8(c.as_raw(), 3, c.dimensions(), norm),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photo(w: u32, h: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            image::Rgb([
                (x * 7 + y * 3) as u8,
                ((x * x + y) % 251) as u8,
                ((x ^ y) * 5) as u8,
            ])
        })
    }

    #[test]
    fn fused_gray_resize_equals_the_two_steps() -> Result<()> {
        let src = photo(97, 61);
        let mut scratch = Scratch::new();
        for (w, h) in [(40, 30), (97, 61), (33, 61), (20, 20), (150, 80)] {
            let mut gray = GrayImage::new(97, 61);
            rgb_to_gray(&src, &mut gray)?;
            let mut two_steps = GrayImage::new(w, h);
            resize_gray(&gray, &mut two_steps)?;
            let mut fused = GrayImage::new(w, h);
            gray_resize_with(&src, &mut fused, &mut scratch)?;
            assert_eq!(fused, two_steps, "{w}x{h}");
        }
        Ok(())
    }

    #[test]
    fn fast_path_equals_the_spec() -> Result<()> {
        let src = photo(640, 480);
        let mut scratch = Scratch::new();
        let fast = gray_clahe_view(&src, 160, 120, 2.0, 8, &mut scratch)?;
        let again = gray_clahe_view(&src, 160, 120, 2.0, 8, &mut scratch)?;
        assert_eq!(fast, again);
        let view = ViewSpec::preset("gray160")?.apply(&DynamicImage::ImageRgb8(src), 0)?;
        let expect: Vec<f32> = fast.as_raw().iter().map(|&v| v as f32 / 255.0).collect();
        assert_eq!((view.channels, view.width, view.height), (1, 160, 120));
        assert_eq!(view.data, expect);
        Ok(())
    }

    #[test]
    fn grey_sources_give_the_same_view_as_rgb_ones() -> Result<()> {
        let gray = GrayImage::from_fn(64, 48, |x, y| image::Luma([(x * 3 + y * 2) as u8]));
        let rgb = DynamicImage::ImageLuma8(gray.clone()).to_rgb8();
        for name in ["gray160", "gradmag", "edges"] {
            let spec = ViewSpec::preset(name)?;
            let a = spec.apply(&DynamicImage::ImageLuma8(gray.clone()), 1)?;
            let b = spec.apply(&DynamicImage::ImageRgb8(rgb.clone()), 1)?;
            assert_eq!(a, b, "{name}");
        }
        // An RGB view of a grey image has three equal channels.
        let v = ViewSpec::preset("rgb256")?.apply(&DynamicImage::ImageLuma8(gray), 0)?;
        assert_eq!(v.channels, 3);
        let plane = 256 * 256;
        assert_eq!(v.data[..plane], v.data[plane..2 * plane]);
        Ok(())
    }

    #[test]
    fn random_crop_follows_the_seed() -> Result<()> {
        let img = DynamicImage::ImageRgb8(photo(64, 48));
        let spec: ViewSpec = "random-crop=16x16".parse()?;
        let a = spec.apply(&img, 7)?;
        assert_eq!(a, spec.apply(&img, 7)?);
        let distinct = (0..20u64)
            .map(|s| spec.apply(&img, s).map(|v| v.data))
            .collect::<Result<Vec<_>>>()?;
        assert!(distinct.iter().any(|d| *d != distinct[0]));
        Ok(())
    }

    #[test]
    fn center_crop_takes_the_middle() -> Result<()> {
        let img = GrayImage::from_fn(5, 3, |x, y| image::Luma([(10 * y + x) as u8]));
        let spec: ViewSpec = "gray,center-crop=2x1".parse()?;
        let v = spec.apply(&DynamicImage::ImageLuma8(img), 0)?;
        // offset ((5 - 2) / 2, (3 - 1) / 2) = (1, 1): values 11, 12
        assert_eq!(v.data, vec![11.0 / 255.0, 12.0 / 255.0]);
        Ok(())
    }

    #[test]
    fn errors_not_panics() -> Result<()> {
        let img = DynamicImage::ImageRgb8(photo(32, 24));
        assert!(
            "center-crop=33x10"
                .parse::<ViewSpec>()?
                .apply(&img, 0)
                .is_err()
        );
        assert!(
            "random-crop=10x25"
                .parse::<ViewSpec>()?
                .apply(&img, 0)
                .is_err()
        );
        let bad = ViewSpec {
            ops: vec![Op::Clahe {
                clip: 2.0,
                tiles: 8,
            }],
        };
        assert!(bad.apply(&img, 0).is_err());
        let empty = DynamicImage::ImageRgb8(RgbImage::new(0, 0));
        assert!(ViewSpec::preset("gray160")?.apply(&empty, 0).is_err());
        assert!(ViewSpec::preset("rgb256")?.apply(&empty, 0).is_err());
        let mut scratch = Scratch::new();
        let src = photo(32, 24);
        assert!(gray_clahe_view(&src, 0, 10, 2.0, 8, &mut scratch).is_err());
        assert!(gray_clahe_view(&src, 16, 12, 0.0, 8, &mut scratch).is_err());
        assert!(gray_clahe_view(&src, 16, 12, 2.0, 0, &mut scratch).is_err());
        Ok(())
    }

    #[test]
    fn presets_have_the_documented_shapes_and_ranges() -> Result<()> {
        let img = DynamicImage::ImageRgb8(photo(640, 480));
        let expect = [
            ("gray160", (1, 160, 120), (0.0, 1.0)),
            ("rgb256", (3, 256, 256), (-1.0, 1.0)),
            ("rgb224", (3, 224, 224), (-1.0, 1.0)),
            ("place240", (3, 240, 240), (-2.2, 2.7)),
            ("gradmag", (1, 160, 120), (0.0, 1.0)),
            ("edges", (1, 160, 120), (0.0, 1.0)),
        ];
        for (name, shape, (lo, hi)) in expect {
            let v = ViewSpec::preset(name)?.apply(&img, 0)?;
            assert_eq!((v.channels, v.width, v.height), shape, "{name}");
            assert_eq!(v.data.len(), (shape.0 * shape.1 * shape.2) as usize);
            assert!(
                v.data.iter().all(|&x| x >= lo && x <= hi),
                "{name} out of range"
            );
        }
        Ok(())
    }
}
