//! Training and inference on a GPU through burn's wgpu backend (feature `wgpu`). Its own test
//! binary, as the device is chosen for the whole process: run it with
//! `cargo test -p learn --features wgpu --test gpu`. It needs a Vulkan driver (a GPU's, or
//! Mesa's lavapipe on a machine without one) and fails without one.

// The shared dataset makers; this binary uses only a few of them.
#[allow(dead_code)]
mod common;

use geom::metrics::{position_error, rotation_error_deg};
use learn::device::{self, ComputeDevice};
use learn::{Arch, Localizer, TrainEvent};

#[test]
fn a_gpu_trains_and_its_checkpoint_answers_alike_on_the_cpu() {
    let gpu = device::select(ComputeDevice::Wgpu(None)).expect("a wgpu device (Vulkan driver)");
    eprintln!("wgpu device: {} (a card: {})", gpu.name, gpu.is_gpu);
    assert_eq!(device::selected(), ComputeDevice::Wgpu(None));

    let tmp = tempfile::tempdir().unwrap();
    let (data, out) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 24);
    let mut cfg = common::tiny_config(&data, &out, 7);
    cfg.epochs = 4;
    cfg.aleatoric = false;
    let mut losses = Vec::new();
    let summary = learn::train(&cfg, &mut |e| {
        if let TrainEvent::Step { loss, .. } = e {
            losses.push(*loss);
        }
    })
    .unwrap();
    let head: f64 = losses[..4].iter().sum::<f64>() / 4.0;
    let tail: f64 = losses[losses.len() - 4..].iter().sum::<f64>() / 4.0;
    assert!(tail < 0.7 * head, "loss did not fall: {head} -> {tail}");
    // Better than always answering the mean position (~1.2 m), as on the CPU.
    assert!(
        summary.val_median_pos_m < 1.0,
        "median position error {}",
        summary.val_median_pos_m
    );

    // The checkpoint written from the GPU loads on the CPU, whose kernels give the same poses.
    let on_gpu = Localizer::load(&out).unwrap();
    let on_cpu = Localizer::load_on(&out, burn::tensor::Device::flex()).unwrap();
    let ds = data::native::NativeDataset::open(&data).unwrap();
    for i in ds
        .split_frames(data::native::SplitName::Val)
        .into_iter()
        .take(6)
    {
        let frame = &ds.trajectory.frames[i];
        let img = image::open(ds.frame_path(frame.name.parse().unwrap())).unwrap();
        let (a, b) = (
            on_gpu.predict(&img, 0).unwrap(),
            on_cpu.predict(&img, 0).unwrap(),
        );
        let (dp, dr) = (
            position_error(&a.pose, &b.pose),
            rotation_error_deg(&a.pose, &b.pose),
        );
        assert!(
            dp < 1e-3 && dr < 0.05,
            "frame {i}: GPU and CPU differ by {dp} m, {dr}°"
        );
        // MC dropout and its spread run on the GPU too.
        let mc = on_gpu.predict(&img, 8).unwrap();
        assert!(mc.sigma_pos_m.is_finite() && mc.sigma_pos_m > 0.0);
    }

    // The benchmark's training step and inference run there (on the shapes trained above: each
    // new shape costs kernel compilation and autotuning, minutes on a software rasterizer).
    let steps = learn::bench::train_step_ms(Arch::Small, [3, 24, 32], 8, 1, 2).unwrap();
    let runs = learn::bench::infer_ms(Arch::Small, [3, 24, 32], 1, 2).unwrap();
    assert!(
        steps
            .iter()
            .chain(&runs)
            .all(|ms| ms.is_finite() && *ms > 0.0)
    );
}
