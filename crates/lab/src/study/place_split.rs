//! `indoorloc study place-split`: how much a random frame split flatters a place classifier.
//!
//! 1. Short walks through the whole default building (every building, floor and corridor the
//!    walk graph reaches), rendered with place labels under several appearances
//!    (`DIR/parts/<variant>`, joined into `DIR/data` with each walk a session), and held-out
//!    walks under an appearance no training walk has (`--heldout-variant`: `DIR/heldout`).
//! 2. The place classifier trained twice on the same frames: validation frames drawn at random
//!    (their neighbours a few centimetres away are in training) and validation by recording
//!    session (whole walks held out).
//! 3. Each model's validation accuracy per level, its accuracy on the held-out walks, model size
//!    and one-thread inference time; per-class precision and recall and confusion matrices of
//!    the session model on the held-out walks (`DIR/confusion-<level>.png`, also in the report).

use crate::output::{print_json, print_text};
use crate::progress::bar;
use crate::train::train_with_progress;
use crate::{Context, Result};
use clap::Args;
use data::native::NativeDataset;
use learn::place::{
    LEVELS, PlaceConfig, PlaceLocalizer, PlacePrediction, PlaceSplit, WalkFrame, class_names,
    train_place,
};
use learn::{Localizer, Schedule, Task, TrainConfig};
use report::{HtmlReport, Table};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use synth::Variant;
use synth::dataset::{SynthConfig, WorldSource};

/// Frames per rendered walk, and the walks' frame rate: many short walks sampled every 0.4 s,
/// so that the frames a training run can afford spread over the whole building. At the same
/// 9600 frames, 960 walks of 10 frames at 2.5 Hz gave 83 % session-split corridor accuracy
/// where 240 walks of 40 frames at 10 Hz gave 60 %: near-duplicate frames teach nothing.
const WALK_FRAMES: usize = 10;
const WALK_FPS: f64 = 2.5;

/// The classifier's view in this study: many walks at a small view rather than few at a large
/// one, since a place unseen in training cannot be recognised at any resolution. At 64x48 for
/// 6 epochs the held-out walks' places (session split) were right in 68 % of frames with 9600
/// training frames, 77 % with 19200 (the quick run; 84 % with the third direction and reframing,
/// `study all --quick` at 7c5f8d3), 85 % with 38400, 90.6 % with 76800 (37 min,
/// 5.6 GB on two cores) and 92.8 % with 153600 (the full run: 74 min, 9.5 GB); with a third
/// direction per corridor (`across`, see `synth::trajectory::Direction`), 94.7 % (42 min
/// alone on the machine, 10.4 GB), 95.0–95.2 % with the live walk filter and 96.0–96.2 % with
/// `localize`'s 2 s lag (two runs). The
/// classifier's own default, `place240`, would need 53 GB for 76800 frames (26.5 GB for 38400,
/// which a 24 GB machine refuses).
const STUDY_VIEW: &str = "resize=64x48,norm=imagenet";

/// Epochs of each classifier. On the full study's 153600 frames, 8 against 6: the session
/// split's validation places 95.1 % against 94.8 %, the held-out walks' 94.7 % either way seen
/// alone, 96.4 % against 96.2 % smoothed with `localize`'s lag; the random split's held-out
/// places 94.9 % against 94.3 %.
const STUDY_EPOCHS: usize = 8;

/// Whether the training views are zoomed and shifted a little (`learn::loader::reframe_view`).
/// On 76800 frames (session split, seed 1, the same data), the held-out walks' places
/// were right in 90.6 % of frames with it and 89.9 % without, and the validation walks' in
/// 91.3 % and 90.9 %; a 96x72 view instead gave 90.2 % for 2.3x the training time.
const REFRAME: bool = true;

/// Appearances the training walks are rendered under, an equal share each (the held-out
/// variant is left out): trained under normal light only, the classifier told the buildings
/// apart in 72 % of held-out frames with some lights off; trained under these, in 99 %.
const TRAIN_VARIANTS: [Variant; 4] = [
    Variant::Normal,
    Variant::Dim,
    Variant::Daylight,
    Variant::FurnitureMoved,
];

/// Arguments of `indoorloc study place-split`.
#[derive(Args, Debug)]
pub struct PlaceSplitConfig {
    /// Folder for the datasets, the two models, the confusion matrices and `report.html`.
    #[arg(
        long,
        value_name = "DIR",
        default_value = "indoorloc-study-place-split"
    )]
    out: PathBuf,
    /// An eighth of the frames and half the held-out walks (minutes, not an hour).
    #[arg(long)]
    quick: bool,
    /// Override the number of training frames (rendered as walks of 10 frames at 2.5 Hz).
    #[arg(long)]
    frames: Option<usize>,
    /// Override the number of held-out frames.
    #[arg(long)]
    heldout_frames: Option<usize>,
    /// Override the view (default: 64x48 RGB, ImageNet normalisation; see [`STUDY_VIEW`]).
    #[arg(long)]
    view: Option<String>,
    /// Override the number of epochs (default 8).
    #[arg(long)]
    epochs: Option<usize>,
    /// Appearance variant of the held-out walks.
    #[arg(long, default_value = "some-lights-off")]
    heldout_variant: String,
    /// Seed of the building, walks and training.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also train a pose regressor per building and one for the whole building, and compare
    /// the global one with the per-building ones chosen by the session classifier (and by the
    /// true building) on the held-out walks.
    #[arg(long)]
    hierarchical: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// `random` or `session`.
    split: String,
    /// Validation accuracy per level under this split.
    building_acc: f64,
    floor_acc: f64,
    corridor_acc: f64,
    /// Accuracy on the held-out walks (other walks, other appearance).
    heldout_building_acc: f64,
    heldout_floor_acc: f64,
    heldout_corridor_acc: f64,
    /// Accuracy on the held-out walks with each frame placed given the frames of its walk
    /// before it (the place filter with no lag, as live; reset at every new walk).
    heldout_walk_building_acc: f64,
    heldout_walk_floor_acc: f64,
    heldout_walk_corridor_acc: f64,
    /// The same with `localize`'s default lag ([`learn::place::DEFAULT_LAG_S`]): each frame
    /// also given the frames of its walk up to that long after it.
    heldout_smooth_building_acc: f64,
    heldout_smooth_floor_acc: f64,
    heldout_smooth_corridor_acc: f64,
    /// Size of the weights file, megabytes.
    model_mb: f64,
    /// Median time per image on one thread, milliseconds (view made beforehand).
    infer_ms: f64,
}

/// Precision and recall of one class of the session model on the held-out walks.
#[derive(Debug, Serialize)]
struct ClassRow {
    level: &'static str,
    class: String,
    frames: usize,
    precision: f64,
    recall: f64,
}

/// Pose errors on the held-out walks of one way to choose the pose regressor.
#[derive(Debug, Serialize)]
struct HierarchyRow {
    /// `global` (one regressor for the whole building), `routed` (the per-building regressor
    /// the place classifier picks), `oracle` (the true building's regressor).
    mode: &'static str,
    median_pos_m: f64,
    mean_pos_m: f64,
    median_rot_deg: f64,
}

/// What `study place-split` prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    classes: Vec<ClassRow>,
    /// Global against per-building pose regressors (`--hierarchical`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    hierarchy: Vec<HierarchyRow>,
    train_frames: usize,
    heldout_frames: usize,
    heldout_variant: String,
    confusion: Vec<PathBuf>,
    report: PathBuf,
}

/// Runs `indoorloc study place-split`.
pub fn run(args: &PlaceSplitConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let frames = args
        .frames
        .unwrap_or(if args.quick { 19200 } else { 153600 });
    let heldout_frames = args
        .heldout_frames
        .unwrap_or(if args.quick { 2400 } else { 4800 });
    let variant: Variant = args
        .heldout_variant
        .parse()
        .map_err(|e| crate::err!("--heldout-variant '{}': {e}", args.heldout_variant))?;
    let data = args.out.join("data");
    let heldout = args.out.join("heldout");
    say(&format!(
        "1/4 rendering {frames} labelled frames and {heldout_frames} held-out ({})",
        args.heldout_variant
    ));
    let base = SynthConfig {
        world: WorldSource::Default { seed: args.seed },
        fps: Some(WALK_FPS),
        width: 160,
        height: 120,
        seed: args.seed,
        depth: false,
        planes: false,
        ..SynthConfig::default()
    };
    let appearances: Vec<Variant> = TRAIN_VARIANTS
        .into_iter()
        .filter(|v| *v != variant)
        .collect();
    let mut parts = Vec::new();
    for (k, appearance) in appearances.iter().enumerate() {
        // Frames spread evenly over the appearances; the first ones take the remainder.
        let n = frames / appearances.len() + usize::from(k < frames % appearances.len());
        let root = args.out.join("parts").join(appearance.name());
        render(
            &SynthConfig {
                frames: n,
                sequences: n.div_ceil(WALK_FRAMES).max(5),
                variant: *appearance,
                walk_seed: Some(args.seed + k as u64),
                ..base.clone()
            },
            &root,
        )?;
        parts.push(data::concat::Part {
            prefix: appearance.name().to_string(),
            root,
        });
    }
    data::concat::concat(&data, "default building, several appearances", &parts)?;
    render(
        &SynthConfig {
            frames: heldout_frames,
            sequences: heldout_frames.div_ceil(WALK_FRAMES).max(1),
            variant,
            seed: args.seed + 1000,
            ..base.clone()
        },
        &heldout,
    )?;

    let ds = NativeDataset::open(&heldout)?;
    let views_img: Vec<image::DynamicImage> = (0..ds.trajectory.len())
        .map(|i| {
            let path = ds.frame_path(ds.frame_number(i).unwrap_or(i as u64));
            data::frames::decode_image(&path).with_context(|| path.display().to_string())
        })
        .collect::<Result<_>>()?;
    let truth: Vec<[String; 3]> = (0..ds.trajectory.len())
        .map(|i| {
            let frame = ds.frame_number(i).unwrap_or(i as u64);
            ds.label(frame)
                .map(class_names)
                .with_context(|| format!("{}: no label for frame {frame}", heldout.display()))
        })
        .collect::<Result<_>>()?;
    let walk_frames = walk_frames(&ds);

    let mut rows = Vec::new();
    let mut session_predictions = None;
    for (k, split) in [PlaceSplit::Random, PlaceSplit::Session]
        .into_iter()
        .enumerate()
    {
        let name = if split == PlaceSplit::Random {
            "random"
        } else {
            "session"
        };
        say(&format!("{}/4 training with a {name} split", k + 2));
        let model = args.out.join(format!("model-{name}"));
        let mut cfg = PlaceConfig::new(&data, &model);
        cfg.view = Some(args.view.clone().unwrap_or_else(|| STUDY_VIEW.into()));
        cfg.epochs = args.epochs.unwrap_or(STUDY_EPOCHS);
        cfg.split = split;
        // photometric jitter: the held-out walks are seen under other lighting
        cfg.augment = true;
        // viewpoints between the walks' frames (see REFRAME)
        cfg.reframe = REFRAME;
        cfg.seed = args.seed;
        cfg.resume = true;
        let pb = bar(cfg.epochs as u64, &format!("{name} split"));
        let summary = train_place(&cfg, &mut |e| {
            if let learn::place::PlaceEvent::Epoch(m) = e {
                pb.set_position(m.epoch as u64);
            }
        })?;
        pb.finish_and_clear();
        let loc = PlaceLocalizer::load(&model)?;
        let views = views_img
            .iter()
            .map(|img| loc.view(img))
            .collect::<learn::Result<Vec<_>>>()?;
        let predicted = loc.predict_batch(&views)?;
        let heldout_acc = heldout_accuracy(&predicted, &truth);
        let [wb, wf, wc] = heldout_accuracy(&loc.predict_walks(&views, &walk_frames, 0.0)?, &truth);
        let [sb, sf, sc] = heldout_accuracy(
            &loc.predict_walks(&views, &walk_frames, learn::place::DEFAULT_LAG_S)?,
            &truth,
        );
        let infer_ms = one_thread_ms(&loc, &views)?;
        let model_mb = std::fs::metadata(model.join(learn::place::PLACE_BPK))?.len() as f64 / 1e6;
        let [b, f, c] = summary.val_accuracy;
        let [hb, hf, hc] = heldout_acc;
        rows.push(Row {
            split: name.into(),
            building_acc: b,
            floor_acc: f,
            corridor_acc: c,
            heldout_building_acc: hb,
            heldout_floor_acc: hf,
            heldout_corridor_acc: hc,
            heldout_walk_building_acc: wb,
            heldout_walk_floor_acc: wf,
            heldout_walk_corridor_acc: wc,
            heldout_smooth_building_acc: sb,
            heldout_smooth_floor_acc: sf,
            heldout_smooth_corridor_acc: sc,
            model_mb,
            infer_ms,
        });
        if split == PlaceSplit::Session {
            session_predictions = Some((loc, predicted));
        }
    }
    say("4/4 per-class figures, confusion matrices and the report");
    let (loc, predicted) = session_predictions.context("the session model was not trained")?;
    let mut page = HtmlReport::new("Place recognition: random against session split");
    page.paragraph(format!(
        "A place classifier (building, floor, corridor and walking direction) trained on {frames} \
         frames of walks through the default building, once with validation frames drawn at \
         random and once with whole walks held out. The held-out columns are other walks under \
         the '{}' appearance. A random split puts near-twins of the validation frames in \
         training, so its validation accuracy says little about new visits.",
        args.heldout_variant
    ));
    page.table(&table(&rows));
    let mut classes = Vec::new();
    let mut confusion = Vec::new();
    for (level, name) in LEVELS.iter().enumerate() {
        let names = loc.meta().classes.levels()[level];
        let (counts, class_rows) = per_class(name, names, &predicted, &truth, level);
        let png = report::confusion_png(
            &format!("{name}: session model on the held-out walks"),
            names,
            &counts,
        )?;
        let path = args.out.join(format!("confusion-{name}.png"));
        data::io::write_atomic(&path, |w| w.write_all(&png))?;
        page.png(
            &png,
            format!("Confusion matrix, {name} (rows: true class)."),
        );
        confusion.push(path);
        classes.extend(class_rows);
    }
    page.table(&class_table(&classes));
    let hierarchy = if args.hierarchical {
        say("   pose regressors: one for the whole building, one per building");
        let rows = hierarchy(args, &data, &ds, &views_img, &predicted, &truth)?;
        page.section("Hierarchical localization");
        page.paragraph(
            "One pose regressor trained on every building, against one per building chosen by \
             the place classifier's building (and, as the bound, by the true building), on the \
             held-out walks.",
        );
        page.table(&hierarchy_table(&rows));
        rows
    } else {
        Vec::new()
    };
    let report = args.out.join("report.html");
    page.write(&report)?;
    let out = StudyOutput {
        rows,
        classes,
        hierarchy,
        train_frames: frames,
        heldout_frames: truth.len(),
        heldout_variant: args.heldout_variant.clone(),
        confusion,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        let hierarchy = if out.hierarchy.is_empty() {
            String::new()
        } else {
            format!("{}\n", hierarchy_table(&out.hierarchy).to_text())
        };
        print_text(
            sink,
            &format!(
                "{}\n{hierarchy}{} training frames, {} held-out ({}); report: {}\n",
                table(&out.rows).to_text(),
                out.train_frames,
                out.heldout_frames,
                out.heldout_variant,
                out.report.display()
            ),
        )
    }
}

/// What the labels of a render mean, beside its settings: a render from before the `across`
/// direction (two directions per corridor) is made again rather than trained on.
const LABELS: &str = "directions fwd/back/across";

/// Renders `cfg` into `dir` unless an earlier run left the same dataset there.
fn render(cfg: &SynthConfig, dir: &Path) -> Result<()> {
    let key = format!("{cfg:?}\nlabels: {LABELS}");
    let key_path = dir.join("study-plan.txt");
    if std::fs::read_to_string(&key_path).is_ok_and(|k| k == key)
        && dir.join(data::native::POSES_CSV).is_file()
    {
        return Ok(());
    }
    let pb = bar(cfg.frames as u64, "render");
    // the study's own folder, rendered with other settings before: replaced
    let cfg = SynthConfig {
        force: true,
        ..cfg.clone()
    };
    synth::dataset::run(&cfg, dir, &|n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    data::io::write_atomic(&key_path, |w| w.write_all(key.as_bytes()))?;
    Ok(())
}

/// The time of each frame of `ds` and whether it starts a walk (a new sequence, a cut, a gap
/// in frame numbers), as `localize` would follow them.
fn walk_frames(ds: &NativeDataset) -> Vec<WalkFrame> {
    let cuts = ds.cuts.clone().unwrap_or_default();
    let frames = &ds.trajectory.frames;
    (0..frames.len())
        .map(|i| {
            let number = ds.frame_number(i);
            let starts_walk = i == 0
                || frames[i - 1].seq != frames[i].seq
                || number.is_none_or(|n| {
                    ds.frame_number(i - 1).map(|m| m + 1) != Some(n)
                        || cuts.binary_search(&n).is_ok()
                });
            WalkFrame {
                t: frames[i].t,
                starts_walk,
            }
        })
        .collect()
}

/// Accuracy per level of predictions against true class names.
fn heldout_accuracy(predicted: &[PlacePrediction], truth: &[[String; 3]]) -> [f64; 3] {
    let mut right = [0usize; 3];
    for (p, t) in predicted.iter().zip(truth) {
        for (level, got) in [&p.building.0, &p.floor.0, &p.corridor.0]
            .into_iter()
            .enumerate()
        {
            right[level] += usize::from(*got == t[level]);
        }
    }
    right.map(|r| r as f64 / truth.len().max(1) as f64)
}

/// Median milliseconds per image of the network on one thread.
fn one_thread_ms(loc: &PlaceLocalizer, views: &[imgproc::view::View]) -> Result<f64> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let timed = &views[..views.len().min(50)];
    pool.install(|| -> Result<f64> {
        if let Some(first) = timed.first() {
            loc.predict_batch(std::slice::from_ref(first))?;
        }
        let mut ms = Vec::with_capacity(timed.len());
        for v in timed {
            let t = Instant::now();
            loc.predict_batch(std::slice::from_ref(v))?;
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(crate::output::median(&ms))
    })
}

/// The confusion counts `[true][predicted]` over the model's classes of `level` (frames whose
/// true class the model does not know are left out of the matrix) and each class's precision
/// and recall.
fn per_class(
    level_name: &'static str,
    names: &[String],
    predicted: &[PlacePrediction],
    truth: &[[String; 3]],
    level: usize,
) -> (Vec<Vec<usize>>, Vec<ClassRow>) {
    let n = names.len();
    let mut counts = vec![vec![0usize; n]; n];
    for (p, t) in predicted.iter().zip(truth) {
        if let Ok(row) = names.binary_search(&t[level]) {
            counts[row][p.indices[level]] += 1;
        }
    }
    let rows = (0..n)
        .filter_map(|k| {
            let frames: usize = counts[k].iter().sum();
            let called: usize = counts.iter().map(|r| r[k]).sum();
            (frames > 0 || called > 0).then(|| ClassRow {
                level: level_name,
                class: names[k].clone(),
                frames,
                precision: counts[k][k] as f64 / called.max(1) as f64,
                recall: counts[k][k] as f64 / frames.max(1) as f64,
            })
        })
        .collect();
    (counts, rows)
}

fn pct(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Place accuracy: validation under each split, and held-out walks",
        [
            "split",
            "building",
            "floor",
            "place",
            "held-out building",
            "held-out floor",
            "held-out place",
            "held-out place, walk filter",
            "held-out place, smoothed",
            "model (MB)",
            "ms / image (1 thread)",
        ],
    );
    for r in rows {
        t.push_row([
            r.split.clone(),
            pct(r.building_acc),
            pct(r.floor_acc),
            pct(r.corridor_acc),
            pct(r.heldout_building_acc),
            pct(r.heldout_floor_acc),
            pct(r.heldout_corridor_acc),
            pct(r.heldout_walk_corridor_acc),
            pct(r.heldout_smooth_corridor_acc),
            format!("{:.2}", r.model_mb),
            format!("{:.2}", r.infer_ms),
        ]);
    }
    t
}

fn class_table(rows: &[ClassRow]) -> Table {
    let mut t = Table::new(
        "Per class, session model on the held-out walks",
        ["level", "class", "frames", "precision", "recall"],
    );
    for r in rows {
        t.push_row([
            r.level.to_string(),
            r.class.clone(),
            r.frames.to_string(),
            pct(r.precision),
            pct(r.recall),
        ]);
    }
    t
}

/// Trains the global and per-building pose regressors (reused when trained before) and
/// measures them on the held-out walks (`classes`: each frame's true class names), routed three
/// ways.
fn hierarchy(
    args: &PlaceSplitConfig,
    data: &Path,
    heldout: &NativeDataset,
    images: &[image::DynamicImage],
    predicted: &[PlacePrediction],
    classes: &[[String; 3]],
) -> Result<Vec<HierarchyRow>> {
    let ds = NativeDataset::open(data)?;
    let labels = ds
        .labels
        .as_ref()
        .with_context(|| format!("{}: no labels.csv", data.display()))?;
    let mut buildings: Vec<String> = labels.iter().map(|l| l.building.clone()).collect();
    buildings.sort();
    buildings.dedup();
    let train = |dir: &Path, model: &Path| -> Result<Localizer> {
        let mut cfg = TrainConfig::new(dir, model);
        cfg.task = Some(Task::Pose6);
        cfg.view = Some(
            if args.quick {
                "gray,resize=64x48,norm=pm1"
            } else {
                "gray,resize=80x60,norm=pm1"
            }
            .into(),
        );
        cfg.epochs = if args.quick { 4 } else { 8 };
        cfg.lr = 2e-3;
        cfg.schedule = Schedule::Cosine {
            final_fraction: 0.02,
        };
        cfg.patience = None;
        cfg.seed = args.seed;
        cfg.resume = true;
        train_with_progress(&cfg, !args.json)?;
        Ok(Localizer::load(model)?)
    };
    let global = train(data, &args.out.join("pose-all"))?;
    let mut per_building = Vec::new();
    for b in &buildings {
        let dir = args.out.join(format!("data-{b}"));
        if write_subset(&ds, labels, b, &dir)? {
            per_building.push((b.clone(), train(&dir, &args.out.join(format!("pose-{b}")))?));
        }
    }
    let views = images
        .iter()
        .map(|img| global.view(img))
        .collect::<learn::Result<Vec<_>>>()?;
    let truth: Vec<geom::Pose> = heldout.trajectory.frames.iter().map(|f| f.pose).collect();
    let global_poses: Vec<geom::Pose> = global
        .predict_batch(&views, 0)?
        .into_iter()
        .map(|e| e.pose)
        .collect();
    // frame i through the regressor of building `choice[i]`; frames routed to a building
    // without its own regressor keep the global estimate
    let routed = |choice: &[&str]| -> Result<Vec<geom::Pose>> {
        let mut out = global_poses.clone();
        for (b, loc) in &per_building {
            let idx: Vec<usize> = (0..views.len()).filter(|&i| choice[i] == b).collect();
            let picked: Vec<_> = idx.iter().map(|&i| views[i].clone()).collect();
            for (i, est) in idx.iter().zip(loc.predict_batch(&picked, 0)?) {
                out[*i] = est.pose;
            }
        }
        Ok(out)
    };
    let by_classifier = routed(
        &predicted
            .iter()
            .map(|p| p.building.0.as_str())
            .collect::<Vec<_>>(),
    )?;
    let by_truth = routed(&classes.iter().map(|c| c[0].as_str()).collect::<Vec<_>>())?;
    [
        ("global", global_poses),
        ("routed", by_classifier),
        ("oracle", by_truth),
    ]
    .into_iter()
    .map(|(mode, poses)| {
        let pos: Vec<f64> = poses
            .iter()
            .zip(&truth)
            .map(|(e, gt)| geom::metrics::position_error(gt, e))
            .collect();
        let rot: Vec<f64> = poses
            .iter()
            .zip(&truth)
            .map(|(e, gt)| geom::metrics::rotation_error_deg(gt, e))
            .collect();
        let (p, r) = (
            geom::metrics::Stats::of(&pos)?,
            geom::metrics::Stats::of(&rot)?,
        );
        Ok(HierarchyRow {
            mode,
            median_pos_m: p.median,
            mean_pos_m: p.mean,
            median_rot_deg: r.median,
        })
    })
    .collect()
}

/// The frames of building `building` as a native dataset in `dir` (the same frame numbers, the
/// images reached through a link to the full dataset's `frames/`), splits kept by sequence;
/// false when too few walks passed through the building to train and validate a regressor.
fn write_subset(
    ds: &NativeDataset,
    labels: &[data::native::Label],
    building: &str,
    dir: &Path,
) -> Result<bool> {
    let keep: std::collections::HashSet<u64> = labels
        .iter()
        .filter(|l| l.building == building)
        .map(|l| l.frame)
        .collect();
    let frames: Vec<data::PoseFrame> = ds
        .trajectory
        .frames
        .iter()
        .filter(|f| f.name.parse::<u64>().is_ok_and(|n| keep.contains(&n)))
        .cloned()
        .collect();
    let mut seqs: Vec<String> = frames.iter().map(|f| f.seq.clone()).collect();
    seqs.sort();
    seqs.dedup();
    let only = |list: &[String]| -> Vec<String> {
        list.iter().filter(|s| seqs.contains(s)).cloned().collect()
    };
    let mut splits = data::native::Splits {
        train: only(&ds.splits.train),
        val: only(&ds.splits.val),
        test: only(&ds.splits.test),
    };
    // a building no validation walk passed through validates on one of its training walks
    if splits.val.is_empty() && splits.train.len() >= 2 {
        splits.val.extend(splits.train.pop());
    }
    if splits.train.is_empty() || splits.val.is_empty() {
        return Ok(false);
    }
    let kept: Vec<data::native::Label> = labels
        .iter()
        .filter(|l| keep.contains(&l.frame))
        .cloned()
        .collect();
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let link = dir.join("frames");
    if !link.exists() {
        let target = std::fs::canonicalize(ds.root.join("frames"))?;
        std::os::unix::fs::symlink(&target, &link)
            .with_context(|| format!("cannot link {} to {}", link.display(), target.display()))?;
    }
    let mut trajectory = data::Trajectory::new(frames);
    trajectory.camera = ds.trajectory.camera;
    data::native::write_metadata(dir, &ds.info, &trajectory, Some(&kept), None, &splits)?;
    Ok(true)
}

fn hierarchy_table(rows: &[HierarchyRow]) -> Table {
    let mut t = Table::new(
        "Pose regressors on the held-out walks",
        ["regressor", "median (m)", "mean (m)", "median (°)"],
    );
    for r in rows {
        let name = match r.mode {
            "global" => "one for all buildings",
            "routed" => "per building, chosen by the classifier",
            _ => "per building, chosen by the true building",
        };
        t.push_row([
            name.to_string(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.3}", r.mean_pos_m),
            format!("{:.2}", r.median_rot_deg),
        ]);
    }
    t
}
