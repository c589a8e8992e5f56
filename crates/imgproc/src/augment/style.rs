//! Texture and style randomisation: new paint, same building.
//!
//! # Model
//! An image is roughly `albedo × shading`. The building's geometry shows in the *edges* of both
//! (where surfaces meet, where a lamp's light falls off); its "paint" is the albedo's colour and
//! texture, and the light's colour. A network that should localise by geometry must not key on
//! paint, so this op repaints and relights the image while keeping its gradient structure:
//!
//! 1. **Re-colour the albedo, per channel**: a random smooth tone curve per channel, monotone
//!    with slopes bounded in `[1/3, 3]` (relative) at full strength, inverted with probability
//!    `strength / 2`. A monotone curve `f` scales every gradient by `f'(I)`, so no edge
//!    disappears and none appears; inversion flips an edge's polarity but not its place.
//! 2. **Rotate the colour space** (RGB only): a random 3-D rotation about a random axis by up to
//!    `strength · 180°`. A rotation is orthogonal, so the multi-channel gradient magnitude
//!    `√(Σ_c |∇I_c|²)` is unchanged; it moves every hue while keeping colour *differences*.
//! 3. **Fit into [0, 1] conformally**: one common scale `k ≤ 1` for all channels (times a random
//!    contrast cut) plus a random offset per channel, so nothing clips and gradients are only
//!    scaled, never distorted channel against channel.
//! 4. **Add a material texture**: band-limited value noise (cell 2.5–8 px) *multiplied* in,
//!    `I · (1 + a·n)`, so its contrast follows the local brightness as a real surface texture
//!    under the same light would. It adds small gradients on flat surfaces; it cannot cancel an
//!    edge.
//! 5. **Relight**: a smooth random colour field per channel (a 4×4 grid of factors in
//!    `exp(±strength/2)`, smoothstep-interpolated) multiplied in: coloured light that changes
//!    across the image. Its own gradient is tiny, so `∇(g·I) ≈ g·∇I`.
//!
//! At `strength = 0` every step is the identity (the op copies up to rounding); the test
//! `style_keeps_edges_changes_colours` measures edge survival and colour change at full strength.
//!
//! Written by hand: neither `image` nor kornia has a shape-preserving style randomisation, and
//! learned stylisation (AdaIN networks) would need a model at augmentation time.

use image::{ImageBuffer, Pixel};
use rand::Rng;

use super::photometric::to_byte;
use crate::{ImgprocError, Result};

/// Parameters of [`style_randomize`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StyleParams {
    /// How far from the original appearance, in [0, 1]: 0 leaves the image as it is, 1 allows
    /// inverted channels, any hue, strong coloured light and visible texture.
    pub strength: f64,
}

impl StyleParams {
    pub(crate) fn validate(&self) -> Result<()> {
        if self.strength.is_finite() && (0.0..=1.0).contains(&self.strength) {
            Ok(())
        } else {
            Err(ImgprocError::Param(format!(
                "style strength must be in [0, 1], got {}",
                self.strength
            )))
        }
    }
}

/// Repaints and relights `src` into `dst` (same size, grey or RGB) keeping its edges; see the
/// module docs for the model and what each step preserves.
pub fn style_randomize<P: Pixel<Subpixel = u8>, R: Rng + ?Sized>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    params: &StyleParams,
    rng: &mut R,
) -> Result<()> {
    super::geometric::same_size(src, dst)?;
    params.validate()?;
    let cn = usize::from(P::CHANNEL_COUNT);
    if cn != 1 && cn != 3 {
        return Err(ImgprocError::Param(format!(
            "style randomisation needs grey or RGB images, not {cn} channels"
        )));
    }
    let (w, h) = (src.width() as usize, src.height() as usize);
    style_slice(
        super::geometric::bytes(src)?,
        super::geometric::bytes_mut(dst)?,
        w,
        h,
        cn,
        params.strength,
        rng,
    );
    Ok(())
}

/// Uniform in `[lo, hi)`, without the panics of `random_range` on empty ranges.
fn uniform<R: Rng + ?Sized>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn smoothstep(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// Number of slope knots of a tone curve.
const TONE_KNOTS: usize = 8;

/// A random monotone tone curve on bytes, values in [0, 1].
///
/// The curve is the integral of a smooth positive slope function (knot slopes in
/// `exp(±strength·ln 3)`, smoothstep-interpolated), so it is smooth, monotone, and exactly the
/// identity when all slopes are equal (strength 0).
fn tone_curve<R: Rng + ?Sized>(strength: f64, rng: &mut R) -> [f32; 256] {
    let spread = strength * 3f64.ln();
    let slopes: [f64; TONE_KNOTS] =
        std::array::from_fn(|_| (spread * uniform(rng, -1.0, 1.0)).exp());
    let slope_at = |v: f64| {
        let u = v / 255.0 * TONE_KNOTS as f64 - 0.5;
        if u <= 0.0 {
            slopes[0]
        } else if u >= (TONE_KNOTS - 1) as f64 {
            slopes[TONE_KNOTS - 1]
        } else {
            let k = u.floor() as usize;
            let t = smoothstep(u - k as f64);
            slopes[k] * (1.0 - t) + slopes[k + 1] * t
        }
    };
    let mut curve = [0f64; 256];
    for v in 1..256 {
        let (a, b) = (slope_at((v - 1) as f64), slope_at(v as f64));
        curve[v] = curve[v - 1] + 0.5 * (a + b);
    }
    let total = curve[255];
    let invert = rng.random::<f64>() < 0.5 * strength;
    curve.map(|c| {
        let y = if total > 0.0 { c / total } else { 0.0 };
        (if invert { 1.0 - y } else { y }) as f32
    })
}

/// A random 3-D rotation by up to `strength · π` about a uniformly random axis (Rodrigues).
fn colour_rotation<R: Rng + ?Sized>(strength: f64, rng: &mut R) -> [[f32; 3]; 3] {
    // Rejection sampling in the unit ball gives a uniform direction; bounded tries, with a grey
    // axis as the (practically unreachable) fallback so the op never loops forever.
    let mut axis = [1.0 / 3f64.sqrt(); 3];
    for _ in 0..64 {
        let v = [
            uniform(rng, -1.0, 1.0),
            uniform(rng, -1.0, 1.0),
            uniform(rng, -1.0, 1.0),
        ];
        let n2: f64 = v.iter().map(|x| x * x).sum();
        if n2 > 1e-6 && n2 <= 1.0 {
            let n = n2.sqrt();
            axis = v.map(|x| x / n);
            break;
        }
    }
    let phi = strength * std::f64::consts::PI * uniform(rng, -1.0, 1.0);
    let (s, c) = phi.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    let m = [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ];
    m.map(|row| row.map(|v| v as f32))
}

/// Per-axis interpolation table: for every pixel, the grid cell to its left/top and the
/// smoothstep weight of the next node.
fn axis_table(n: usize, scale: f64, offset: f64, last_cell: usize) -> Vec<(usize, f32)> {
    (0..n)
        .map(|i| {
            let u = i as f64 * scale + offset;
            let k = (u.floor().max(0.0) as usize).min(last_cell);
            let t = (u - k as f64).clamp(0.0, 1.0);
            (k, smoothstep(t) as f32)
        })
        .collect()
}

/// A smooth random field on a grid of `gw × gh` nodes.
struct Field {
    gw: usize,
    nodes: Vec<f32>,
}

impl Field {
    fn random<R: Rng + ?Sized>(gw: usize, gh: usize, rng: &mut R, f: impl Fn(f64) -> f64) -> Self {
        let nodes = (0..gw * gh)
            .map(|_| f(uniform(rng, -1.0, 1.0)) as f32)
            .collect();
        Field { gw, nodes }
    }

    /// The field along grid row `j` blended with row `j + 1` by `t`, into `out` (`gw` values).
    fn row(&self, j: usize, t: f32, out: &mut [f32]) {
        let (a, b) = (
            &self.nodes[j * self.gw..(j + 1) * self.gw],
            &self.nodes[(j + 1) * self.gw..(j + 2) * self.gw],
        );
        for ((o, &p), &q) in out.iter_mut().zip(a).zip(b) {
            *o = p + (q - p) * t;
        }
    }
}

/// Cells of the lighting field across the image (4×4 nodes).
const LIGHT_CELLS: usize = 3;

pub(crate) fn style_slice<R: Rng + ?Sized>(
    src: &[u8],
    dst: &mut [u8],
    w: usize,
    h: usize,
    cn: usize,
    strength: f64,
    rng: &mut R,
) {
    if w == 0 || h == 0 {
        return;
    }
    // 1–2: tone curves and colour rotation, into f32 with per-channel ranges.
    let curves: Vec<[f32; 256]> = (0..cn).map(|_| tone_curve(strength, rng)).collect();
    let rot = if cn == 3 {
        Some(colour_rotation(strength, rng))
    } else {
        None
    };
    let mut vals = vec![0f32; w * h * cn];
    let mut lo = vec![f32::INFINITY; cn];
    let mut hi = vec![f32::NEG_INFINITY; cn];
    for (o, i) in vals.chunks_exact_mut(cn).zip(src.chunks_exact(cn)) {
        match rot {
            Some(m) => {
                let t = [
                    curves[0][usize::from(i[0])] - 0.5,
                    curves[1][usize::from(i[1])] - 0.5,
                    curves[2][usize::from(i[2])] - 0.5,
                ];
                for c in 0..3 {
                    o[c] = m[c][0] * t[0] + m[c][1] * t[1] + m[c][2] * t[2] + 0.5;
                }
            }
            None => {
                for c in 0..cn {
                    o[c] = curves[c][usize::from(i[c])];
                }
            }
        }
        for c in 0..cn {
            lo[c] = lo[c].min(o[c]);
            hi[c] = hi[c].max(o[c]);
        }
    }
    // 3: one common scale so the widest channel fits, a random contrast cut, random offsets.
    let widest = (0..cn)
        .map(|c| f64::from(hi[c] - lo[c]))
        .fold(0.0, f64::max);
    let k = 1.0 / widest.max(1.0) * (1.0 - 0.4 * strength * rng.random::<f64>());
    let offsets: Vec<f32> = (0..cn)
        .map(|c| {
            // Offsets that keep the channel in [0, 1]: [−k·lo, 1 − k·hi] (non-empty as k·range ≤ 1).
            let (a, b) = (-k * f64::from(lo[c]), 1.0 - k * f64::from(hi[c]));
            let keep = 0f64.clamp(a.min(b), b.max(a));
            ((1.0 - strength) * keep + strength * uniform(rng, a, b)) as f32
        })
        .collect();
    let k = k as f32;

    // 4: material texture, value noise with a random cell size and phase.
    let cell = uniform(rng, 2.5f64.ln(), 8f64.ln()).exp();
    let amp = (strength * uniform(rng, 0.05, 0.2)) as f32;
    let (tgw, tgh) = (
        (w as f64 / cell).ceil() as usize + 2,
        (h as f64 / cell).ceil() as usize + 2,
    );
    let texture = Field::random(tgw, tgh, rng, |u| u);
    let (ox, oy) = (rng.random::<f64>(), rng.random::<f64>());
    let tx = axis_table(w, 1.0 / cell, ox, tgw - 2);
    let ty = axis_table(h, 1.0 / cell, oy, tgh - 2);

    // 5: coloured light, one smooth field per channel.
    let light_amp = 0.5 * strength;
    let light: Vec<Field> = (0..cn)
        .map(|_| {
            Field::random(LIGHT_CELLS + 1, LIGHT_CELLS + 1, rng, |u| {
                (light_amp * u).exp()
            })
        })
        .collect();
    let span = |n: usize| {
        if n > 1 {
            LIGHT_CELLS as f64 / (n - 1) as f64
        } else {
            0.0
        }
    };
    let lx = axis_table(w, span(w), 0.0, LIGHT_CELLS - 1);
    let ly = axis_table(h, span(h), 0.0, LIGHT_CELLS - 1);

    let ctx = Shading {
        w,
        vals: &vals,
        k,
        offsets: &offsets,
        amp,
        texture: &texture,
        tx: &tx,
        ty: &ty,
        light: &light,
        lx: &lx,
        ly: &ly,
    };
    if cn == 1 {
        shade::<1>(&ctx, dst);
    } else {
        shade::<3>(&ctx, dst);
    }
}

/// Everything the final per-pixel pass needs.
struct Shading<'a> {
    w: usize,
    vals: &'a [f32],
    k: f32,
    offsets: &'a [f32],
    amp: f32,
    texture: &'a Field,
    tx: &'a [(usize, f32)],
    ty: &'a [(usize, f32)],
    light: &'a [Field],
    lx: &'a [(usize, f32)],
    ly: &'a [(usize, f32)],
}

/// Steps 3–5 per pixel: conformal fit, texture, light; `C` channels known at compile time so the
/// channel loops unroll.
fn shade<const C: usize>(s: &Shading<'_>, dst: &mut [u8]) {
    const L: usize = LIGHT_CELLS + 1;
    let offsets: [f32; C] = std::array::from_fn(|c| s.offsets.get(c).copied().unwrap_or(0.0));
    let mut trow = vec![0f32; s.texture.gw];
    let mut lrows = [[0f32; L]; C];
    for (y, (drow, vrow)) in dst
        .chunks_exact_mut(s.w * C)
        .zip(s.vals.chunks_exact(s.w * C))
        .enumerate()
    {
        s.texture.row(s.ty[y].0, s.ty[y].1, &mut trow);
        for (f, lr) in s.light.iter().zip(lrows.iter_mut()) {
            f.row(s.ly[y].0, s.ly[y].1, lr);
        }
        for ((o, v), (&(ti, tt), &(li, lt))) in drow
            .chunks_exact_mut(C)
            .zip(vrow.chunks_exact(C))
            .zip(s.tx.iter().zip(s.lx.iter()))
        {
            let (t0, t1) = (trow[ti], trow[ti + 1]);
            let tex = 255.0 * (1.0 + s.amp * (t0 + (t1 - t0) * tt));
            let li = li.min(L - 2);
            for c in 0..C {
                let (g0, g1) = (lrows[c][li], lrows[c][li + 1]);
                let g = g0 + (g1 - g0) * lt;
                o[c] = to_byte((s.k * v[c] + offsets[c]) * tex * g);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::augment::test_util::{
        colour_histogram, gradient_magnitude, intersection, pearson, scene,
    };
    use image::{GrayImage, Luma, RgbImage};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn style_keeps_edges_changes_colours() -> Result<()> {
        let src = scene(160, 120);
        let g0 = gradient_magnitude(&src);
        let h0 = colour_histogram(&src);
        // Control: the metric does notice a change of geometry. Shifting the scene diagonally
        // by 1 pixel gives 0.70, by 2 pixels 0.43; the restyled images must beat a 1-pixel shift.
        let shifted = RgbImage::from_fn(160, 120, |x, y| {
            *src.get_pixel(x.saturating_sub(2), y.saturating_sub(2))
        });
        let control = pearson(&g0, &gradient_magnitude(&shifted));
        assert!(control < 0.5, "shift control correlation {control}");

        let mut dst = RgbImage::new(160, 120);
        let (mut corr_sum, mut inter_sum, n) = (0.0, 0.0, 16);
        for seed in 0..n {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            style_randomize(&src, &mut dst, &StyleParams { strength: 1.0 }, &mut rng)?;
            let corr = pearson(&g0, &gradient_magnitude(&dst));
            let inter = intersection(&h0, &colour_histogram(&dst));
            // Measured at the time of writing: correlation 0.81–0.99 (mean 0.94),
            // intersection 0.03–0.20 (mean 0.11).
            assert!(corr >= 0.75, "seed {seed}: gradient correlation {corr}");
            assert!(inter <= 0.4, "seed {seed}: histogram intersection {inter}");
            corr_sum += corr;
            inter_sum += inter;
        }
        let (corr, inter) = (corr_sum / n as f64, inter_sum / n as f64);
        assert!(corr >= 0.85, "mean gradient correlation {corr}");
        assert!(inter <= 0.25, "mean histogram intersection {inter}");
        Ok(())
    }

    #[test]
    fn zero_strength_is_identity() -> Result<()> {
        let src = scene(64, 48);
        let mut dst = RgbImage::new(64, 48);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        style_randomize(&src, &mut dst, &StyleParams { strength: 0.0 }, &mut rng)?;
        assert_eq!(dst, src);
        Ok(())
    }

    #[test]
    fn grey_images_are_restyled_too() -> Result<()> {
        let src = GrayImage::from_fn(60, 40, |x, y| {
            Luma([if x > 30 { 200 } else { 50 + y as u8 }])
        });
        let mut dst = GrayImage::new(60, 40);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        style_randomize(&src, &mut dst, &StyleParams { strength: 1.0 }, &mut rng)?;
        assert_ne!(dst, src);
        // The step edge at x = 30.5 is still the strongest horizontal change in every row.
        for y in 0..40 {
            let row: Vec<i32> = (0..60).map(|x| i32::from(dst.get_pixel(x, y)[0])).collect();
            let strongest = (0..59)
                .max_by_key(|&x| (row[x + 1] - row[x]).abs())
                .unwrap_or(0);
            assert_eq!(strongest, 30, "row {y}");
        }
        Ok(())
    }

    #[test]
    fn bad_style_parameters_are_errors() {
        let src = RgbImage::new(8, 8);
        let mut dst = RgbImage::new(8, 8);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        for strength in [-0.1, 1.5, f64::NAN] {
            assert!(style_randomize(&src, &mut dst, &StyleParams { strength }, &mut rng).is_err());
        }
        let mut small = RgbImage::new(8, 4);
        assert!(
            style_randomize(&src, &mut small, &StyleParams { strength: 0.5 }, &mut rng).is_err()
        );
    }
}
