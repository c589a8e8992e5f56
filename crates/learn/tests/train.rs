//! Training, checkpoints and inference end to end on a tiny procedural dataset.

use crate::common;

use std::path::Path;

use geom::metrics::{Stats, position_error, rotation_error_deg};
use learn::{
    Arch, LearnError, Loaded, Localizer, Schedule, Task, TrainConfig, TrainEvent, TrainSummary,
    train,
};

/// A config that trains the small net on the tiny dataset in a few seconds.
fn tiny_config(data: &Path, out: &Path, epochs: usize) -> TrainConfig {
    let mut cfg = TrainConfig::new(data, out);
    cfg.arch = Arch::Small;
    cfg.view = Some("resize=32x24".into());
    cfg.epochs = epochs;
    cfg.batch_size = 8;
    cfg.lr = 3e-3;
    cfg.schedule = Schedule::Constant;
    cfg.beta = 1.0;
    // A loss that is a plain error, so that "the loss falls" means what it says; the per-image
    // scale (whose likelihood can be negative) has its own test.
    cfg.aleatoric = false;
    cfg.seed = 7;
    cfg
}

fn run(cfg: &TrainConfig) -> (TrainSummary, Vec<TrainEvent>) {
    let mut events = Vec::new();
    let summary = train(cfg, &mut |e| events.push(e.clone())).unwrap();
    (summary, events)
}

fn step_losses(events: &[TrainEvent]) -> Vec<f64> {
    events
        .iter()
        .filter_map(|e| match e {
            TrainEvent::Step { loss, .. } => Some(*loss),
            _ => None,
        })
        .collect()
}

/// Median position / rotation errors of a loaded model on the validation frames, read from disk.
fn val_errors(loc: &Localizer, data: &Path) -> (f64, f64) {
    let ds = data::native::NativeDataset::open(data).unwrap();
    let (mut pos, mut rot) = (Vec::new(), Vec::new());
    for i in ds.split_frames(data::native::SplitName::Val) {
        let frame = &ds.trajectory.frames[i];
        let img = image::open(ds.frame_path(frame.name.parse().unwrap())).unwrap();
        let est = loc.predict(&img, 0).unwrap();
        pos.push(position_error(&frame.pose, &est.pose));
        rot.push(rotation_error_deg(&frame.pose, &est.pose));
    }
    (
        Stats::of(&pos).unwrap().median,
        Stats::of(&rot).unwrap().median,
    )
}

#[test]
fn loss_falls_and_inference_reproduces_the_stored_validation_error() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, out) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 24);
    let (summary, events) = run(&tiny_config(&data, &out, 4));
    assert!(matches!(
        events[0],
        TrainEvent::Loaded(Loaded {
            train: 48,
            val: 24,
            input: [3, 24, 32],
            ..
        })
    ));
    let losses = step_losses(&events);
    assert_eq!(losses.len(), 4 * 6);
    let head: f64 = losses[..4].iter().sum::<f64>() / 4.0;
    let tail: f64 = losses[losses.len() - 4..].iter().sum::<f64>() / 4.0;
    assert!(tail < 0.7 * head, "loss did not fall: {head} -> {tail}");
    assert_eq!(summary.epochs, 4);
    assert_eq!(summary.history.len(), 4);
    for f in [
        "model.toml",
        "model.bpk",
        "state/weights-0004.bpk",
        "state/optimizer-0004.bpk",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(
        !out.join("state/weights-0003.bpk").exists(),
        "old state is pruned"
    );

    let loc = Localizer::load(&out).unwrap();
    assert_eq!(loc.meta().coding.task, Task::Pose6);
    assert_eq!(loc.meta().best_epoch, summary.best_epoch);
    let (pos, rot) = val_errors(&loc, &data);
    assert!(
        (pos - summary.val_median_pos_m).abs() < 1e-4,
        "{pos} vs {}",
        summary.val_median_pos_m
    );
    assert!(
        (rot - summary.val_median_rot_deg).abs() < 1e-3,
        "{rot} vs {}",
        summary.val_median_rot_deg
    );
    // The model learned something: better than always answering the mean position (~1.2 m).
    assert!(pos < 1.0, "median position error {pos}");

    // The calibration's passes over the validation frames, handed on for the fused track's,
    // are what the calibrated model gives those frames read from disk.
    let passes = summary.validation.expect("24 validation frames calibrate");
    let ds = data::native::NativeDataset::open(&data).unwrap();
    let val = ds.split_frames(data::native::SplitName::Val);
    let names: Vec<String> = val
        .iter()
        .map(|&i| {
            format!(
                "{}/{}",
                ds.trajectory.frames[i].seq, ds.trajectory.frames[i].name
            )
        })
        .collect();
    assert_eq!(passes.names, names);
    let loc = loc.with_tta(true);
    let views: Vec<_> = val
        .iter()
        .map(|&i| {
            let name = &ds.trajectory.frames[i].name;
            loc.view(&image::open(ds.frame_path(name.parse().unwrap())).unwrap())
                .unwrap()
        })
        .collect();
    let again = loc
        .predict_batch(&views, learn::calibrate::CALIBRATION_MC)
        .unwrap();
    assert_eq!(passes.estimates.len(), again.len());
    for (handed, now) in passes.estimates.iter().zip(&again) {
        assert_eq!(handed.passes, now.passes);
        assert!(
            position_error(&handed.pose, &now.pose) < 1e-6,
            "{handed:?} {now:?}"
        );
        assert!(
            (handed.cov_pos_m2 - now.cov_pos_m2).abs().max() < 1e-9,
            "{handed:?} {now:?}"
        );
        assert!((handed.sigma_rot_deg - now.sigma_rot_deg).abs() < 1e-6);
    }
    // A model resumed with its calibration made hands on nothing.
    let mut cfg = tiny_config(&data, &out, 4);
    cfg.resume = true;
    assert_eq!(run(&cfg).0.validation, None);
}

#[test]
fn resume_continues_from_the_last_epoch_and_matches_an_uninterrupted_run() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 16);
    // With view jitter on, so that its generator is checked to resume as well.
    let jittered = |out: &Path, epochs| {
        let mut cfg = tiny_config(&data, out, epochs);
        cfg.augment = true;
        cfg
    };
    let straight = tmp.path().join("straight");
    let (full, _) = run(&jittered(&straight, 2));
    let (plain, _) = run(&tiny_config(&data, &tmp.path().join("plain"), 2));
    assert_ne!(
        plain.history[0].train_loss, full.history[0].train_loss,
        "the jitter changes what the network sees"
    );

    let split = tmp.path().join("split");
    let (first, _) = run(&jittered(&split, 1));
    assert_eq!(first.epochs, 1);
    let mut cfg = jittered(&split, 2);
    cfg.resume = true;
    let (second, events) = run(&cfg);
    assert!(events.contains(&TrainEvent::Resumed { epoch: 1 }));
    assert_eq!(step_losses(&events).len(), 4, "only epoch 2 runs");
    assert_eq!(second.epochs, 2);
    assert_eq!(second.history.len(), 2);
    assert_eq!(second.history[0], first.history[0]);
    let (a, b) = (&full.history[1], &second.history[1]);
    assert!(
        (a.val_median_pos_m - b.val_median_pos_m).abs() < 1e-4,
        "{a:?} vs {b:?}"
    );
    assert!((a.train_loss - b.train_loss).abs() < 1e-4, "{a:?} vs {b:?}");

    // Resuming a finished run trains nothing.
    let (again, events) = run(&cfg);
    assert_eq!(step_losses(&events).len(), 0);
    assert_eq!(again.epochs, 2);
}

#[test]
fn damaged_or_mismatched_checkpoints_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 8);
    let out = tmp.path().join("model");
    run(&tiny_config(&data, &out, 1));

    // Other settings on resume.
    let mut cfg = tiny_config(&data, &out, 2);
    cfg.resume = true;
    cfg.beta = 5.0;
    let err = train(&cfg, &mut |_| {}).unwrap_err();
    assert!(matches!(err, LearnError::Mismatch { .. }), "{err}");
    assert!(err.to_string().contains("model.toml"), "{err}");

    // Other data on resume.
    let other = tmp.path().join("other");
    common::make_dataset(&other, 6, 9);
    let mut cfg = tiny_config(&other, &out, 2);
    cfg.resume = true;
    let err = train(&cfg, &mut |_| {}).unwrap_err();
    assert!(matches!(err, LearnError::Mismatch { .. }), "{err}");

    // Damaged weights.
    let bpk = out.join("model.bpk");
    let mut bytes = std::fs::read(&bpk).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0xff;
    std::fs::write(&bpk, &bytes).unwrap();
    let err = Localizer::load(&out).unwrap_err();
    assert!(matches!(err, LearnError::Corrupt { .. }), "{err}");
    assert!(err.to_string().contains("model.bpk"), "{err}");

    // Truncated weights whose hash was "fixed up": the record itself is refused.
    let toml_path = out.join("model.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    let meta: learn::checkpoint::ModelMeta = toml::from_str(&text).unwrap();
    std::fs::write(&bpk, &bytes[..n / 3]).unwrap();
    let mut fixed = meta.clone();
    fixed.weights_hash = learn_hash(&bytes[..n / 3]);
    std::fs::write(&toml_path, toml::to_string(&fixed).unwrap()).unwrap();
    let err = Localizer::load(&out).unwrap_err();
    assert!(matches!(err, LearnError::Corrupt { .. }), "{err}");

    // Garbage model.toml, missing checkpoint.
    std::fs::write(&toml_path, "arch = [").unwrap();
    let err = Localizer::load(&out).unwrap_err();
    assert!(err.to_string().contains("model.toml"), "{err}");
    let err = Localizer::load(&tmp.path().join("nothing")).unwrap_err();
    assert!(err.to_string().contains("model.toml"), "{err}");
}

/// The checkpoint's content hash (FNV-1a 64), computed independently.
fn learn_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    format!("fnv1a64:{h:016x}")
}

#[test]
fn mc_dropout_gives_uncertainty_deterministically_and_pose3_gives_level_ceiling_poses() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 3, 8);
    let out = tmp.path().join("model");
    let mut cfg = tiny_config(&data, &out, 1);
    cfg.view = Some("gray,resize=32x24".into());
    cfg.dropout = 0.3;
    run(&cfg);
    let loc = Localizer::load(&out).unwrap();
    assert_eq!(loc.meta().coding.task, Task::Pose3);
    assert_eq!(loc.meta().input, [1, 24, 32]);
    let img = image::open(data.join("frames/000003.png")).unwrap();

    let plain = loc.predict(&img, 0).unwrap();
    // No spread, no scale output: only the millimetre floor on x and y.
    assert!(
        (plain.sigma_pos_m - 2e-6f64.sqrt()).abs() < 1e-9,
        "{plain:?}"
    );
    assert_eq!((plain.sigma_rot_deg, plain.passes), (0.0, 0));
    assert_eq!(loc.predict(&img, 1).unwrap(), plain);
    // A level ceiling camera: optical axis straight up.
    let up = plain.pose.rotation * nalgebra::Vector3::z();
    assert!((up.z - 1.0).abs() < 1e-9, "{up:?}");
    let p3 = plain.pose3.unwrap();
    assert!((p3.x - plain.pose.translation.x).abs() < 1e-12);

    let mc = loc.predict(&img, 16).unwrap();
    assert_eq!(mc.passes, 16);
    assert!(mc.sigma_pos_m > 0.0 && mc.sigma_rot_deg > 0.0, "{mc:?}");
    assert_eq!(
        loc.predict(&img, 16).unwrap(),
        mc,
        "same seed, same estimate"
    );
    // Every image goes through the same MC ensemble: its estimate does not depend on the other
    // images of the batch or on its place among them.
    let view = loc.view(&img).unwrap();
    let other = loc
        .view(&image::open(data.join("frames/000001.png")).unwrap())
        .unwrap();
    let batch = loc
        .predict_batch(&[view.clone(), other.clone(), view], 16)
        .unwrap();
    assert_eq!(batch.len(), 3);
    for e in [&batch[0], &batch[2]] {
        assert!((e.sigma_pos_m - mc.sigma_pos_m).abs() < 1e-6, "{e:?}");
        assert!((e.sigma_rot_deg - mc.sigma_rot_deg).abs() < 1e-6, "{e:?}");
    }
    let alone = loc.predict_view(&other, 16).unwrap();
    assert!((batch[1].sigma_pos_m - alone.sigma_pos_m).abs() < 1e-6);
    let other = Localizer::load(&out)
        .unwrap()
        .with_seed(99)
        .predict(&img, 16)
        .unwrap();
    assert_ne!(other.sigma_pos_m, mc.sigma_pos_m);

    // A view of the wrong size is an error, not a panic.
    let wrong = imgproc::view::ViewSpec::resolve("gray,resize=16x16")
        .unwrap()
        .apply(&img, 0)
        .unwrap();
    assert!(matches!(
        loc.predict_view(&wrong, 0),
        Err(LearnError::Input(_))
    ));
}

#[test]
fn the_per_image_scale_gives_uncertainty_without_mc_passes() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 8);
    let out = tmp.path().join("model");
    let mut cfg = tiny_config(&data, &out, 2);
    cfg.hidden = 32;
    cfg.aleatoric = true;
    assert!(TrainConfig::new(&data, &out).aleatoric, "on by default");
    run(&cfg);
    let loc = Localizer::load(&out).unwrap();
    assert!(loc.meta().net.head.aleatoric);
    let img = image::open(data.join("frames/000003.png")).unwrap();
    let plain = loc.predict(&img, 0).unwrap();
    assert_eq!(plain.passes, 0);
    assert!(
        plain.sigma_pos_m.is_finite() && plain.sigma_pos_m > 0.0,
        "{plain:?}"
    );
    assert!(plain.sigma_rot_deg < 1e-9, "{plain:?}");
    let mc = loc.predict(&img, 8).unwrap();
    assert!(mc.sigma_pos_m > 0.0 && mc.sigma_rot_deg > 0.0, "{mc:?}");
}

#[test]
fn two_networks_train_and_localize_a_ceiling_camera() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 3, 8);
    let out = tmp.path().join("model");
    let mut cfg = tiny_config(&data, &out, 3);
    cfg.view = Some("gray,resize=32x24".into());
    cfg.hidden = 32;
    cfg.split = true;
    let (summary, events) = run(&cfg);
    let losses = step_losses(&events);
    let (head, tail) = (losses[0], losses[losses.len() - 1]);
    assert!(tail < head, "loss did not fall: {head} -> {tail}");
    let loc = Localizer::load(&summary.out).unwrap();
    assert!(loc.meta().net.split);
    let img = image::open(data.join("frames/000003.png")).unwrap();
    let est = loc.predict(&img, 8).unwrap();
    assert!(est.pose3.is_some() && est.sigma_pos_m > 0.0, "{est:?}");
    let (pos, _) = val_errors(&loc, &data);
    assert!((pos - summary.val_median_pos_m).abs() < 1e-3);
}

#[test]
fn the_plane_branch_and_shape_bias_train_and_the_network_can_be_explained() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 16);
    let out = tmp.path().join("model");
    let mut cfg = tiny_config(&data, &out, 12);
    cfg.view = Some("resize=64x48".into());
    cfg.hidden = 32;
    cfg.planes = true;
    cfg.shape_bias = true;
    // Without depth there is nothing to learn the planes from: an error naming the file.
    let err = train(&cfg, &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("depth") && err.contains("000000.png"), "{err}");
    common::add_depth_and_planes(&data, true);
    let (summary, events) = run(&cfg);
    let losses = step_losses(&events);
    assert!(losses.iter().all(|l| l.is_finite()));
    let accuracy: Vec<f64> = summary
        .history
        .iter()
        .map(|m| m.val_plane_accuracy.unwrap())
        .collect();
    // A third of the cells are floor: always answering "wall" would score 0.67.
    assert!(accuracy[accuracy.len() - 1] > 0.9, "{accuracy:?}");
    let loc = Localizer::load(&summary.out).unwrap();
    assert!(loc.meta().net.planes && loc.meta().config.shape_bias);
    let (pos, _) = val_errors(&loc, &data);
    assert!((pos - summary.val_median_pos_m).abs() < 1e-3);
    // Grad-CAM on the stride-8 map (8x6 cells for a 64x48 view) and on the last (2x2):
    // values in [0, 1], the peak at 1, one score.
    let img = image::open(data.join("frames/000005.png")).unwrap();
    let explainer = learn::Explainer::load(&summary.out).unwrap();
    let view = explainer.view(&img).unwrap();
    let mid = explainer.grad_cam(&view, learn::CamLayer::Mid).unwrap();
    let last = explainer.grad_cam(&view, learn::CamLayer::Last).unwrap();
    assert_eq!(
        (mid.width, mid.height, last.width, last.height),
        (8, 6, 2, 2)
    );
    for cam in [&mid, &last] {
        assert!(cam.values.iter().all(|v| (0.0..=1.0).contains(v)));
        assert!(cam.values.contains(&1.0), "{cam:?}");
    }
    assert!(mid.score > 0.0 && (mid.score - last.score).abs() < 1e-6 * mid.score);
    // Without plane ids the planes are found in the depth (RANSAC) and training still works.
    std::fs::remove_dir_all(data.join("planes")).unwrap();
    let mut cfg = tiny_config(&data, &tmp.path().join("model-ransac"), 1);
    cfg.planes = true;
    let (summary, _) = run(&cfg);
    assert!(summary.history[0].val_plane_accuracy.is_some());
}

#[test]
fn bad_configurations_and_datasets_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 4);
    let out = tmp.path().join("model");
    let mut cfg = tiny_config(&data, &out, 1);
    cfg.batch_size = 1;
    assert!(matches!(
        train(&cfg, &mut |_| {}),
        Err(LearnError::Config(_))
    ));
    let mut cfg = tiny_config(&data, &out, 1);
    cfg.learned_weighting = true;
    cfg.aleatoric = true;
    let err = train(&cfg, &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("learned weighting"), "{err}");
    let mut cfg = tiny_config(&data, &out, 1);
    cfg.view = Some("resize=0x3".into());
    assert!(matches!(
        train(&cfg, &mut |_| {}),
        Err(LearnError::Config(_))
    ));
    std::fs::remove_file(data.join("frames/000002.png")).unwrap();
    let err = train(&tiny_config(&data, &out, 1), &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("000002.png"), "{err}");
    let err = train(&tiny_config(&tmp.path().join("none"), &out, 1), &mut |_| {}).unwrap_err();
    assert!(
        err.to_string().contains("none") && err.to_string().contains("No such file"),
        "{err}"
    );
}
