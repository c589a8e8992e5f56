//! Seeded, reproducible augmentation of training images.
//!
//! # Entry points
//! - [`augment`] / [`augment_into`]: one random draw of a whole [`AugmentConfig`], returning the
//!   augmented image and the [`LabelChange`] the label must follow.
//! - The individual ops, kornia style (`src`, `&mut dst`, parameters; `dst` can be reused across
//!   calls): [`rotate_about_center`], [`affine_jitter`], [`warp_affine`], [`adjust_brightness`],
//!   [`adjust_contrast`], [`adjust_gamma`], [`adjust_color`], [`add_gaussian_noise`],
//!   [`gaussian_blur`], [`random_erase`], [`style_randomize`]. All work on grey and RGB
//!   (`adjust_color` on RGB only).
//!
//! # Which ops keep which label
//! | op | 6-DoF pose | ceiling 3-DoF pose | place class |
//! |---|---|---|---|
//! | photometric, blur, noise, erasing, style | kept | kept | kept |
//! | rotation about the centre | **falsified** | heading `+θ` ([`LabelChange::heading_delta`]) | kept |
//! | affine jitter (scale, shear, shift) | **falsified** | **falsified** | kept |
//!
//! [`AugmentConfig::light`] (6-DoF regression) therefore has no geometric op at all;
//! [`AugmentConfig::ceiling`] adds the rotation. [`LabelChange::preserves_pose`] tells at run
//! time whether any geometric op fired.
//!
//! # Rotation is a heading change (sign derivation)
//! Take a ceiling camera at the origin with heading `h`: OpenCV axes with `z_cam` = world up,
//! image-up `−y_cam` = world `(cos h, sin h, 0)` (the heading convention of DESIGN.md), hence
//! `y_cam = (−cos h, −sin h, 0)` and `x_cam = y_cam × z_cam = (−sin h, cos h, 0)`. A ceiling
//! point at height `H` in direction `a`, `r·(cos a, sin a, H/r)`, has camera coordinates
//! `(r·sin(a − h), −r·cos(a − h), H)`, so with the principal point at the image centre it
//! projects to `u − cx = ρ·sin(a − h)`, `v − cy = −ρ·cos(a − h)` with `ρ = f·r/H`.
//! As displayed (x right, *up* = `−v`), the point sits at angle `ψ = atan2(ρ cos(a − h),
//! ρ sin(a − h)) = π/2 − a + h`, counter-clockwise from the right. Rotating the image content
//! counter-clockwise by `θ` adds `θ` to every `ψ`, which is the same as replacing `h` by `h + θ`:
//!
//! **rotating a ceiling image by `+θ` counter-clockwise (as displayed) equals turning the camera's
//! heading by `+θ` (counter-clockwise seen from above): `s = +1`, `heading_delta = +θ`.**
//!
//! (Intuition: seen from below, the ceiling is mirrored, so the camera turning counter-clockwise
//! as seen from above turns clockwise as seen in its own image, and the scene appears to turn the
//! other way, counter-clockwise.) The test `rotation_is_a_heading_change` renders coloured
//! ceiling points through exactly this projection at `h`, `h + θ` and `h − θ` and checks
//! numerically that the rotated image matches `h + θ` to within a fraction of a pixel and not
//! `h − θ`. The relation needs the principal point at the image centre; a different `(cx, cy)`
//! calls for a rotation about it ([`Affine2::rotation_about`] with [`warp_affine`]).
//!
//! # Reproducibility
//! Every random number comes from `ChaCha8Rng::seed_from_u64(seed)`, a separate ChaCha stream
//! per stage (`set_stream`), so the same image, config and seed give byte-identical output, and
//! switching one stage off does not change what the others draw. Floating-point maths is plain
//! `f32`/`f64` without fused multiply-adds, so results agree across machines that share the
//! platform's `libm` (`powf`, `exp`, `sin`).
//!
//! # Order of the stages
//! geometry (one warp: rotation, then affine jitter) → style → tone (brightness, contrast, gamma,
//! fused into one table) → colour (saturation, hue) → blur → noise → erasing. Noise after blur
//! because sensor noise is added after the optics blurred the scene; erasing last so that
//! occluders keep hard edges, as in random erasing (Zhong et al. 2020).

mod geometric;
mod photometric;
mod style;

#[cfg(test)]
mod serde_check;
#[cfg(test)]
mod test_util;

use image::{ImageBuffer, Pixel};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

pub use geometric::{
    Affine2, AffineParams, Border, LabelChange, affine_jitter, rotate_about_center, warp_affine,
};
pub use photometric::{
    EraseFill, EraseParams, EraseRect, MAX_BLUR_SIGMA, add_gaussian_noise, adjust_brightness,
    adjust_color, adjust_contrast, adjust_gamma, gaussian_blur, random_erase,
};
pub use style::{StyleParams, style_randomize};

use crate::{ImgprocError, Result};

/// A random parameter: applied with probability `p`, its value drawn uniformly from `range`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jitter {
    /// Probability of applying the op, in [0, 1].
    pub p: f64,
    /// `[min, max]` of the parameter, `min ≤ max`; the unit is in the field's name.
    pub range: [f64; 2],
}

impl Jitter {
    /// Applied with probability `p`, value uniform in `[min, max]`.
    pub const fn new(p: f64, min: f64, max: f64) -> Self {
        Jitter {
            p,
            range: [min, max],
        }
    }

    /// Never applied; `neutral` is the value that would change nothing, kept so the range stays
    /// valid for the parameter.
    pub const fn off(neutral: f64) -> Self {
        Self::new(0.0, neutral, neutral)
    }

    fn fires<R: Rng + ?Sized>(&self, rng: &mut R) -> bool {
        // Always draw, so that the stream position does not depend on p.
        rng.random::<f64>() < self.p
    }

    /// Draws the value (always, to keep the stream aligned) and returns it if the op fires.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Option<f64> {
        let fire = self.fires(rng);
        let v = lerp(self.range[0], self.range[1], rng.random::<f64>());
        fire.then_some(v)
    }

    /// As [`Self::sample`], log-uniform: for factors where `x` and `1/x` should be equally likely.
    fn sample_log<R: Rng + ?Sized>(&self, rng: &mut R) -> Option<f64> {
        let fire = self.fires(rng);
        let t = rng.random::<f64>();
        let v = lerp(self.range[0].ln(), self.range[1].ln(), t).exp();
        fire.then_some(v)
    }

    /// An error unless `p ∈ [0, 1]` and `lo ≤ min ≤ max ≤ hi`, all finite.
    fn check(&self, name: &str, lo: f64, hi: f64) -> Result<()> {
        let [a, b] = self.range;
        let ok = self.p.is_finite()
            && (0.0..=1.0).contains(&self.p)
            && a.is_finite()
            && b.is_finite()
            && lo <= a
            && a <= b
            && b <= hi;
        if ok {
            Ok(())
        } else {
            Err(ImgprocError::Param(format!(
                "{name}: need p in [0, 1] and {lo} ≤ min ≤ max ≤ {hi}; got p = {}, range = [{a}, {b}]",
                self.p
            )))
        }
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Random affine jitter: scale, shear and shift about the image centre. Falsifies pose labels
/// (see [`AffineParams`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AffineJitter {
    /// Probability of applying it, in [0, 1].
    pub p: f64,
    /// Scale factor range, > 0.
    pub scale: [f64; 2],
    /// Horizontal shear range, degrees, within ±45.
    pub shear_deg: [f64; 2],
    /// Shift range as a fraction of the width (x) and height (y), each axis drawn separately,
    /// within ±1.
    pub translate: [f64; 2],
}

impl AffineJitter {
    /// Never applied.
    pub const OFF: AffineJitter = AffineJitter {
        p: 0.0,
        scale: [1.0, 1.0],
        shear_deg: [0.0, 0.0],
        translate: [0.0, 0.0],
    };

    fn validate(&self) -> Result<()> {
        Jitter {
            p: self.p,
            range: self.scale,
        }
        .check("affine scale", f64::MIN_POSITIVE, f64::MAX)?;
        Jitter {
            p: self.p,
            range: self.shear_deg,
        }
        .check("affine shear_deg", -45.0, 45.0)?;
        Jitter {
            p: self.p,
            range: self.translate,
        }
        .check("affine translate", -1.0, 1.0)
    }

    fn sample<R: Rng + ?Sized>(&self, rng: &mut R, w: u32, h: u32) -> Option<AffineParams> {
        let fire = rng.random::<f64>() < self.p;
        let mut u = || rng.random::<f64>();
        let scale = lerp(self.scale[0].ln(), self.scale[1].ln(), u()).exp();
        let shear = lerp(self.shear_deg[0], self.shear_deg[1], u()).to_radians();
        let tx = lerp(self.translate[0], self.translate[1], u()) * f64::from(w);
        let ty = lerp(self.translate[0], self.translate[1], u()) * f64::from(h);
        fire.then_some(AffineParams {
            scale,
            shear,
            tx,
            ty,
        })
    }
}

/// Random erasing: `count` rectangles covering `area` of the image in total.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EraseJitter {
    /// Probability of erasing at all, in [0, 1].
    pub p: f64,
    /// Range of the number of rectangles (at most 64).
    pub count: [u32; 2],
    /// Range of the total erased area as a fraction of the image, within [0, 1].
    pub area: [f64; 2],
    /// Range of each rectangle's width/height ratio, > 0 (drawn log-uniformly).
    pub aspect: [f64; 2],
    /// Probability that a rectangle set is filled with noise rather than one colour, in [0, 1].
    pub noise_fill_p: f64,
}

impl EraseJitter {
    /// Never applied.
    pub const OFF: EraseJitter = EraseJitter {
        p: 0.0,
        count: [1, 1],
        area: [0.0, 0.0],
        aspect: [1.0, 1.0],
        noise_fill_p: 0.0,
    };

    /// Most rectangles per image: more than this is no longer occlusion but noise.
    pub const MAX_COUNT: u32 = 64;

    fn validate(&self) -> Result<()> {
        Jitter {
            p: self.p,
            range: self.area,
        }
        .check("erase area", 0.0, 1.0)?;
        Jitter {
            p: self.noise_fill_p,
            range: self.aspect,
        }
        .check("erase aspect / noise_fill_p", f64::MIN_POSITIVE, f64::MAX)?;
        let [c0, c1] = self.count;
        if c0 > c1 || c1 > Self::MAX_COUNT {
            return Err(ImgprocError::Param(format!(
                "erase count: need min ≤ max ≤ {}; got [{c0}, {c1}]",
                Self::MAX_COUNT
            )));
        }
        Ok(())
    }

    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Option<EraseParams> {
        let fire = rng.random::<f64>() < self.p;
        let span = u64::from(self.count[1] - self.count[0]) + 1;
        let count = self.count[0] + (rng.random::<f64>() * span as f64).floor().min((span - 1) as f64) as u32;
        let area_fraction = lerp(self.area[0], self.area[1], rng.random::<f64>());
        let fill = if rng.random::<f64>() < self.noise_fill_p {
            EraseFill::Noise
        } else {
            EraseFill::Color
        };
        fire.then_some(EraseParams {
            count,
            area_fraction,
            aspect: self.aspect,
            fill,
        })
    }
}

/// Random style randomisation (see [`style_randomize`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StyleJitter {
    /// Probability of applying it, in [0, 1].
    pub p: f64,
    /// Range of [`StyleParams::strength`], within [0, 1].
    pub strength: [f64; 2],
}

impl StyleJitter {
    /// Never applied.
    pub const OFF: StyleJitter = StyleJitter {
        p: 0.0,
        strength: [0.0, 0.0],
    };
}

/// What augmentation to apply, with what probability and strength; stored with a model so that
/// training can be repeated. Angles are in degrees here because people write these files.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AugmentConfig {
    /// Rotation about the image centre, degrees counter-clockwise as displayed. A heading
    /// change for ceiling cameras; falsifies 6-DoF poses.
    pub rotation_deg: Jitter,
    /// Scale / shear / shift jitter; falsifies pose labels.
    pub affine: AffineJitter,
    /// What fills pixels that the warp brings in from outside the image.
    pub border: Border,
    /// Texture and style randomisation.
    pub style: StyleJitter,
    /// Exposure factor (≥ 0; 1 = unchanged), drawn log-uniformly.
    pub brightness: Jitter,
    /// Contrast factor about the mean (≥ 0; 1 = unchanged), drawn log-uniformly.
    pub contrast: Jitter,
    /// Gamma exponent (> 0; 1 = unchanged), drawn log-uniformly.
    pub gamma: Jitter,
    /// Saturation factor (≥ 0; 1 = unchanged; RGB only).
    pub saturation: Jitter,
    /// Hue shift, degrees within ±180 (RGB only).
    pub hue_deg: Jitter,
    /// Gaussian blur sigma, pixels, within [0, [`MAX_BLUR_SIGMA`]].
    pub blur_sigma: Jitter,
    /// Gaussian noise sigma, grey levels, within [0, 255].
    pub noise_sigma: Jitter,
    /// Random erasing (occlusion).
    pub erase: EraseJitter,
}

impl Default for AugmentConfig {
    /// [`AugmentConfig::light`]: safe for every label, so a default can never corrupt one.
    fn default() -> Self {
        Self::light()
    }
}

/// ChaCha stream of each stage, so stages draw independently of each other.
mod stream {
    pub const GEOMETRY: u64 = 1;
    pub const STYLE: u64 = 2;
    pub const TONE: u64 = 3;
    pub const COLOR: u64 = 4;
    pub const BLUR: u64 = 5;
    pub const NOISE: u64 = 6;
    pub const ERASE: u64 = 7;
}

impl AugmentConfig {
    /// No augmentation: the output is the input.
    pub const fn none() -> Self {
        AugmentConfig {
            rotation_deg: Jitter::off(0.0),
            affine: AffineJitter::OFF,
            border: Border::Black,
            style: StyleJitter::OFF,
            brightness: Jitter::off(1.0),
            contrast: Jitter::off(1.0),
            gamma: Jitter::off(1.0),
            saturation: Jitter::off(1.0),
            hue_deg: Jitter::off(0.0),
            blur_sigma: Jitter::off(0.0),
            noise_sigma: Jitter::off(0.0),
            erase: EraseJitter::OFF,
        }
    }

    /// For 6-DoF pose regression: photometric changes of the size that lamps, windows and auto
    /// exposure cause between visits, slight defocus and sensor noise, and small occluders
    /// (people, furniture moved). No geometric op, since any warp would falsify the pose label.
    pub const fn light() -> Self {
        AugmentConfig {
            brightness: Jitter::new(0.8, 0.7, 1.4),
            contrast: Jitter::new(0.8, 0.75, 1.3),
            gamma: Jitter::new(0.5, 0.8, 1.25),
            saturation: Jitter::new(0.5, 0.7, 1.3),
            hue_deg: Jitter::new(0.3, -8.0, 8.0),
            blur_sigma: Jitter::new(0.2, 0.3, 1.0),
            noise_sigma: Jitter::new(0.4, 1.0, 5.0),
            erase: EraseJitter {
                p: 0.3,
                count: [1, 2],
                area: [0.02, 0.1],
                aspect: [0.3, 3.3],
                noise_fill_p: 0.3,
            },
            ..Self::none()
        }
    }

    /// For upward-looking ceiling cameras (3-DoF): [`Self::light`] plus a uniform rotation over the
    /// full circle, which is an exact heading change ([`LabelChange::heading_delta`]) and makes the
    /// network see every heading at every place. Black corners: see [`Border`].
    pub const fn ceiling() -> Self {
        AugmentConfig {
            rotation_deg: Jitter::new(1.0, -180.0, 180.0),
            border: Border::Black,
            ..Self::light()
        }
    }

    /// Shape over texture: strong style randomisation most of the time, stronger photometric
    /// changes and more occlusion, so a network (typically trained on synthetic renders) learns
    /// the building's geometry rather than its paint. No geometric op; combine with a rotation
    /// for ceiling cameras.
    pub const fn shape_bias() -> Self {
        AugmentConfig {
            style: StyleJitter {
                p: 0.8,
                strength: [0.5, 1.0],
            },
            brightness: Jitter::new(0.8, 0.5, 1.8),
            contrast: Jitter::new(0.8, 0.6, 1.5),
            gamma: Jitter::new(0.5, 0.7, 1.4),
            saturation: Jitter::new(0.5, 0.3, 1.5),
            hue_deg: Jitter::new(0.5, -30.0, 30.0),
            blur_sigma: Jitter::new(0.3, 0.3, 1.5),
            noise_sigma: Jitter::new(0.5, 1.0, 8.0),
            erase: EraseJitter {
                p: 0.5,
                count: [1, 4],
                area: [0.02, 0.2],
                aspect: [0.3, 3.3],
                noise_fill_p: 0.5,
            },
            ..Self::none()
        }
    }

    /// A preset by name: `none`, `light`, `ceiling`, `shape_bias`.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "none" => Some(Self::none()),
            "light" => Some(Self::light()),
            "ceiling" => Some(Self::ceiling()),
            "shape_bias" => Some(Self::shape_bias()),
            _ => None,
        }
    }

    /// An error naming the first parameter out of its range (probability outside [0, 1],
    /// negative sigma, area fraction above 1, min > max, non-finite values...).
    pub fn validate(&self) -> Result<()> {
        self.rotation_deg
            .check("rotation_deg", -360.0, 360.0)?;
        self.affine.validate()?;
        Jitter {
            p: self.style.p,
            range: self.style.strength,
        }
        .check("style strength", 0.0, 1.0)?;
        self.brightness.check("brightness", f64::MIN_POSITIVE, f64::MAX)?;
        self.contrast.check("contrast", f64::MIN_POSITIVE, f64::MAX)?;
        self.gamma.check("gamma", f64::MIN_POSITIVE, f64::MAX)?;
        self.saturation.check("saturation", 0.0, f64::MAX)?;
        self.hue_deg.check("hue_deg", -180.0, 180.0)?;
        self.blur_sigma.check("blur_sigma", 0.0, MAX_BLUR_SIGMA)?;
        self.noise_sigma.check("noise_sigma", 0.0, 255.0)?;
        self.erase.validate()
    }

    /// Whether some op can change the pixel geometry (and so a pose label).
    pub fn is_geometric(&self) -> bool {
        self.rotation_deg.p > 0.0 || self.affine.p > 0.0
    }
}

fn stage_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Augments `img` (grey or RGB) by one random draw of `cfg` from `seed`; returns the new image
/// and how the label must change.
///
/// ```
/// use imgproc::augment::{augment, AugmentConfig};
/// let img = image::RgbImage::from_pixel(32, 24, image::Rgb([120, 130, 140]));
/// let (a, change) = augment(&img, &AugmentConfig::ceiling(), 7)?;
/// let (b, _) = augment(&img, &AugmentConfig::ceiling(), 7)?;
/// assert_eq!(a, b); // same seed, same bytes
/// assert!(change.heading_delta.abs() <= std::f64::consts::PI);
/// # Ok::<(), imgproc::ImgprocError>(())
/// ```
pub fn augment<P: Pixel<Subpixel = u8>>(
    img: &ImageBuffer<P, Vec<u8>>,
    cfg: &AugmentConfig,
    seed: u64,
) -> Result<(ImageBuffer<P, Vec<u8>>, LabelChange)> {
    let mut out = ImageBuffer::new(img.width(), img.height());
    let change = augment_into(img, cfg, seed, &mut out)?;
    Ok((out, change))
}

/// As [`augment`], writing into `dst` (same size as `img`) so a training loop can reuse it.
pub fn augment_into<P: Pixel<Subpixel = u8>>(
    img: &ImageBuffer<P, Vec<u8>>,
    cfg: &AugmentConfig,
    seed: u64,
    dst: &mut ImageBuffer<P, Vec<u8>>,
) -> Result<LabelChange> {
    cfg.validate()?;
    geometric::same_size(img, dst)?;
    let cn = usize::from(P::CHANNEL_COUNT);
    if cn != 1 && cn != 3 {
        return Err(ImgprocError::Param(format!(
            "augmentation needs grey or RGB images, not {cn} channels"
        )));
    }
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 {
        return Err(ImgprocError::Size(format!(
            "cannot augment an empty {w}x{h} image"
        )));
    }
    let (wu, hu) = (w as usize, h as usize);
    // `cur` holds the image so far; ops that cannot work in place write to `tmp` and swap.
    let mut cur: Vec<u8> = img.as_raw().clone();
    let mut tmp: Vec<u8> = vec![0; cur.len()];
    let mut change = LabelChange::NONE;

    // Geometry: rotation then affine jitter, composed into one warp (one interpolation).
    let mut rng = stage_rng(seed, stream::GEOMETRY);
    let theta = cfg.rotation_deg.sample(&mut rng).map(f64::to_radians);
    let jitter = cfg.affine.sample(&mut rng, w, h);
    if theta.is_some() || jitter.is_some() {
        let (cx, cy) = geometric::image_centre(w, h);
        let mut map = Affine2::IDENTITY;
        if let Some(t) = theta {
            map = Affine2::rotation_about(t, cx, cy);
            change.heading_delta = geometric::wrap_angle(t);
        }
        if let Some(j) = jitter {
            map = map.then(&j.matrix(w, h)?);
        }
        change.pixel_map = map;
        let src = as_image::<P>(w, h, std::mem::take(&mut cur))?;
        let mut out = as_image::<P>(w, h, std::mem::take(&mut tmp))?;
        warp_affine(&src, &mut out, &map, cfg.border)?;
        cur = out.into_raw();
        tmp = src.into_raw();
    }

    let mut rng = stage_rng(seed, stream::STYLE);
    let fire = rng.random::<f64>() < cfg.style.p;
    let strength = lerp(cfg.style.strength[0], cfg.style.strength[1], rng.random::<f64>());
    if fire {
        style::style_slice(&cur, &mut tmp, wu, hu, cn, strength, &mut rng);
        std::mem::swap(&mut cur, &mut tmp);
    }

    // Tone: brightness, contrast, gamma composed into one table; the contrast mean is that of
    // the brightened image, exactly as if the ops ran one after the other.
    let mut rng = stage_rng(seed, stream::TONE);
    let brightness = cfg.brightness.sample_log(&mut rng);
    let contrast = cfg.contrast.sample_log(&mut rng);
    let gamma = cfg.gamma.sample_log(&mut rng);
    if brightness.is_some() || contrast.is_some() || gamma.is_some() {
        let mut lut = photometric::identity_lut();
        if let Some(b) = brightness {
            lut = photometric::brightness_lut(b)?;
        }
        if let Some(c) = contrast {
            let mean = photometric::mapped_mean(&cur, &lut);
            lut = photometric::compose_lut(&lut, &photometric::contrast_lut(c, mean)?);
        }
        if let Some(g) = gamma {
            lut = photometric::compose_lut(&lut, &photometric::gamma_lut(g)?);
        }
        for v in cur.iter_mut() {
            *v = lut[usize::from(*v)];
        }
    }

    let mut rng = stage_rng(seed, stream::COLOR);
    let saturation = cfg.saturation.sample(&mut rng);
    let hue = cfg.hue_deg.sample(&mut rng).map(f64::to_radians);
    if cn == 3 && (saturation.is_some() || hue.is_some()) {
        let m = photometric::color_matrix(saturation.unwrap_or(1.0), hue.unwrap_or(0.0))?;
        photometric::apply_color_matrix(&cur, &mut tmp, &m);
        std::mem::swap(&mut cur, &mut tmp);
    }

    let mut rng = stage_rng(seed, stream::BLUR);
    if let Some(sigma) = cfg.blur_sigma.sample(&mut rng) {
        photometric::blur_slice(&cur, &mut tmp, wu, hu, cn, sigma);
        std::mem::swap(&mut cur, &mut tmp);
    }

    let mut rng = stage_rng(seed, stream::NOISE);
    if let Some(sigma) = cfg.noise_sigma.sample(&mut rng) {
        photometric::add_noise_slice(&cur, &mut tmp, sigma as f32, &mut rng);
        std::mem::swap(&mut cur, &mut tmp);
    }

    let mut rng = stage_rng(seed, stream::ERASE);
    if let Some(params) = cfg.erase.sample(&mut rng) {
        photometric::erase_slice(&mut cur, w, h, cn, &params, &mut rng);
    }

    let d: &mut [u8] = dst;
    d.copy_from_slice(&cur);
    Ok(change)
}

/// Wraps a byte buffer of the right length as an image.
fn as_image<P: Pixel<Subpixel = u8>>(w: u32, h: u32, buf: Vec<u8>) -> Result<ImageBuffer<P, Vec<u8>>> {
    let len = buf.len();
    ImageBuffer::from_raw(w, h, buf).ok_or_else(|| {
        ImgprocError::Size(format!("buffer of {len} bytes does not hold a {w}x{h} image"))
    })
}
