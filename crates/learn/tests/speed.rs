//! Speed of one training step of the small network, batch 32, 1x120x160, as `torch_apr.py
//! --arch small` times it (forward in training mode, PoseNet loss, backward, Adam step). Run
//! with `cargo test --release -p learn --test speed -- --ignored --nocapture`.

use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Distribution, Tensor};
use geom::Mount;
use learn::loss::pose_loss;
use learn::{Arch, NetConfig, PoseCoding, Task};

#[test]
#[ignore = "timing; run in release"]
fn small_net_training_step_and_inference() {
    let device = Device::flex().autodiff();
    let mut net = NetConfig {
        arch: Arch::Small,
        channels: 1,
        outputs: 7,
        learned_weighting: false,
    }
    .init(&device, 0)
    .unwrap();
    let coding = PoseCoding {
        task: Task::Pose6,
        pos_mean: vec![0.0; 3],
        pos_std: vec![1.0; 3],
        mount: Mount::Forward,
        z: 0.0,
    };
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    device.seed(1);
    let x = Tensor::<4>::random([32, 1, 120, 160], Distribution::Normal(0.0, 1.0), &device);
    let y = Tensor::<2>::random([32, 7], Distribution::Normal(0.0, 1.0), &device);
    let mut times = Vec::new();
    for i in 0..13 {
        let t = Instant::now();
        let out = net.forward(x.clone());
        let loss = pose_loss(&coding, out, y.clone(), 1.0, None).total;
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        net = optim.step(1e-3, net, grads);
        let _ = loss.into_scalar::<f32>();
        if i >= 3 {
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "small net train step, batch 32, 1x120x160: median {:.1} ms ({} threads)",
        times[times.len() / 2],
        rayon::current_num_threads()
    );

    let plain = Device::flex();
    let valid = net.valid();
    let one = Tensor::<4>::zeros([1, 1, 120, 160], &plain);
    let mut times = Vec::new();
    for i in 0..23 {
        let t = Instant::now();
        let _ = valid.forward(one.clone()).into_data();
        if i >= 3 {
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "small net inference, one 1x120x160 image: median {:.2} ms",
        times[times.len() / 2]
    );
}
