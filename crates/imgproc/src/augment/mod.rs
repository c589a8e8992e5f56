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
mod test_util;

use image::{ImageBuffer, Pixel};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

pub use geometric::{
    Affine2, AffineParams, Border, LabelChange, affine_jitter, rotate_about_center, warp_affine,
    warp_view,
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
        let count = self.count[0]
            + (rng.random::<f64>() * span as f64)
                .floor()
                .min((span - 1) as f64) as u32;
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
    /// Exposure factor (> 0; 1 = unchanged), drawn log-uniformly.
    pub brightness: Jitter,
    /// Contrast factor about the mean (> 0; 1 = unchanged), drawn log-uniformly.
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
        self.rotation_deg.check("rotation_deg", -360.0, 360.0)?;
        self.affine.validate()?;
        Jitter {
            p: self.style.p,
            range: self.style.strength,
        }
        .check("style strength", 0.0, 1.0)?;
        self.brightness
            .check("brightness", f64::MIN_POSITIVE, f64::MAX)?;
        self.contrast
            .check("contrast", f64::MIN_POSITIVE, f64::MAX)?;
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
    let mut cur: Vec<u8> = geometric::bytes(img)?.to_vec();
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
    let strength = lerp(
        cfg.style.strength[0],
        cfg.style.strength[1],
        rng.random::<f64>(),
    );
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

    geometric::bytes_mut(dst)?.copy_from_slice(&cur);
    Ok(change)
}

/// Wraps a byte buffer of the right length as an image.
fn as_image<P: Pixel<Subpixel = u8>>(
    w: u32,
    h: u32,
    buf: Vec<u8>,
) -> Result<ImageBuffer<P, Vec<u8>>> {
    let len = buf.len();
    ImageBuffer::from_raw(w, h, buf).ok_or_else(|| {
        ImgprocError::Size(format!(
            "buffer of {len} bytes does not hold a {w}x{h} image"
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::test_util::scene;
    use super::*;
    use image::{GrayImage, RgbImage, imageops};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::PI;
    use std::time::Instant;

    /// Every op fires, at moderate strength: the worst case for speed and for determinism.
    fn everything() -> AugmentConfig {
        AugmentConfig {
            rotation_deg: Jitter::new(1.0, -30.0, 30.0),
            affine: AffineJitter {
                p: 1.0,
                scale: [0.9, 1.1],
                shear_deg: [-5.0, 5.0],
                translate: [-0.05, 0.05],
            },
            border: Border::Reflect,
            style: StyleJitter {
                p: 1.0,
                strength: [0.5, 1.0],
            },
            brightness: Jitter::new(1.0, 0.7, 1.4),
            contrast: Jitter::new(1.0, 0.7, 1.4),
            gamma: Jitter::new(1.0, 0.8, 1.25),
            saturation: Jitter::new(1.0, 0.5, 1.5),
            hue_deg: Jitter::new(1.0, -20.0, 20.0),
            blur_sigma: Jitter::new(1.0, 0.5, 1.0),
            noise_sigma: Jitter::new(1.0, 2.0, 6.0),
            erase: EraseJitter {
                p: 1.0,
                count: [1, 3],
                area: [0.05, 0.15],
                aspect: [0.5, 2.0],
                noise_fill_p: 0.5,
            },
        }
    }

    fn presets() -> Vec<(&'static str, AugmentConfig)> {
        vec![
            ("none", AugmentConfig::none()),
            ("light", AugmentConfig::light()),
            ("ceiling", AugmentConfig::ceiling()),
            ("shape_bias", AugmentConfig::shape_bias()),
            ("everything", everything()),
        ]
    }

    #[test]
    fn same_seed_same_bytes_other_seed_other_bytes() -> Result<()> {
        let img = scene(96, 72);
        for (name, cfg) in presets() {
            for seed in [0u64, 1, 42, u64::MAX] {
                let (a, la) = augment(&img, &cfg, seed)?;
                let (b, lb) = augment(&img, &cfg, seed)?;
                assert_eq!(a.as_raw(), b.as_raw(), "{name}, seed {seed}");
                assert_eq!(la, lb);
            }
        }
        // With every op firing, any two seeds differ.
        let cfg = everything();
        let outs: Vec<RgbImage> = (0..8)
            .map(|s| augment(&img, &cfg, s).map(|(i, _)| i))
            .collect::<Result<_>>()?;
        for i in 0..outs.len() {
            for j in i + 1..outs.len() {
                assert_ne!(outs[i], outs[j], "seeds {i} and {j}");
            }
        }
        // Presets with probabilities below 1 still vary over seeds.
        let light: Vec<RgbImage> = (0..8)
            .map(|s| augment(&img, &AugmentConfig::light(), s).map(|(i, _)| i))
            .collect::<Result<_>>()?;
        assert!(light.windows(2).any(|w| w[0] != w[1]));
        Ok(())
    }

    #[test]
    fn none_is_the_identity() -> Result<()> {
        let img = scene(50, 40);
        for seed in 0..5 {
            let (out, change) = augment(&img, &AugmentConfig::none(), seed)?;
            assert_eq!(out, img);
            assert_eq!(change, LabelChange::NONE);
        }
        Ok(())
    }

    #[test]
    fn labels_follow_the_geometry() -> Result<()> {
        let img = scene(80, 60);
        for seed in 0..50 {
            // 6-DoF presets never move a pixel.
            for cfg in [AugmentConfig::light(), AugmentConfig::shape_bias()] {
                assert!(!cfg.is_geometric());
                assert!(augment(&img, &cfg, seed)?.1.preserves_pose());
            }
            // The ceiling preset rotates about the centre; its pixel map is exactly the rotation
            // by heading_delta.
            let (_, change) = augment(&img, &AugmentConfig::ceiling(), seed)?;
            let d = change.heading_delta;
            assert!(d > -PI && d <= PI);
            let expected = Affine2::rotation_about(d, 39.5, 29.5);
            for (a, b) in change.pixel_map.m.iter().zip(expected.m.iter()) {
                assert!((a - b).abs() < 1e-9, "seed {seed}");
            }
        }
        // The ceiling preset's rotation image equals rotate_about_center with the same angle
        // when nothing else fires.
        let cfg = AugmentConfig {
            rotation_deg: Jitter::new(1.0, -180.0, 180.0),
            ..AugmentConfig::none()
        };
        let (out, change) = augment(&img, &cfg, 3)?;
        let mut direct = RgbImage::new(80, 60);
        rotate_about_center(&img, &mut direct, change.heading_delta, Border::Black)?;
        assert_eq!(out, direct);
        Ok(())
    }

    #[test]
    fn stages_draw_independently() -> Result<()> {
        // Switching blur and noise off does not change the rotation another stage drew.
        let img = scene(64, 48);
        let full = everything();
        let geometric_only = AugmentConfig {
            rotation_deg: full.rotation_deg,
            ..AugmentConfig::none()
        };
        for seed in 0..10 {
            let a = augment(&img, &full, seed)?.1.heading_delta;
            let b = augment(&img, &geometric_only, seed)?.1.heading_delta;
            assert_eq!(a, b);
        }
        Ok(())
    }

    #[test]
    fn fused_tone_table_equals_the_ops_in_sequence() -> Result<()> {
        let img = scene(64, 48);
        let cfg = AugmentConfig {
            brightness: Jitter::new(1.0, 1.25, 1.25),
            contrast: Jitter::new(1.0, 0.8, 0.8),
            gamma: Jitter::new(1.0, 1.1, 1.1),
            ..AugmentConfig::none()
        };
        let (fused, _) = augment(&img, &cfg, 0)?;
        let (mut a, mut b) = (RgbImage::new(64, 48), RgbImage::new(64, 48));
        adjust_brightness(&img, &mut a, 1.25)?;
        adjust_contrast(&a, &mut b, 0.8)?;
        adjust_gamma(&b, &mut a, 1.1)?;
        let max_diff = fused
            .as_raw()
            .iter()
            .zip(a.as_raw())
            .map(|(p, q)| p.abs_diff(*q))
            .max();
        // log-uniform draws of a one-point range may differ from it by an ulp.
        assert!(max_diff <= Some(1), "{max_diff:?}");
        Ok(())
    }

    #[test]
    fn grey_images_augment_too() -> Result<()> {
        let img = imageops::grayscale(&scene(80, 60));
        for cfg in [
            AugmentConfig::ceiling(),
            AugmentConfig::shape_bias(),
            everything(),
        ] {
            let (a, _) = augment(&img, &cfg, 5)?;
            let (b, _) = augment(&img, &cfg, 5)?;
            assert_eq!(a, b);
        }
        let mut dst = GrayImage::new(80, 60);
        augment_into(&img, &everything(), 1, &mut dst)?;
        assert_ne!(dst, img);
        Ok(())
    }

    #[test]
    fn invalid_configs_are_errors_not_panics() {
        let img = scene(16, 12);
        let mut bad = Vec::new();
        let mut c = AugmentConfig::light();
        c.brightness.p = 1.5;
        bad.push(("probability > 1", c));
        let mut c = AugmentConfig::light();
        c.noise_sigma.range = [-1.0, 2.0];
        bad.push(("negative noise sigma", c));
        let mut c = AugmentConfig::light();
        c.blur_sigma.range = [-0.5, 1.0];
        bad.push(("negative blur sigma", c));
        let mut c = AugmentConfig::light();
        c.erase.area = [0.5, 1.2];
        bad.push(("area fraction > 1", c));
        let mut c = AugmentConfig::light();
        c.erase.count = [3, 2];
        bad.push(("count min > max", c));
        let mut c = AugmentConfig::light();
        c.erase.count = [1, 1000];
        bad.push(("too many rectangles", c));
        let mut c = AugmentConfig::light();
        c.erase.noise_fill_p = -0.1;
        bad.push(("negative fill probability", c));
        let mut c = AugmentConfig::light();
        c.gamma.range = [0.0, 1.0];
        bad.push(("gamma 0", c));
        let mut c = AugmentConfig::light();
        c.contrast.range = [1.2, 0.8];
        bad.push(("min > max", c));
        let mut c = AugmentConfig::ceiling();
        c.rotation_deg.range = [f64::NAN, 10.0];
        bad.push(("NaN angle", c));
        let mut c = AugmentConfig::light();
        c.style.strength = [0.5, 1.5];
        bad.push(("style strength > 1", c));
        let mut c = AugmentConfig::light();
        c.affine.shear_deg = [-80.0, 0.0];
        bad.push(("shear beyond 45°", c));
        let mut c = AugmentConfig::light();
        c.affine.scale = [0.0, 1.0];
        bad.push(("scale 0", c));
        let mut c = AugmentConfig::light();
        c.hue_deg.p = f64::NAN;
        bad.push(("NaN probability", c));
        for (what, cfg) in bad {
            assert!(cfg.validate().is_err(), "{what}");
            assert!(augment(&img, &cfg, 0).is_err(), "{what}");
        }
        let mut wrong = RgbImage::new(8, 8);
        assert!(augment_into(&img, &AugmentConfig::light(), 0, &mut wrong).is_err());
        assert!(augment(&RgbImage::new(0, 5), &AugmentConfig::light(), 0).is_err());
        for (name, cfg) in presets() {
            assert!(cfg.validate().is_ok(), "{name}");
        }
    }

    #[test]
    fn oversized_buffers_and_odd_sizes_are_handled() -> Result<()> {
        // An ImageBuffer may own more bytes than its pixels need; the ops ignore the tail.
        let long =
            RgbImage::from_raw(5, 3, vec![90; 100]).ok_or(ImgprocError::Size("from_raw".into()))?;
        let (out, _) = augment(&long, &everything(), 2)?;
        assert_eq!(out.dimensions(), (5, 3));
        let mut dst =
            RgbImage::from_raw(5, 3, vec![0; 60]).ok_or(ImgprocError::Size("from_raw".into()))?;
        augment_into(&long, &AugmentConfig::shape_bias(), 2, &mut dst)?;
        rotate_about_center(&long, &mut dst, 1.0, Border::Reflect)?;
        gaussian_blur(&long, &mut dst, 2.0)?;
        // One-pixel images, and a warp into an empty destination.
        let dot = GrayImage::new(1, 1);
        for seed in 0..4 {
            augment(&dot, &everything(), seed)?;
        }
        let mut empty = RgbImage::new(0, 4);
        warp_affine(&long, &mut empty, &Affine2::IDENTITY, Border::Black)?;
        Ok(())
    }

    #[test]
    fn config_serde_round_trip() -> std::result::Result<(), Box<dyn std::error::Error>> {
        // TOML is how a config is stored in a checkpoint's model.toml; JSON how tools see it.
        for (name, cfg) in presets() {
            let text = toml::to_string(&cfg)?;
            let back: AugmentConfig = toml::from_str(&text)?;
            assert_eq!(back, cfg, "{name}");
            let json = serde_json::to_value(cfg)?;
            assert_eq!(json.as_object().map(|m| m.len()), Some(12), "{name}");
            assert!(matches!(json["border"].as_str(), Some("black" | "reflect")));
            assert_eq!(
                serde_json::from_value::<AugmentConfig>(json)?,
                cfg,
                "{name}"
            );
        }
        // Unknown fields are rejected, so a typo in a stored config does not go unnoticed.
        let mut json = serde_json::to_value(AugmentConfig::light())?;
        json["rotation"] = serde_json::json!(1.0);
        assert!(serde_json::from_value::<AugmentConfig>(json).is_err());
        for name in ["none", "light", "ceiling", "shape_bias"] {
            assert!(AugmentConfig::preset(name).is_some());
        }
        assert!(AugmentConfig::preset("heavy").is_none());
        assert_eq!(AugmentConfig::default(), AugmentConfig::light());
        Ok(())
    }

    /// This thread's CPU time, seconds (utime + stime from `/proc/thread-self/stat`, 10 ms
    /// ticks), so that figures taken on a busy machine count only the time this test ran.
    fn thread_cpu_s() -> Option<f64> {
        let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
        // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
        let rest = stat.rsplit_once(')')?.1;
        let f: Vec<&str> = rest.split_whitespace().collect();
        let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
        Some(ticks / 100.0)
    }

    /// Runs `f` for at least a second of CPU time (or wall time where `/proc` is missing);
    /// returns ms per call, wall and CPU, and the number of calls.
    fn measure(mut f: impl FnMut() -> Result<()>) -> Result<(f64, f64, u32)> {
        let (t0, c0) = (Instant::now(), thread_cpu_s());
        let mut n = 0u32;
        loop {
            for _ in 0..10 {
                f()?;
            }
            n += 10;
            let cpu = match (c0, thread_cpu_s()) {
                (Some(a), Some(b)) => b - a,
                _ => t0.elapsed().as_secs_f64(),
            };
            if cpu >= 1.0 {
                let wall = t0.elapsed().as_secs_f64();
                return Ok((wall * 1e3 / f64::from(n), cpu * 1e3 / f64::from(n), n));
            }
        }
    }

    /// Speed of whole-pipeline draws, ms per image; run with
    /// `cargo test -p imgproc --release augment_speed -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn augment_speed() -> Result<()> {
        for (w, h) in [(160, 120), (320, 240)] {
            let img = scene(w, h);
            let mut dst = RgbImage::new(w, h);
            for (name, cfg) in [
                ("light", AugmentConfig::light()),
                ("ceiling", AugmentConfig::ceiling()),
                ("shape_bias", AugmentConfig::shape_bias()),
                ("everything", everything()),
            ] {
                for seed in 0..20 {
                    augment_into(&img, &cfg, seed, &mut dst)?;
                }
                let mut seed = 0;
                let (wall, cpu, n) = measure(|| {
                    seed += 1;
                    augment_into(&img, &cfg, seed, &mut dst).map(|_| ())
                })?;
                println!(
                    "{w}x{h} {name:>10}: {cpu:.3} ms CPU per image ({wall:.3} ms wall, {n} images)"
                );
            }
        }
        // Each op alone at 320x240, to see where the time goes.
        let img = scene(320, 240);
        let mut dst = RgbImage::new(320, 240);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut time = |name: &str,
                        f: &mut dyn FnMut(&mut RgbImage, &mut ChaCha8Rng) -> Result<()>|
         -> Result<()> {
            let (wall, cpu, _) = measure(|| f(&mut dst, &mut rng))?;
            println!("320x240 {name:>16}: {cpu:.3} ms CPU ({wall:.3} ms wall)");
            Ok(())
        };
        time("rotate", &mut |d, _| {
            rotate_about_center(&img, d, 0.3, Border::Black).map(|_| ())
        })?;
        time("style", &mut |d, r| {
            style_randomize(&img, d, &StyleParams { strength: 1.0 }, r)
        })?;
        time("brightness", &mut |d, _| adjust_brightness(&img, d, 1.2))?;
        time("contrast", &mut |d, _| adjust_contrast(&img, d, 1.2))?;
        time("gamma", &mut |d, _| adjust_gamma(&img, d, 1.2))?;
        time("colour", &mut |d, _| adjust_color(&img, d, 1.2, 0.1))?;
        time("blur 1.0", &mut |d, _| gaussian_blur(&img, d, 1.0))?;
        time("noise", &mut |d, r| add_gaussian_noise(&img, d, 5.0, r))?;
        let ep = EraseParams {
            count: 2,
            area_fraction: 0.1,
            aspect: [0.5, 2.0],
            fill: EraseFill::Noise,
        };
        time("erase", &mut |d, r| {
            random_erase(&img, d, &ep, r).map(|_| ())
        })?;
        Ok(())
    }

    /// Writes a contact sheet of augmentations to `$TMPDIR/augment.png` for a look by eye: a
    /// synthetic scene and a real 7-Scenes frame (where `../shared/data` is present), each as
    /// original, light ×2, ceiling ×2, shape_bias ×3.
    #[test]
    #[ignore]
    fn contact_sheet() -> std::result::Result<(), Box<dyn std::error::Error>> {
        let (tw, th) = (320u32, 240u32);
        let mut sources = vec![scene(tw, th)];
        let real = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(
            "../../../shared/data/7scenes_stairs_sample/kapture/sensors/records_data/seq-04/frame-000001.color.jpg",
        );
        if let Ok(img) = image::open(&real) {
            sources.push(imageops::resize(
                &img.to_rgb8(),
                tw,
                th,
                imageops::FilterType::Triangle,
            ));
        }
        let plan = [
            ("light", 1u64),
            ("light", 2),
            ("ceiling", 3),
            ("ceiling", 4),
            ("shape_bias", 5),
            ("shape_bias", 6),
            ("shape_bias", 7),
        ];
        let cols = 4u32;
        let rows_per_source = (plan.len() as u32 + 1).div_ceil(cols);
        let mut sheet = RgbImage::new(cols * tw, rows_per_source * sources.len() as u32 * th);
        for (s, src) in sources.iter().enumerate() {
            let mut tiles = vec![src.clone()];
            for (name, seed) in plan {
                let cfg = AugmentConfig::preset(name).ok_or("preset")?;
                tiles.push(augment(src, &cfg, seed)?.0);
            }
            for (i, tile) in tiles.iter().enumerate() {
                let (c, r) = (
                    i as u32 % cols,
                    i as u32 / cols + s as u32 * rows_per_source,
                );
                imageops::replace(&mut sheet, tile, i64::from(c * tw), i64::from(r * th));
            }
        }
        let path = std::env::temp_dir().join("augment.png");
        sheet.save(&path)?;
        println!("wrote {}", path.display());
        Ok(())
    }
}
