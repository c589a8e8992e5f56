//! Training batches, assembled on a worker thread while the previous step trains, optionally
//! reframed ([`reframe_view`], place training only), restyled ([`style_view`], shape-biased
//! training) and jittered ([`jitter_view`]), with the plane targets of their frames when the
//! network has a plane branch.
//!
//! The jitter works on the views already in memory (after grey conversion, resizing, CLAHE and
//! normalisation), not on source images: `imgproc::augment` needs the `u8` source image, which
//! training does not keep (40 000 frames would be gigabytes). What can be done to a finished
//! view is photometric — contrast and brightness about the view's own mean and spread, sensor
//! noise, and occluding rectangles — which keeps every pose label true and works whatever the
//! view's normalisation. Geometric jitter would falsify 6-DoF labels and is left out of pose
//! training; place labels survive a small zoom and shift ([`reframe_view`]).
//!
//! The style randomisation of shape-biased training (`imgproc::augment::style_randomize`:
//! random monotone tone curves, possibly inverted, a material texture, coloured light that
//! changes across the image, all keeping the edges) runs on the view mapped to bytes over its
//! own range and back; views come from 8-bit images, so nothing is lost but rounding.
//!
//! Determinism: the jitter of epoch `e` comes from a ChaCha generator seeded with the run's
//! seed on stream `AUGMENT_STREAM + e`, drawn in batch order on the one worker thread, so it
//! does not depend on timing; the frame order is decided by the caller.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::Scope;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use imgproc::augment::{StyleParams, style_randomize};

use crate::dataset::Samples;
use crate::planes::{PlaneBatch, PlaneTargets};

/// Stream offset of the jitter generators (the training loop uses streams `1..=epochs`).
pub const AUGMENT_STREAM: u64 = 1 << 32;

/// Batches prepared ahead of the training step.
const PREFETCH: usize = 2;

/// One batch: inputs `[rows, C, H, W]` and targets `[rows, outputs]`, packed.
pub struct Batch {
    /// Input values.
    pub inputs: Vec<f32>,
    /// Target values.
    pub targets: Vec<f32>,
    /// Images in the batch.
    pub rows: usize,
    /// Plane targets of the batch's frames, when asked for.
    pub planes: Option<PlaneBatch>,
}

/// How training views are changed before each step; one generator for all of it, seeded per
/// epoch ([`jitter_rng`]).
pub struct Augment {
    /// The epoch's generator.
    pub rng: ChaCha8Rng,
    /// Photometric jitter ([`jitter_view`]).
    pub jitter: bool,
    /// Style randomisation ([`style_view`]), before the jitter.
    pub style: bool,
    /// A small random zoom and shift ([`reframe_view`]), first: only for labels that a turn
    /// of a few degrees or a step forward leaves true (places, not poses).
    pub reframe: bool,
}

/// What [`spawn`] reads.
#[derive(Clone, Copy)]
pub struct Source<'a> {
    /// The views.
    pub samples: &'a Samples,
    /// Targets per view.
    pub targets: &'a [Vec<f32>],
    /// Plane targets per view, for a network with a plane branch.
    pub planes: Option<&'a PlaneTargets>,
}

/// Starts a worker in `scope` that sends the batches of `order` (`steps` batches of `size`)
/// in order, changed as `augment` says. It stops early when the receiver is dropped.
pub fn spawn<'scope>(
    scope: &'scope Scope<'scope, '_>,
    source: Source<'scope>,
    order: Vec<usize>,
    size: usize,
    steps: usize,
    augment: Option<Augment>,
) -> Receiver<Batch> {
    let (tx, rx) = sync_channel(PREFETCH);
    scope.spawn(move || produce(source, &order, size, steps, augment, &tx));
    rx
}

fn produce(
    source: Source<'_>,
    order: &[usize],
    size: usize,
    steps: usize,
    mut augment: Option<Augment>,
    tx: &SyncSender<Batch>,
) {
    let Source {
        samples,
        targets,
        planes,
    } = source;
    let n = samples.view_len();
    let (c, h, w) = (samples.channels, samples.height, samples.width);
    for step in 0..steps {
        let idx = &order[step * size..(step + 1) * size];
        let mut inputs = Vec::with_capacity(idx.len() * n);
        let mut values = Vec::with_capacity(idx.len() * targets[0].len());
        for &i in idx {
            let start = inputs.len();
            inputs.extend_from_slice(samples.input(i));
            if let Some(aug) = augment.as_mut() {
                let view = &mut inputs[start..];
                if aug.reframe {
                    reframe_view(view, c, h, w, &mut aug.rng);
                }
                if aug.style && aug.rng.random::<f64>() < STYLE_PROBABILITY {
                    style_view(view, c, h, w, &mut aug.rng);
                }
                if aug.jitter {
                    jitter_view(view, c, h, w, &mut aug.rng);
                }
            }
            values.extend_from_slice(&targets[i]);
        }
        let batch = Batch {
            inputs,
            targets: values,
            rows: idx.len(),
            planes: planes.map(|p| PlaneBatch::of(p, idx)),
        };
        if tx.send(batch).is_err() {
            return;
        }
    }
}

/// Jitters one view `[C, H, W]` in place: contrast ×[0.7, 1.3] about its mean, brightness
/// ±0.2 of its standard deviation, Gaussian noise of up to 0.05 standard deviations, and with
/// probability 0.3 one rectangle of 2–10 % of the area filled with the mean (an occluder).
pub fn jitter_view(
    view: &mut [f32],
    channels: usize,
    height: usize,
    width: usize,
    rng: &mut ChaCha8Rng,
) {
    if view.is_empty() {
        return;
    }
    let n = view.len() as f64;
    let mean = view.iter().map(|&v| v as f64).sum::<f64>() / n;
    let std = (view.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n)
        .sqrt()
        .max(1e-6);
    let contrast = rng.random_range(0.7..1.3);
    let shift = rng.random_range(-0.2..0.2) * std;
    let noise = rng.random_range(0.0..0.05) * std;
    for v in view.iter_mut() {
        // Box-Muller from two uniforms: one normal draw per value.
        let (u1, u2): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
        let normal = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        *v = (mean + contrast * (*v as f64 - mean) + shift + noise * normal) as f32;
    }
    if rng.random::<f64>() < 0.3 && height > 1 && width > 1 {
        let area = rng.random_range(0.02..0.1) * (height * width) as f64;
        let aspect: f64 = rng.random_range(0.5..2.0);
        let h = ((area * aspect).sqrt().round() as usize).clamp(1, height);
        let w = ((area / aspect).sqrt().round() as usize).clamp(1, width);
        let (y0, x0) = (
            rng.random_range(0..=height - h),
            rng.random_range(0..=width - w),
        );
        for c in 0..channels {
            for y in y0..y0 + h {
                let row = (c * height + y) * width;
                view[row + x0..row + x0 + w].fill(mean as f32);
            }
        }
    }
}

/// Largest zoom of [`reframe_view`], as a fraction of the view's size either way.
const REFRAME_ZOOM: f64 = 0.1;

/// Largest shift of [`reframe_view`], as a fraction of the view's width and height.
const REFRAME_SHIFT: f64 = 0.08;

/// Reframes one view `[C, H, W]` in place: zoomed by a factor in `1 ± REFRAME_ZOOM` about its
/// centre and shifted by up to `REFRAME_SHIFT` of its size, resampled bilinearly, the border
/// repeated where the new frame reaches past the old. To the network this is the camera a step
/// nearer or further and turned a few degrees (at 64x48 and a 59° field of view, a shift of
/// 5 pixels is about 4.6°): new viewpoints between the rendered ones, without the memory of
/// more frames. Place labels stay true; pose labels would not, so pose training never asks.
///
/// Written here rather than with `fast_image_resize` or `imgproc`: the view is already a
/// normalised planar `f32` array `[C, H, W]` (see the module docs), where those take images of
/// interleaved pixels, and zooming out reaches past the border, which a crop box cannot.
pub fn reframe_view(
    view: &mut [f32],
    channels: usize,
    height: usize,
    width: usize,
    rng: &mut ChaCha8Rng,
) {
    if height < 2 || width < 2 || view.len() != channels * height * width {
        return;
    }
    let zoom = 1.0 + rng.random_range(-REFRAME_ZOOM..REFRAME_ZOOM);
    let dx = rng.random_range(-REFRAME_SHIFT..REFRAME_SHIFT) * width as f64;
    let dy = rng.random_range(-REFRAME_SHIFT..REFRAME_SHIFT) * height as f64;
    let (cx, cy) = ((width - 1) as f64 / 2.0, (height - 1) as f64 / 2.0);
    // Source coordinate of each output column and row, split into a cell and a weight.
    let sample = |out: usize, centre: f64, shift: f64, len: usize| {
        let at = ((out as f64 - centre) / zoom + centre + shift).clamp(0.0, (len - 1) as f64);
        let lo = (at.floor() as usize).min(len - 2);
        (lo, (at - lo as f64) as f32)
    };
    let cols: Vec<(usize, f32)> = (0..width).map(|x| sample(x, cx, dx, width)).collect();
    let rows: Vec<(usize, f32)> = (0..height).map(|y| sample(y, cy, dy, height)).collect();
    let plane = height * width;
    let mut source = vec![0.0f32; plane];
    for c in 0..channels {
        let channel = &mut view[c * plane..(c + 1) * plane];
        source.copy_from_slice(channel);
        for (y, &(y0, fy)) in rows.iter().enumerate() {
            let (top, bottom) = (&source[y0 * width..], &source[(y0 + 1) * width..]);
            for (x, &(x0, fx)) in cols.iter().enumerate() {
                let upper = top[x0] + fx * (top[x0 + 1] - top[x0]);
                let lower = bottom[x0] + fx * (bottom[x0 + 1] - bottom[x0]);
                channel[y * width + x] = upper + fy * (lower - upper);
            }
        }
    }
}

/// Strength of the style randomisation, drawn per view: from a gentle repaint to strong
/// coloured light and, now and then, inverted channels.
const STYLE_STRENGTH: std::ops::Range<f64> = 0.3..0.8;

/// Share of training views restyled: the others keep their rendered look, so the network
/// sees both and learns the pose as fast as from plain views while not keying on paint.
const STYLE_PROBABILITY: f64 = 0.5;

/// Restyles one view `[C, H, W]` (grey or RGB) in place for shape-biased training: the view is
/// mapped to bytes over its own range, [`style_randomize`] repaints and relights it keeping its
/// edges (see the module docs), and it is mapped back to the same range. A flat view is left
/// alone.
pub fn style_view(
    view: &mut [f32],
    channels: usize,
    height: usize,
    width: usize,
    rng: &mut ChaCha8Rng,
) {
    let (lo, hi) = view
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let flat = (hi - lo).is_nan() || hi - lo <= 1e-6;
    if flat || (channels != 1 && channels != 3) || view.len() != channels * height * width {
        return;
    }
    let plane = height * width;
    let byte = |v: f32| ((v - lo) / (hi - lo) * 255.0).round().clamp(0.0, 255.0) as u8;
    let back = |b: u8| lo + f32::from(b) / 255.0 * (hi - lo);
    let params = StyleParams {
        strength: rng.random_range(STYLE_STRENGTH),
    };
    let (w, h) = (width as u32, height as u32);
    if channels == 1 {
        let src = image::GrayImage::from_fn(w, h, |x, y| {
            image::Luma([byte(view[y as usize * width + x as usize])])
        });
        let mut dst = image::GrayImage::new(w, h);
        if style_randomize(&src, &mut dst, &params, rng).is_ok() {
            for (v, p) in view.iter_mut().zip(dst.pixels()) {
                *v = back(p.0[0]);
            }
        }
    } else {
        let src = image::RgbImage::from_fn(w, h, |x, y| {
            let i = y as usize * width + x as usize;
            image::Rgb([
                byte(view[i]),
                byte(view[plane + i]),
                byte(view[2 * plane + i]),
            ])
        });
        let mut dst = image::RgbImage::new(w, h);
        if style_randomize(&src, &mut dst, &params, rng).is_ok() {
            for (i, p) in dst.pixels().enumerate() {
                for k in 0..3 {
                    view[k * plane + i] = back(p.0[k]);
                }
            }
        }
    }
}

/// The jitter generator of `epoch` for a run seeded with `seed`.
pub fn jitter_rng(seed: u64, epoch: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(AUGMENT_STREAM + epoch as u64);
    rng
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(len: usize) -> Vec<f32> {
        (0..len).map(|i| (i % 17) as f32 / 8.0 - 1.0).collect()
    }

    #[test]
    fn jitter_keeps_the_view_near_its_statistics_and_follows_the_seed() {
        let view = ramp(3 * 12 * 16);
        let mut a = view.clone();
        jitter_view(&mut a, 3, 12, 16, &mut jitter_rng(5, 1));
        let mut b = view.clone();
        jitter_view(&mut b, 3, 12, 16, &mut jitter_rng(5, 1));
        assert_eq!(a, b, "same seed and epoch, same jitter");
        let mut c = view.clone();
        jitter_view(&mut c, 3, 12, 16, &mut jitter_rng(5, 2));
        assert_ne!(a, c);
        assert_ne!(a, view);
        let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        // The ramp's spread is about 0.6: the mean moves by at most 0.2 of it (plus noise).
        assert!(
            (mean(&a) - mean(&view)).abs() < 0.2,
            "{} {}",
            mean(&a),
            mean(&view)
        );
        assert!(a.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn reframing_zooms_and_shifts_within_bounds() {
        let (c, h, w) = (2, 24, 32);
        // Channel 0 rises along x, channel 1 along y: a zoom and shift keeps each a plane whose
        // slope is the original over the zoom, wherever the frame stays inside the old one.
        let view: Vec<f32> = (0..c * h * w)
            .map(|i| {
                let (ch, y, x) = (i / (h * w), (i / w) % h, i % w);
                if ch == 0 { x as f32 } else { y as f32 }
            })
            .collect();
        let mut a = view.clone();
        reframe_view(&mut a, c, h, w, &mut jitter_rng(3, 1));
        let mut b = view.clone();
        reframe_view(&mut b, c, h, w, &mut jitter_rng(3, 1));
        assert_eq!(a, b, "same seed, same frame");
        assert_ne!(a, view);
        let (lo, hi) = (
            1.0 / (1.0 + REFRAME_ZOOM) - 1e-4,
            1.0 / (1.0 - REFRAME_ZOOM) + 1e-4,
        );
        let mid = h / 2 * w;
        let slopes: Vec<f64> = (1..w)
            .map(|x| f64::from(a[mid + x] - a[mid + x - 1]))
            .filter(|&d| d > 0.0)
            .collect();
        // Columns clamped at the border repeat it (slope 0); the others share one slope.
        assert!(slopes.len() > w / 2, "{slopes:?}");
        for s in &slopes[1..slopes.len() - 1] {
            assert!((lo..=hi).contains(s), "slope {s} outside 1/(1 ± zoom)");
        }
        // The centre moved by at most the largest shift (plus the zoom's rounding).
        let centre = f64::from(a[mid + w / 2]);
        assert!((centre - w as f64 / 2.0).abs() <= REFRAME_SHIFT * w as f64 + 2.0);
        // Interpolation never leaves the original range, and a flat view stays flat.
        assert!(a.iter().all(|&v| (0.0..=(w - 1) as f32).contains(&v)));
        let mut flat = vec![0.25f32; c * h * w];
        reframe_view(&mut flat, c, h, w, &mut jitter_rng(3, 2));
        assert!(flat.iter().all(|&v| (v - 0.25).abs() < 1e-6));
    }

    #[test]
    fn batches_come_in_order_and_stop_when_dropped() {
        let samples = Samples {
            channels: 1,
            width: 2,
            height: 1,
            inputs: (0..10).map(|i| i as f32).collect(),
            poses: vec![geom::Pose::identity(); 5],
            names: (0..5).map(|i| i.to_string()).collect(),
        };
        let targets: Vec<Vec<f32>> = (0..5).map(|i| vec![i as f32]).collect();
        std::thread::scope(|scope| {
            let source = Source {
                samples: &samples,
                targets: &targets,
                planes: None,
            };
            let rx = spawn(scope, source, vec![4, 3, 2, 1, 0], 2, 2, None);
            let first = rx.recv().unwrap();
            assert_eq!(first.rows, 2);
            assert_eq!(first.inputs, vec![8.0, 9.0, 6.0, 7.0]);
            assert_eq!(first.targets, vec![4.0, 3.0]);
            assert_eq!(rx.recv().unwrap().targets, vec![2.0, 1.0]);
            assert!(rx.recv().is_err(), "two steps only");
        });
        std::thread::scope(|scope| {
            let source = Source {
                samples: &samples,
                targets: &targets,
                planes: None,
            };
            let rx = spawn(scope, source, vec![0, 1, 2, 3, 4], 1, 5, None);
            drop(rx);
        });
    }
}
