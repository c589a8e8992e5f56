//! The place classifier on the tiny procedural dataset with place labels made from the pose
//! (which the image colour encodes): training, the stored accuracy, resuming, bad input.

use crate::common;

use std::path::Path;

use data::native::{Label, NativeDataset, write_metadata};
use learn::place::{
    PlaceConfig, PlaceEvent, PlaceFilter, PlaceLoaded, PlaceLocalizer, PlaceSmoother, PlaceSplit,
    PlaceTransitions, WalkFrame, train_place,
};
use learn::{Arch, LearnError};

/// Labels from the pose: building by x, corridor by the sign of y, direction by heading.
fn add_labels(root: &Path) {
    let ds = NativeDataset::open(root).unwrap();
    let labels: Vec<Label> = ds
        .trajectory
        .frames
        .iter()
        .map(|f| {
            let [x, y, _] = f.pose.position();
            Label {
                frame: f.name.parse().unwrap(),
                building: if x < 2.4 { "B0" } else { "B1" }.into(),
                floor: "F0".into(),
                corridor: if y < 0.0 { "C0" } else { "C1" }.into(),
                direction: "fwd".into(),
            }
        })
        .collect();
    write_metadata(
        root,
        &ds.info,
        &ds.trajectory,
        Some(&labels),
        None,
        &ds.splits,
    )
    .unwrap();
}

fn config(data: &Path, out: &Path, epochs: usize) -> PlaceConfig {
    let mut cfg = PlaceConfig::new(data, out);
    cfg.arch = Arch::Small;
    cfg.view = Some("resize=32x24".into());
    cfg.epochs = epochs;
    cfg.batch_size = 8;
    cfg.lr = 3e-3;
    cfg.patience = None;
    cfg.seed = 2;
    cfg
}

#[test]
fn learns_places_and_inference_reproduces_the_stored_accuracy() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, out) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 24);
    add_labels(&data);
    let mut events = Vec::new();
    let summary = train_place(&config(&data, &out, 6), &mut |e| events.push(e.clone())).unwrap();
    assert!(matches!(
        events[0],
        PlaceEvent::Loaded(PlaceLoaded {
            train: 48,
            val: 24,
            classes: [2, 2, 3],
            ..
        })
    ));
    // floors are named within their building (B0/F0, B1/F0), places within their floor
    let acc = summary.val_accuracy;
    assert!(
        acc[0] >= 0.8 && acc[1] >= 0.8 && acc[2] >= 0.6,
        "accuracy {acc:?}"
    );

    // the loaded model gives the stored accuracy on the validation frames
    let loc = PlaceLocalizer::load(&out).unwrap();
    let ds = NativeDataset::open(&data).unwrap();
    let val = ds.split_frames(data::native::SplitName::Val);
    let mut right = [0usize; 3];
    for &i in &val {
        let number = ds.frame_number(i).unwrap();
        let img = image::open(ds.frame_path(number)).unwrap();
        let p = loc.predict(&img).unwrap();
        assert!((0.0..=1.0).contains(&p.corridor.1));
        let want = learn::place::class_names(ds.label(number).unwrap());
        for (level, got) in [&p.building.0, &p.floor.0, &p.corridor.0]
            .iter()
            .enumerate()
        {
            right[level] += usize::from(**got == want[level]);
        }
    }
    let measured = right.map(|r| r as f64 / val.len() as f64);
    assert_eq!(measured, acc);

    // The training walks' motion model: every pair of consecutive training frames (2 walks of
    // 24), at the dataset's frame rate.
    let meta = loc.meta();
    let transitions = meta.transitions.as_ref().expect("a motion model");
    assert_eq!(transitions.pairs, 2 * 23);
    assert!((transitions.frame_s - 1.0 / ds.info.frame_rate).abs() < 1e-9);
    assert_eq!(transitions.changes.len(), meta.classes.corridor.len());
    // Frames that each start a walk are placed alone, as by predict_batch; along the walk the
    // filter gives distributions too.
    let views: Vec<_> = val
        .iter()
        .map(|&i| {
            let img = image::open(ds.frame_path(ds.frame_number(i).unwrap())).unwrap();
            loc.view(&img).unwrap()
        })
        .collect();
    let alone = vec![
        WalkFrame {
            t: None,
            starts_walk: true
        };
        views.len()
    ];
    let batch = loc.predict_batch(&views).unwrap();
    for lag in [0.0, 2.0] {
        let walks = loc.predict_walks(&views, &alone, lag).unwrap();
        assert_eq!(walks.len(), batch.len());
        for (w, b) in walks.iter().zip(&batch) {
            assert_eq!(w.indices, b.indices);
            assert_eq!(w.indices, b.indices);
            for (x, y) in [
                (&w.building, &b.building),
                (&w.floor, &b.floor),
                (&w.corridor, &b.corridor),
            ] {
                assert!(
                    x.0 == y.0 && (x.1 - y.1).abs() < 1e-5,
                    "{w:?} against {b:?}"
                );
            }
        }
    }
    // One walk: every frame is told once, with no lag at once and with the whole walk's lag at
    // the end; the levels stay nested.
    let one_walk: Vec<WalkFrame> = (0..views.len())
        .map(|k| WalkFrame {
            t: None,
            starts_walk: k == 0,
        })
        .collect();
    let whole = loc.predict_walks(&views, &one_walk, f64::INFINITY).unwrap();
    assert_eq!(whole.len(), views.len());
    let mut live = loc.tracker(0.0);
    assert!(live.filters());
    let mut at_end = loc.tracker(f64::INFINITY);
    for view in &views {
        let told = live.step(view, None).unwrap();
        assert_eq!(told.len(), 1);
        let p = &told[0];
        assert!(p.building.1 + 1e-6 >= p.floor.1 && p.floor.1 + 1e-6 >= p.corridor.1);
        assert!(at_end.step(view, None).unwrap().is_empty());
    }
    assert!(live.finish().is_empty());
    // (one frame at a time against a batch: the same places, probabilities to float rounding)
    let last = at_end.finish();
    assert_eq!(last.len(), whole.len());
    for (a, b) in last.iter().zip(&whole) {
        assert_eq!(a.indices, b.indices);
        assert!(
            (a.corridor.1 - b.corridor.1).abs() < 1e-5,
            "{a:?} against {b:?}"
        );
    }

    // resuming to more epochs continues; other settings are refused by name
    let mut more = config(&data, &out, 7);
    more.resume = true;
    let mut events = Vec::new();
    let summary = train_place(&more, &mut |e| events.push(e.clone())).unwrap();
    assert!(events.contains(&PlaceEvent::Resumed { epoch: 6 }));
    assert_eq!(summary.epochs, 7);
    let mut other = more.clone();
    other.epochs = 8;
    other.lr = 1e-2;
    let err = train_place(&other, &mut |_| {}).unwrap_err();
    assert!(
        matches!(&err, LearnError::Mismatch { path, .. } if path.ends_with("place.toml")),
        "{err}"
    );
}

#[test]
fn a_random_split_mixes_sequences_and_unlabelled_data_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_dataset(&data, 6, 10);
    // no labels.csv yet
    let err = train_place(&config(&data, &tmp.path().join("m0"), 1), &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("labels.csv"), "{err}");
    add_labels(&data);
    let mut cfg = config(&data, &tmp.path().join("m1"), 1);
    cfg.split = PlaceSplit::Random;
    let mut events = Vec::new();
    train_place(&cfg, &mut |e| events.push(e.clone())).unwrap();
    // 30 frames pooled, a fifth drawn for validation
    assert!(matches!(
        events[0],
        PlaceEvent::Loaded(PlaceLoaded {
            train: 24,
            val: 6,
            ..
        })
    ));
}

#[test]
fn a_model_from_before_the_pooling_grid_reads_as_global_pooling() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, out) = (tmp.path().join("data"), tmp.path().join("model"));
    common::make_dataset(&data, 6, 10);
    add_labels(&data);
    let mut bad = config(&data, &out, 1);
    bad.grid = 5;
    let err = train_place(&bad, &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("grid 5"), "{err}");
    let mut global = config(&data, &out, 1);
    global.grid = 1;
    train_place(&global, &mut |_| {}).unwrap();
    let img = image::open(NativeDataset::open(&data).unwrap().frame_path(0)).unwrap();
    let before = PlaceLocalizer::load(&out).unwrap().predict(&img).unwrap();
    // an older place.toml has no `grid` keys
    let toml = out.join(learn::place::PLACE_TOML);
    let text = std::fs::read_to_string(&toml).unwrap();
    let old: String = text
        .lines()
        .filter(|l| !l.starts_with("grid ="))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(old.len() < text.len());
    std::fs::write(&toml, old).unwrap();
    let after = PlaceLocalizer::load(&out).unwrap().predict(&img).unwrap();
    assert_eq!(before, after);
    // A motion model without a row per place is refused, naming the file.
    let text = std::fs::read_to_string(&toml).unwrap();
    let cut = text
        .find("[transitions]")
        .expect("a motion model in place.toml");
    let changes = cut + text[cut..].find("changes = ").unwrap();
    std::fs::write(&toml, format!("{}changes = [[0]]\n", &text[..changes])).unwrap();
    let err = PlaceLocalizer::load(&out).unwrap_err();
    assert!(
        err.to_string().contains("place.toml") && err.to_string().contains("[transitions]"),
        "{err}"
    );
    // ... nor a motion model: its frames are placed alone
    std::fs::write(&toml, &text[..cut]).unwrap();
    let old = PlaceLocalizer::load(&out).unwrap();
    let mut tracker = old.tracker(f64::INFINITY);
    assert!(!tracker.filters());
    let view = old.view(&img).unwrap();
    for _ in 0..2 {
        assert_eq!(tracker.step(&view, None).unwrap(), vec![before.clone()]);
    }
    assert!(tracker.finish().is_empty());
}

/// Two buildings, B0 with floors F0 and F1, B1 with F0; places under them.
fn classes() -> learn::place::PlaceClasses {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    learn::place::PlaceClasses {
        building: names(&["B0", "B1"]),
        floor: names(&["B0/F0", "B0/F1", "B1/F0"]),
        corridor: names(&[
            "B0/F0/C0/fwd",
            "B0/F1/C0/fwd",
            "B0/F1/none/none",
            "B1/F0/C1/back",
        ]),
    }
}

#[test]
fn the_heads_are_decoded_as_one_consistent_place() {
    let classes = classes();
    let tree = classes.tree().unwrap();
    assert_eq!(tree, vec![[0, 0], [0, 1], [0, 1], [1, 2]]);
    // The place head leans to B0/F0/C0 (0.40 against 0.35), but the floor head is sure of
    // B0/F1: together they choose B0/F1/C0, which the place head alone would have missed.
    let building = [0.9, 0.1];
    let floor = [0.1, 0.8, 0.1];
    let place = [0.40, 0.35, 0.05, 0.20];
    let [b, f, p] = learn::place::joint([&building, &floor, &place], &tree);
    assert_eq!((b.0, f.0, p.0), (0, 1, 1));
    // The probabilities are the product's posterior: nested, and a place's floor and building
    // hold at least its own mass.
    let score = |i: usize| {
        let [bi, fi] = tree[i];
        building[bi] * floor[fi] * place[i]
    };
    let total: f32 = (0..4).map(score).sum();
    assert!((p.1 - score(1) / total).abs() < 1e-5, "{p:?}");
    assert!((f.1 - (score(1) + score(2)) / total).abs() < 1e-5, "{f:?}");
    assert!(b.1 >= f.1 && f.1 >= p.1 && b.1 <= 1.0 + 1e-6);
    // A head that gives a class zero probability rules it out, without NaNs.
    let [_, _, p] = learn::place::joint([&[0.0, 1.0], &[0.0, 0.0, 1.0], &place], &tree);
    assert_eq!(p.0, 3);
    assert!(p.1.is_finite() && p.1 > 0.99, "{p:?}");
}

#[test]
fn a_place_outside_the_floor_lists_leaves_the_heads_independent() {
    let mut classes = classes();
    classes.corridor.push("B2/F0/C9/fwd".into());
    assert_eq!(classes.tree(), None);
}

#[test]
fn transitions_are_counted_between_consecutive_frames_of_a_walk() {
    // Walk 1: 0, 0, 1; walk 2: 2, 2 (the `None` breaks the chain).
    let chain = [Some(0), Some(0), Some(1), None, Some(2), Some(2)];
    let t = PlaceTransitions::count(chain, 3, 0.4);
    assert_eq!((t.pairs, t.stays), (3, 2));
    assert_eq!(t.changes, vec![vec![0, 1, 0], vec![0; 3], vec![0; 3]]);
    assert_eq!(t.frame_s, 0.4);
    // one pseudo-count each way: (2 + 1) / (3 + 2)
    assert!((t.stay() - 0.6).abs() < 1e-12);
}

/// A motion model over three places where walkers keep their place 95 % of the time and turn
/// from place 0 to place 1 (and back) when they move.
fn sticky() -> PlaceTransitions {
    PlaceTransitions {
        frame_s: 0.4,
        pairs: 1000,
        stays: 950,
        changes: vec![vec![0, 25, 0], vec![25, 0, 0], vec![0, 0, 0]],
    }
}

#[test]
fn the_walk_filter_keeps_the_place_through_an_unclear_frame_and_follows_a_real_change() {
    let mut filter = PlaceFilter::new(&sticky());
    let sure_0 = [0.9, 0.05, 0.05];
    let unclear = [0.4, 0.5, 0.1];
    let sure_1 = [0.05, 0.9, 0.05];
    let best = |b: &[f32]| argmax(b);
    for k in 0..3 {
        let b = filter.step(&sure_0, Some(0.4 * k as f64));
        assert_eq!(best(&b), 0);
        assert!((b.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{b:?}");
    }
    // Alone, the unclear frame reads as place 1; after three frames of place 0 it stays 0.
    assert_eq!(best(&filter.step(&unclear, Some(1.2))), 0);
    // A real turn: two clear frames of place 1 are enough.
    filter.step(&sure_1, Some(1.6));
    assert_eq!(best(&filter.step(&sure_1, Some(2.0))), 1);
    // After a reset the unclear frame stands alone.
    filter.reset();
    assert_eq!(filter.step(&unclear, Some(0.0)), unclear.to_vec());
    // Time matters: long after a clear frame, the walker may be anywhere, and the unclear
    // frame decides for itself again.
    filter.reset();
    filter.step(&sure_0, Some(0.0));
    assert_eq!(best(&filter.step(&unclear, Some(600.0))), 1);
    // A posterior of the wrong length starts the walk over instead of failing.
    assert_eq!(filter.step(&[0.5, 0.5], Some(600.4)), vec![0.5, 0.5]);
    assert_eq!(filter.step(&unclear, Some(600.8)), unclear.to_vec());
}

#[test]
fn the_smoother_settles_a_turn_from_the_frames_after_it_and_tells_every_frame_once() {
    let sure_0 = [0.9, 0.05, 0.05];
    let leaning_1 = [0.3, 0.6, 0.1];
    let sure_1 = [0.05, 0.9, 0.05];
    let walk = [sure_0, sure_0, sure_0, leaning_1, sure_1, sure_1, sure_1];
    let time = |k: usize| Some(0.4 * k as f64);
    // The filter holds on to place 0 at the turn's first frame ...
    let mut filter = PlaceFilter::new(&sticky());
    let filtered: Vec<Vec<f32>> = walk
        .iter()
        .enumerate()
        .map(|(k, p)| filter.step(p, time(k)))
        .collect();
    assert_eq!(argmax(&filtered[3]), 0);
    // ... which the frames after it show to be place 1's.
    let mut whole = PlaceSmoother::new(&sticky(), f64::INFINITY);
    for (k, p) in walk.iter().enumerate() {
        assert!(whole.push(p, time(k)).is_empty());
    }
    let smoothed = whole.finish();
    let best: Vec<usize> = smoothed.iter().map(|b| argmax(b)).collect();
    assert_eq!(best, [0, 0, 0, 1, 1, 1, 1]);
    for b in &smoothed {
        assert!((b.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{b:?}");
    }
    // The last frame has nothing after it: its smoothed belief is the filter's.
    assert!(close(&smoothed[6], &filtered[6]));
    // With no lag the smoother is the filter; with 0.8 s each frame is told two frames late.
    let mut live = PlaceSmoother::new(&sticky(), 0.0);
    let mut late = PlaceSmoother::new(&sticky(), 0.8);
    let mut told_late = Vec::new();
    for (k, p) in walk.iter().enumerate() {
        let now = live.push(p, time(k));
        assert!(now.len() == 1 && close(&now[0], &filtered[k]), "frame {k}");
        let told = late.push(p, time(k));
        assert_eq!(told.len(), usize::from(k >= 2), "frame {k}");
        told_late.extend(told);
    }
    told_late.extend(late.finish());
    assert_eq!(told_late.len(), walk.len());
    assert_eq!(argmax(&told_late[3]), 1);
    // A posterior of the wrong length ends the walk: the frames held are told, then it.
    let mut held = PlaceSmoother::new(&sticky(), f64::INFINITY);
    held.push(&sure_0, time(0));
    held.push(&sure_0, time(1));
    let told = held.push(&[0.5, 0.5], time(2));
    assert_eq!(told.len(), 3);
    assert_eq!(told[2], vec![0.5, 0.5]);
    assert!(held.finish().is_empty());
}

fn close(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
}

fn argmax(v: &[f32]) -> usize {
    (0..v.len()).fold(0, |a, i| if v[i] > v[a] { i } else { a })
}

#[test]
fn a_scene_cut_breaks_the_training_walks_motion_model() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    // training walks s0 (frames 0-9) and s1 (10-19): 18 pairs of consecutive frames
    common::make_dataset(&data, 6, 10);
    add_labels(&data);
    let ds = NativeDataset::open(&data).unwrap();
    write_metadata(
        &data,
        &ds.info,
        &ds.trajectory,
        ds.labels.as_deref(),
        Some(&[5]),
        &ds.splits,
    )
    .unwrap();
    let out = tmp.path().join("model");
    train_place(&config(&data, &out, 1), &mut |_| {}).unwrap();
    let meta = PlaceLocalizer::load(&out).unwrap().meta().clone();
    // frame 5 follows a cut: 4 -> 5 is not a step of the walk
    assert_eq!(meta.transitions.unwrap().pairs, 17);
}

/// The walk filter's and the smoother's claim, guarded: on a long walk through three places
/// whose per-frame beliefs point to a wrong place a third of the time, the filter and the
/// smoother tell the place right far more often than the frames do alone. Deterministic (a
/// fixed draw).
#[test]
fn the_filter_and_the_smoother_beat_frames_alone_on_a_noisy_walk() {
    let transitions = PlaceTransitions {
        frame_s: 0.4,
        pairs: 1000,
        stays: 950,
        changes: vec![vec![0, 10, 10], vec![10, 0, 5], vec![10, 5, 0]],
    };
    let mut state = 0x5eed_u64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut place, mut truth, mut beliefs) = (0usize, Vec::new(), Vec::new());
    for _ in 0..600 {
        if uniform() < 0.05 {
            place = (place + 1 + usize::from(uniform() < 0.5)) % 3;
        }
        let shown = if uniform() < 0.35 {
            (place + 1 + usize::from(uniform() < 0.5)) % 3
        } else {
            place
        };
        let mut belief = vec![0.2f32; 3];
        belief[shown] = 0.6;
        truth.push(place);
        beliefs.push(belief);
    }
    let share = |told: &[Vec<f32>]| {
        told.iter()
            .zip(&truth)
            .filter(|(b, t)| argmax(b) == **t)
            .count() as f64
            / truth.len() as f64
    };
    let time = |k: usize| Some(0.4 * k as f64);
    let mut filter = PlaceFilter::new(&transitions);
    let filtered: Vec<Vec<f32>> = beliefs
        .iter()
        .enumerate()
        .map(|(k, b)| filter.step(b, time(k)))
        .collect();
    let mut smoother = PlaceSmoother::new(&transitions, 2.0);
    let mut smoothed = Vec::new();
    for (k, b) in beliefs.iter().enumerate() {
        smoothed.extend(smoother.push(b, time(k)));
    }
    smoothed.extend(smoother.finish());
    assert_eq!(smoothed.len(), beliefs.len());
    let (alone, walk, lagged) = (share(&beliefs), share(&filtered), share(&smoothed));
    assert!((0.55..0.75).contains(&alone), "frames alone {alone}");
    assert!(
        walk >= alone + 0.15,
        "filter {walk} against frames alone {alone}"
    );
    assert!(lagged >= walk, "smoother {lagged} against filter {walk}");
}
