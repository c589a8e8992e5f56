//! Training batches, assembled on a worker thread while the previous step trains, optionally
//! jittered ([`jitter_view`]).
//!
//! The jitter works on the views already in memory (after grey conversion, resizing, CLAHE and
//! normalisation), not on source images: `imgproc::augment` needs the `u8` source image, which
//! training does not keep (40 000 frames would be gigabytes). What can be done to a finished
//! view is photometric — contrast and brightness about the view's own mean and spread, sensor
//! noise, and occluding rectangles — which keeps every pose label true and works whatever the
//! view's normalisation. Geometric jitter would falsify 6-DoF labels and is left out.
//!
//! Determinism: the jitter of epoch `e` comes from a ChaCha generator seeded with the run's
//! seed on stream `AUGMENT_STREAM + e`, drawn in batch order on the one worker thread, so it
//! does not depend on timing; the frame order is decided by the caller.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::Scope;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::dataset::Samples;

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
}

/// Starts a worker in `scope` that sends the batches of `order` (`steps` batches of `size`)
/// in order, jittered when `jitter` holds the epoch's generator. It stops early when the
/// receiver is dropped.
pub fn spawn<'scope>(
    scope: &'scope Scope<'scope, '_>,
    samples: &'scope Samples,
    targets: &'scope [Vec<f32>],
    order: Vec<usize>,
    size: usize,
    steps: usize,
    jitter: Option<ChaCha8Rng>,
) -> Receiver<Batch> {
    let (tx, rx) = sync_channel(PREFETCH);
    scope.spawn(move || produce(samples, targets, &order, size, steps, jitter, &tx));
    rx
}

fn produce(
    samples: &Samples,
    targets: &[Vec<f32>],
    order: &[usize],
    size: usize,
    steps: usize,
    mut jitter: Option<ChaCha8Rng>,
    tx: &SyncSender<Batch>,
) {
    let n = samples.view_len();
    for step in 0..steps {
        let idx = &order[step * size..(step + 1) * size];
        let mut inputs = Vec::with_capacity(idx.len() * n);
        let mut values = Vec::with_capacity(idx.len() * targets[0].len());
        for &i in idx {
            let start = inputs.len();
            inputs.extend_from_slice(samples.input(i));
            if let Some(rng) = jitter.as_mut() {
                jitter_view(
                    &mut inputs[start..],
                    samples.channels,
                    samples.height,
                    samples.width,
                    rng,
                );
            }
            values.extend_from_slice(&targets[i]);
        }
        let batch = Batch {
            inputs,
            targets: values,
            rows: idx.len(),
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
            let rx = spawn(scope, &samples, &targets, vec![4, 3, 2, 1, 0], 2, 2, None);
            let first = rx.recv().unwrap();
            assert_eq!(first.rows, 2);
            assert_eq!(first.inputs, vec![8.0, 9.0, 6.0, 7.0]);
            assert_eq!(first.targets, vec![4.0, 3.0]);
            assert_eq!(rx.recv().unwrap().targets, vec![2.0, 1.0]);
            assert!(rx.recv().is_err(), "two steps only");
        });
        std::thread::scope(|scope| {
            let rx = spawn(scope, &samples, &targets, vec![0, 1, 2, 3, 4], 1, 5, None);
            drop(rx);
        });
    }
}
