//! Speed of the networks as `torch_apr.py` measures PyTorch's, for `indoorloc bench train|infer`:
//! the same work on seeded random data, so the two figures compare like for like.
//!
//! - Training step (timed as a whole): forward in training mode, PoseNet loss (β = 1), backward,
//!   Adam step (lr 1e-3, ε 1e-8, no weight decay), reading the loss back.
//! - Inference: the network in evaluation mode on one image, BatchNorm folded into the
//!   convolutions as `Localizer` does, reading the output back.
//!
//! - A localized frame ([`localize_ms`]): what `localize` runs per frame, as the trained
//!   models' head has it (a 1024-wide hidden layer, the per-image scale, dropout 0.2): the
//!   view's test-time copies, the backbone once per view in one batch, the plain head per view
//!   and the MC passes on the frame's own features, outputs read back. PyTorch has no peer of
//!   it; it is compared with one plain pass of the same network.
//!
//! All run `warmup` untimed repetitions first and return every timed one in milliseconds.

use std::time::Instant;

use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Distribution, Tensor};
use geom::Mount;

use imgproc::view::View;

use crate::Result;
use crate::head::{PoseCoding, Task};
use crate::infer::{Passes, predict_outputs};
use crate::loss::pose_loss;
use crate::net::{Arch, HeadConfig, NetConfig};

fn net_config(arch: Arch, channels: usize) -> NetConfig {
    NetConfig {
        arch,
        channels,
        outputs: Task::Pose6.outputs(),
        learned_weighting: false,
        head: HeadConfig::default(),
        split: false,
        planes: false,
    }
}

/// Milliseconds per training step of `arch` on batches `[batch, C, H, W]` (`input` = `[C, H, W]`).
pub fn train_step_ms(
    arch: Arch,
    input: [usize; 3],
    batch: usize,
    warmup: usize,
    steps: usize,
) -> Result<Vec<f64>> {
    let device = crate::device::training();
    let [c, h, w] = input;
    let mut net = net_config(arch, c).init(&device, 0)?;
    let coding = PoseCoding {
        task: Task::Pose6,
        pos_mean: vec![0.0; 3],
        pos_std: vec![1.0; 3],
        mount: Mount::Forward,
        z: 0.0,
    };
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    device.seed(1);
    let x = Tensor::<4>::random([batch, c, h, w], Distribution::Normal(0.0, 1.0), &device);
    let y = Tensor::<2>::random([batch, 7], Distribution::Normal(0.0, 1.0), &device);
    let mut times = Vec::with_capacity(steps);
    for i in 0..warmup + steps {
        let t = Instant::now();
        let out = net.forward(x.clone());
        let loss = pose_loss(&coding, out, y.clone(), 1.0, None).total;
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        net = optim.step(1e-3, net, grads);
        let _ = loss.into_scalar::<f32>();
        if i >= warmup {
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    Ok(times)
}

/// Milliseconds per single-image inference of `arch` on one `[1, C, H, W]` image.
pub fn infer_ms(arch: Arch, input: [usize; 3], warmup: usize, runs: usize) -> Result<Vec<f64>> {
    let device = crate::device::inference();
    let [c, h, w] = input;
    // As `Localizer` runs it: BatchNorm folded into the convolutions.
    let net = net_config(arch, c).init(&device, 0)?.fold_batchnorm();
    let one = Tensor::<4>::random([1, c, h, w], Distribution::Normal(0.0, 1.0), &device);
    timed(warmup, runs, || {
        std::hint::black_box(net.forward(one.clone()).into_data());
        Ok(())
    })
}

/// Milliseconds of each of `runs` calls of `run` after `warmup` untimed ones. (A training step
/// keeps its own loop: it consumes the network and gets the next one back.)
fn timed(warmup: usize, runs: usize, mut run: impl FnMut() -> Result<()>) -> Result<Vec<f64>> {
    let mut times = Vec::with_capacity(runs);
    for i in 0..warmup + runs {
        let t = Instant::now();
        run()?;
        if i >= warmup {
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    Ok(times)
}

/// Milliseconds per frame of `arch` on a `[C, H, W]` view as `localize` runs it: with test-time
/// augmentation (`tta`) and `mc` MC-dropout passes (fewer than 2: none); see the module docs.
pub fn localize_ms(
    arch: Arch,
    input: [usize; 3],
    tta: bool,
    mc: usize,
    warmup: usize,
    runs: usize,
) -> Result<Vec<f64>> {
    let device = crate::device::inference();
    let [c, h, w] = input;
    let defaults = crate::TrainConfig::new("", "");
    let config = NetConfig {
        head: HeadConfig {
            hidden: defaults.hidden,
            aleatoric: defaults.aleatoric,
        },
        ..net_config(arch, c)
    };
    let net = config.init(&device, 0)?.fold_batchnorm();
    // a fixed pseudo-random view: the time does not depend on the values
    let data = (0..c * h * w)
        .map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 24) as f32 / 255.0)
        .collect();
    let view = View {
        channels: c as u32,
        width: w as u32,
        height: h as u32,
        data,
        norm: None,
    };
    let passes = Passes::new(tta, mc, defaults.dropout, crate::DEFAULT_MC_SEED);
    let views = std::slice::from_ref(&view);
    timed(warmup, runs, || {
        std::hint::black_box(predict_outputs(
            &net, views, input, "bench", passes, &device,
        )?);
        Ok(())
    })
}
