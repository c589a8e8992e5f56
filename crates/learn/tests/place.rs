//! The place classifier on the tiny procedural dataset with place labels made from the pose
//! (which the image colour encodes): training, the stored accuracy, resuming, bad input.

use crate::common;

use std::path::Path;

use data::native::{Label, NativeDataset, write_metadata};
use learn::place::{PlaceConfig, PlaceEvent, PlaceLoaded, PlaceLocalizer, PlaceSplit, train_place};
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
