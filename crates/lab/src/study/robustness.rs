//! `indoorloc study robustness`: how pose networks hold up when the building's appearance
//! changes, and what shape-biased training and the dominant-plane task buy.
//!
//! Three models, each the demo's network trained on walks under normal conditions only
//! (`DIR/<model>/`, reused when there):
//! - `baseline`: the building as built (with the quick demo's photometric jitter);
//! - `shape`: shape-biased training, the training walks rendered with randomised materials and
//!   lighting and half the views restyled (`demo --shape-bias`);
//! - `shape+planes`: the same plus the dominant-plane branch (`demo --shape-bias --planes`).
//!
//! All three are tested on one held-out walk rendered under each appearance variant
//! (`DIR/test-walks/`: the same poses, only the appearance changes): normal, some lights off,
//! dim, people walking through, furniture moved, posters changed, after a disaster, every
//! material swapped. A model's growth under a variant is its median position error there over
//! its own normal-condition median. With `--quick` each model trains on 6000 frames for 8
//! epochs, so that the three trainings and the tests stay within 15 minutes on two cores.

use super::common::ErrorColumns;
use crate::demo::{self, DemoConfig, Evaluation, FrameResult};
use crate::output::{print_json, print_text};
use crate::{Result, ensure};
use clap::Args;
use data::native::NativeDataset;
use learn::Localizer;
use report::{HtmlReport, Series, Table};
use serde::Serialize;
use std::path::{Path, PathBuf};
use synth::Variant;

/// Training frames per model with `--quick`.
const QUICK_TRAIN_FRAMES: usize = 6000;
/// Epochs per model with `--quick`.
const QUICK_EPOCHS: usize = 8;

/// A model compared: name, folder, and what it changes in the demo's setup.
type Model = (&'static str, &'static str, fn(DemoConfig) -> DemoConfig);

/// The models compared.
const MODELS: [Model; 3] = [
    ("baseline", "baseline", |d| d),
    ("shape", "shape", |d| DemoConfig {
        shape_bias: Some(true),
        ..d
    }),
    ("shape+planes", "shape-planes", |d| DemoConfig {
        shape_bias: Some(true),
        planes: Some(true),
        ..d
    }),
];

/// The held-out appearance variants (after `normal`).
const HELD_OUT: [Variant; 7] = [
    Variant::SomeLightsOff,
    Variant::Dim,
    Variant::People,
    Variant::FurnitureMoved,
    Variant::PostersChanged,
    Variant::Disaster,
    Variant::TextureSwap,
];

/// Arguments of `indoorloc study robustness`.
#[derive(Args, Debug)]
pub struct RobustnessConfig {
    /// Folder for the datasets and models (one sub-folder per model), the test walks and
    /// `report.html`.
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-robustness")]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// The models to train and compare, comma-separated (default: all three).
    #[arg(long, value_delimiter = ',', value_name = "MODELS",
          value_parser = ["baseline", "shape", "shape+planes"])]
    models: Vec<String>,
    /// The held-out variants to test under, comma-separated (default: all seven); the normal
    /// walk is always tested, as every growth is measured against it.
    #[arg(long, value_delimiter = ',', value_name = "VARIANTS")]
    variants: Vec<Variant>,
    /// Monte-Carlo-dropout passes per test frame (0: one deterministic pass).
    #[arg(long, default_value_t = 0)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table: one model under one variant.
#[derive(Debug, Serialize)]
struct Row {
    /// `normal` or the held-out variant.
    variant: String,
    /// `baseline`, `shape` or `shape+planes`.
    model: String,
    #[serde(flatten)]
    errors: ErrorColumns,
    /// Median position error over the same model's under normal conditions.
    growth: f64,
}

/// Per model, how its errors grow over the held-out variants.
#[derive(Debug, Serialize)]
struct ModelSummary {
    model: String,
    normal_median_pos_m: f64,
    /// Median of the growth over the held-out variants.
    median_growth: f64,
    /// The largest growth, the variant it came from, and the median position error there
    /// (a growth alone flatters a model that is poor under normal conditions too).
    worst_growth: f64,
    worst_variant: String,
    worst_median_pos_m: f64,
    /// Median validation error (normal conditions), metres.
    val_median_pos_m: f64,
    /// Share of validation cells whose plane class the plane branch gets right.
    #[serde(skip_serializing_if = "Option::is_none")]
    val_plane_accuracy: Option<f64>,
}

/// What `study robustness` prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    models: Vec<ModelSummary>,
    frames: usize,
    report: PathBuf,
}

/// Runs `indoorloc study robustness`.
pub fn run(args: &RobustnessConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let mut scale = args.scale.clone();
    if scale.quick {
        scale.train_frames = scale.train_frames.or(Some(QUICK_TRAIN_FRAMES));
        scale.epochs = scale.epochs.or(Some(QUICK_EPOCHS));
    }
    let chosen: Vec<&Model> = MODELS
        .iter()
        .filter(|(name, _, _)| args.models.is_empty() || args.models.iter().any(|m| m == name))
        .collect();
    let held_out: Vec<Variant> = HELD_OUT
        .into_iter()
        .filter(|v| args.variants.is_empty() || args.variants.contains(v))
        .collect();
    ensure!(
        !held_out.is_empty(),
        "--variants names no held-out variant (one of: {})",
        HELD_OUT.map(|v| v.name()).join(", ")
    );
    let mut prepared = Vec::new();
    for (k, (name, dir, extra)) in chosen.iter().enumerate() {
        say(&format!("model {} of {}: {name}", k + 1, chosen.len()));
        let demo_args = DemoConfig {
            train_variants: vec!["normal".into()],
            ..extra(scale.demo(&args.out.join(dir)))
        };
        prepared.push(demo::render_and_train(&demo_args, &say)?);
    }
    let variants: Vec<Variant> = std::iter::once(Variant::Normal)
        .chain(held_out.iter().copied())
        .collect();
    let walks = args.out.join("test-walks");
    say(&format!(
        "the held-out walk under {} appearances, into {}",
        variants.len(),
        walks.display()
    ));
    let plan = prepared[0].scene();
    demo::scene::render_variant_walks(plan, &walks, &variants, &|_| {})?;
    let ds = NativeDataset::open(&walks)?;

    let mut rows = Vec::new();
    let mut results: Vec<Vec<Vec<FrameResult>>> = Vec::new();
    let mut models = Vec::new();
    for ((name, _, _), p) in chosen.iter().zip(&prepared) {
        say(&format!("localizing the walks with {name}"));
        let per_variant = localize_variants(&ds, &p.model_dir, &variants, args.mc)?;
        let task = learn::checkpoint::ModelMeta::read(&p.model_dir)?
            .coding
            .task;
        let evals = per_variant
            .iter()
            .map(|r| Evaluation::of(r, task))
            .collect::<Result<Vec<_>>>()?;
        let normal = evals[0].pos_median;
        for (v, ev) in variants.iter().zip(&evals) {
            rows.push(Row {
                variant: v.name().to_string(),
                model: name.to_string(),
                errors: ErrorColumns::of(ev),
                growth: ev.pos_median / normal,
            });
        }
        let growth: Vec<f64> = evals[1..].iter().map(|e| e.pos_median / normal).collect();
        let (worst, worst_growth) =
            growth
                .iter()
                .enumerate()
                .fold(
                    (0, f64::NEG_INFINITY),
                    |b, (i, &g)| if g > b.1 { (i, g) } else { b },
                );
        let meta = learn::checkpoint::ModelMeta::read(&p.model_dir)?;
        models.push(ModelSummary {
            model: name.to_string(),
            normal_median_pos_m: normal,
            median_growth: crate::output::median(&growth),
            worst_growth,
            worst_variant: held_out[worst].name().to_string(),
            worst_median_pos_m: evals[1 + worst].pos_median,
            val_median_pos_m: p.val_median_pos_m(),
            val_plane_accuracy: meta
                .history
                .iter()
                .find(|m| m.epoch == meta.best_epoch)
                .and_then(|m| m.val_plane_accuracy),
        });
        results.push(per_variant);
    }
    let report = args.out.join("report.html");
    let names: Vec<&str> = chosen.iter().map(|(name, _, _)| *name).collect();
    write_report(&report, &rows, &models, &names, &variants, &results)?;
    let out = StudyOutput {
        frames: results[0][0].len(),
        rows,
        models,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{}\n{} frames per walk; report: {}\n",
                table(&out.rows).to_text(),
                summary_table(&out.models).to_text(),
                out.frames,
                out.report.display()
            ),
        )
    }
}

/// Each variant's walk (sequence `test-<variant>`) localized by the model in `model_dir`.
fn localize_variants(
    ds: &NativeDataset,
    model_dir: &Path,
    variants: &[Variant],
    mc: usize,
) -> Result<Vec<Vec<FrameResult>>> {
    let loc = Localizer::load(model_dir)?;
    let task = loc.meta().coding.task;
    variants
        .iter()
        .map(|v| {
            let seq = format!("{}-{}", demo::scene::TEST_SEQ, v.name());
            let index: Vec<usize> = (0..ds.trajectory.len())
                .filter(|&i| ds.trajectory.frames[i].seq == seq)
                .collect();
            ensure!(
                !index.is_empty(),
                "{}: no frames of '{seq}'",
                ds.root.display()
            );
            let views = demo::views_of(ds, &index, &loc, synth::render::RenderMode::Textured)?;
            let estimates = loc.predict_batch(&views, mc)?;
            Ok(demo::frame_results(ds, &index, estimates, task))
        })
        .collect()
}

fn table(rows: &[Row]) -> Table {
    let mut header = ErrorColumns::headers(&["variant", "model"], rows.iter().map(|r| &r.errors));
    header.push("× normal".into());
    let mut t = Table::new(
        "Trained under normal conditions, tested under each variant",
        header,
    );
    for r in rows {
        let mut cells = r.errors.cells(vec![r.variant.clone(), r.model.clone()]);
        cells.push(format!("{:.2}", r.growth));
        t.push_row(cells);
    }
    t
}

fn summary_table(models: &[ModelSummary]) -> Table {
    let mut t = Table::new(
        "Growth of the median position error over normal conditions",
        [
            "model",
            "normal (m)",
            "median growth",
            "worst growth",
            "worst variant",
            "there (m)",
            "val (m)",
            "plane classes",
        ],
    );
    for m in models {
        t.push_row([
            m.model.clone(),
            format!("{:.3}", m.normal_median_pos_m),
            format!("{:.2}", m.median_growth),
            format!("{:.2}", m.worst_growth),
            m.worst_variant.clone(),
            format!("{:.3}", m.worst_median_pos_m),
            format!("{:.3}", m.val_median_pos_m),
            m.val_plane_accuracy
                .map_or("–".into(), |a| format!("{:.1} %", 100.0 * a)),
        ]);
    }
    t
}

fn write_report(
    path: &Path,
    rows: &[Row],
    models: &[ModelSummary],
    names: &[&str],
    variants: &[Variant],
    results: &[Vec<Vec<FrameResult>>],
) -> Result<()> {
    let mut page = HtmlReport::new("Robustness to appearance change");
    page.paragraph(
        "Networks trained on walks under normal conditions only: the baseline on the \
         building as built, 'shape' with shape-biased training (randomised materials and \
         lighting in the training renders, half the views restyled), 'shape+planes' with \
         the dominant-plane task beside it. Each is tested on one held-out walk rendered under every appearance \
         variant: the same poses, only lights, people, furniture, posters, damage or paint \
         change. Growth is a model's median position error under a variant over its own \
         under normal conditions.",
    );
    page.table(&summary_table(models));
    page.table(&table(rows));
    for (v, variant) in variants.iter().enumerate() {
        let series = |f: fn(&FrameResult) -> f64| -> Vec<Series> {
            names
                .iter()
                .zip(results)
                .map(|(name, r)| Series::new(*name, r[v].iter().map(f).collect::<Vec<_>>()))
                .collect()
        };
        let cdf = report::error_cdf(
            &format!("Error CDF: {}", variant.name()),
            &series(|r| r.pos_err_m),
            &series(|r| r.rot_err_deg),
        );
        page.figure(
            &cdf,
            format!("The held-out walk under '{}', per model.", variant.name()),
        )?;
    }
    page.write(path)?;
    Ok(())
}
