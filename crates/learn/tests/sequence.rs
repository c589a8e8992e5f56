//! The sequence model (CNN+LSTM on frozen features) end to end on the tiny procedural dataset:
//! training, the stored validation figure, live stepping against whole runs, resuming, and
//! refusing a sequence part whose CNN changed.

use crate::common;

use std::path::Path;

use data::native::{NativeDataset, SplitName};
use geom::metrics::{Stats, position_error};
use learn::seq::{SeqConfig, SeqEvent, SeqFeatures, SeqLocalizer, SeqSummary, train_sequence};
use learn::{LearnError, Schedule, train};

fn seq_config(data: &Path, model: &Path, epochs: usize) -> SeqConfig {
    let mut cfg = SeqConfig::new(data, model);
    cfg.window = 4;
    cfg.hidden = 16;
    cfg.epochs = epochs;
    cfg.batch_size = 8;
    cfg.lr = 1e-2;
    // a rate that does not depend on the number of epochs, so that a run resumed to more
    // epochs compares with an unbroken one
    cfg.schedule = Schedule::Constant;
    cfg.jittered_copies = 1;
    cfg.patience = None;
    cfg.seed = 3;
    cfg
}

fn run_seq(cfg: &SeqConfig) -> (SeqSummary, Vec<SeqEvent>) {
    let mut events = Vec::new();
    let summary = train_sequence(cfg, &mut |e| events.push(e.clone())).unwrap();
    (summary, events)
}

/// The validation frames' views, in order, with their poses.
fn val_views(loc: &SeqLocalizer, data: &Path) -> (Vec<imgproc::view::View>, Vec<geom::Pose>) {
    split_views(loc, data, SplitName::Val)
}

/// The views of a split's frames, in order, with their poses.
fn split_views(
    loc: &SeqLocalizer,
    data: &Path,
    split: SplitName,
) -> (Vec<imgproc::view::View>, Vec<geom::Pose>) {
    let ds = NativeDataset::open(data).unwrap();
    ds.split_frames(split)
        .into_iter()
        .map(|i| {
            let frame = &ds.trajectory.frames[i];
            let img = image::open(ds.frame_path(frame.name.parse().unwrap())).unwrap();
            (loc.base().view(&img).unwrap(), frame.pose)
        })
        .unzip()
}

fn close(a: &learn::Estimate, b: &learn::Estimate) -> bool {
    position_error(&a.pose, &b.pose) < 1e-5
        && (a.sigma_pos_m - b.sigma_pos_m).abs() < 1e-5
        && (a.sigma_rot_deg - b.sigma_rot_deg).abs() < 1e-3
}

#[test]
fn trains_on_windows_and_steps_live_as_it_runs_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, model) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 24);
    train(&common::tiny_config(&data, &model, 7), &mut |_| {}).unwrap();
    let (summary, events) = run_seq(&seq_config(&data, &model, 4));
    // two training sequences of 24 frames: 21 windows of 4 in each
    assert!(matches!(
        events[0],
        SeqEvent::Loaded(SeqFeatures {
            train: 48,
            val: 24,
            windows: 42,
            copies: 2,
            ..
        })
    ));
    let losses: Vec<f64> = events
        .iter()
        .filter_map(|e| match e {
            SeqEvent::Step { loss, .. } => Some(*loss),
            _ => None,
        })
        .collect();
    assert_eq!(losses.len(), 4 * 5);
    let head = losses[..3].iter().sum::<f64>() / 3.0;
    let tail = losses[losses.len() - 3..].iter().sum::<f64>() / 3.0;
    assert!(tail < 0.7 * head, "loss {head} -> {tail}");
    assert_eq!(summary.history.len(), 4);
    assert!(model.join("seq.toml").is_file() && model.join("seq.bpk").is_file());

    let loc = SeqLocalizer::load(&model).unwrap();
    let (views, poses) = val_views(&loc, &data);
    // the stored validation error is what inference gives on the validation walk
    let run = loc.predict_run(&views, 0).unwrap();
    let errors: Vec<f64> = run
        .iter()
        .zip(&poses)
        .map(|(e, gt)| position_error(gt, &e.pose))
        .collect();
    let median = Stats::of(&errors).unwrap().median;
    assert!(
        (median - summary.val_median_pos_m).abs() < 1e-4,
        "{median} vs {}",
        summary.val_median_pos_m
    );
    // live stepping gives the whole run's estimates, with and without MC dropout; a reset
    // starts over as a fresh tracker
    for mc in [0, 4] {
        let whole = loc.predict_run(&views, mc).unwrap();
        let mut tracker = loc.tracker(mc);
        assert!(!tracker.has_history());
        for (v, w) in views.iter().zip(&whole) {
            let e = tracker.step(v).unwrap();
            assert!(close(&e, w), "mc {mc}: {e:?} vs {w:?}");
        }
        assert!(tracker.has_history());
        tracker.reset();
        for (v, w) in views.iter().zip(&whole).take(3) {
            assert!(close(&tracker.step(v).unwrap(), w));
        }
        if mc > 1 {
            assert!(whole.iter().all(|e| e.passes == mc && e.sigma_pos_m > 0.0));
        }
    }
    // the history matters: frame 5 after frames 0-4 differs from frame 5 alone
    let alone = loc.predict_run(&views[5..6], 0).unwrap();
    assert!(position_error(&alone[0].pose, &run[5].pose) > 1e-6);
    // runs split the views and start each afresh
    let split = loc.predict_runs(&views, &[0..10, 10..24], 0).unwrap();
    let second = loc.predict_run(&views[10..], 0).unwrap();
    assert!(close(&split[10], &second[0]) && close(&split[3], &run[3]));
}

#[test]
fn resuming_continues_as_an_unbroken_run() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 3, 16);
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    // one CNN for both (training it twice may differ in the last bits: threads sum in any order)
    train(&common::tiny_config(&data, &a, 5), &mut |_| {}).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    for file in ["model.toml", "model.bpk"] {
        std::fs::copy(a.join(file), b.join(file)).unwrap();
    }
    let (full, _) = run_seq(&seq_config(&data, &a, 3));
    let (two, _) = run_seq(&seq_config(&data, &b, 2));
    let mut resumed = seq_config(&data, &b, 3);
    resumed.resume = true;
    let (cont, events) = run_seq(&resumed);
    assert!(matches!(events[1], SeqEvent::Resumed { epoch: 2 }));
    assert_eq!(cont.history.len(), 3);
    assert_eq!(cont.history[..2], two.history[..]);
    for (x, y) in full.history.iter().zip(&cont.history) {
        assert!((x.train_loss - y.train_loss).abs() < 1e-4, "{x:?} vs {y:?}");
        assert!(
            (x.val_median_pos_m - y.val_median_pos_m).abs() < 1e-4,
            "{x:?} vs {y:?}"
        );
    }
    // only the last epoch's state is kept
    let state: Vec<_> = std::fs::read_dir(b.join("seq-state")).unwrap().collect();
    assert_eq!(state.len(), 2);
    // other settings are refused by name
    let mut other = resumed.clone();
    other.hidden = 8;
    other.epochs = 4;
    let err = train_sequence(&other, &mut |_| {}).unwrap_err();
    assert!(
        matches!(&err, LearnError::Mismatch { path, .. } if path.ends_with("seq.toml")),
        "{err}"
    );
}

#[test]
fn a_retrained_network_or_short_recordings_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, model) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 8);
    train(&common::tiny_config(&data, &model, 1), &mut |_| {}).unwrap();
    // windows longer than the recordings
    let mut long = seq_config(&data, &model, 1);
    long.window = 9;
    let err = train_sequence(&long, &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("consecutive"), "{err}");
    run_seq(&seq_config(&data, &model, 1));
    assert!(SeqLocalizer::load(&model).is_ok());
    // the CNN trained again with another seed: its features are not the ones the LSTM knows
    let mut again = common::tiny_config(&data, &model, 2);
    again.force = true;
    train(&again, &mut |_| {}).unwrap();
    let err = SeqLocalizer::load(&model).unwrap_err();
    assert!(
        matches!(&err, LearnError::Mismatch { path, .. } if path.ends_with("seq.toml")),
        "{err}"
    );
}

/// Position errors of estimates against the poses.
fn position_errors(estimates: &[learn::Estimate], poses: &[geom::Pose]) -> Vec<f64> {
    estimates
        .iter()
        .zip(poses)
        .map(|(e, gt)| position_error(gt, &e.pose))
        .collect()
}

/// The sequence model's claim, guarded: on a held-out recording whose frames flicker (what no
/// single frame can tell from a move), it beats the single-frame network it is built on, in
/// median position error and in jitter.
#[test]
fn the_sequence_model_beats_its_own_network_on_a_held_out_walk() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, model) = (tmp.path().join("data"), tmp.path().join("model"));
    let seq_data = tmp.path().join("seq-data");
    // the LSTM trains on recordings the network never saw, as `study sequence` trains it: on
    // the network's own training frames its outputs are too good to need any history
    common::make_flickering_walks(&data, 60, 40.0, 1);
    common::make_flickering_walks(&seq_data, 60, 40.0, 2);
    let mut base = common::tiny_config(&data, &model, 4);
    base.epochs = 8;
    train(&base, &mut |_| {}).unwrap();
    let mut cfg = seq_config(&seq_data, &model, 20);
    cfg.window = 10;
    cfg.hidden = 32;
    // the default rate, as `study sequence` trains: at 3e-3 the validation error jumped from
    // epoch to epoch (0.2 to 0.5 m) and the outcome hung on the last bits of the CNN's features
    cfg.lr = 1e-3;
    run_seq(&cfg);
    let loc = SeqLocalizer::load(&model).unwrap();
    let (views, poses) = split_views(&loc, &data, SplitName::Test);
    let single = position_errors(&loc.base().predict_batch(&views, 0).unwrap(), &poses);
    let sequence = position_errors(&loc.predict_run(&views, 0).unwrap(), &poses);
    let median = |e: &[f64]| Stats::of(e).unwrap().median;
    let jitter = geom::metrics::jitter;
    let (m1, ms) = (median(&single), median(&sequence));
    let (j1, js) = (jitter(&single), jitter(&sequence));
    eprintln!("single {m1:.3} m (jitter {j1:.3}), sequence {ms:.3} m (jitter {js:.3})");
    // measured (sequence against single): 0.193 m against 0.271 m, jitter 0.085 against 0.176
    // on an Intel Xeon with gemm's AVX2 kernels, 0.244 m against 0.291 m, jitter 0.086 against
    // 0.239 with its AVX-512 ones (2026-12-07). The networks' numerics differ between CPUs and kernel
    // versions, so the recipe was checked over five seed pairs on two kernel versions: the
    // sequence model at 0.28x to 0.84x its network's median error. The regression it guards
    // against put the sequence model at 1.6x its network.
    assert!(
        ms <= 0.9 * m1,
        "sequence {ms:.3} m against single {m1:.3} m"
    );
    assert!(js < j1, "jitter {js:.3} against {j1:.3}");
}
