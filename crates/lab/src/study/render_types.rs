//! `indoorloc study render-types`: which kind of synthetic image transfers best to photos, the
//! render-type comparison of BIM-PoseNet (Acharya et al. 2019) on the built-in building.
//!
//! For each render mode, the demo's dataset is rendered with its training and validation walks
//! in that mode and the demo's network trained on it (`DIR/<mode>/`, reused when there). Every
//! model is tested on the same kind of held-out walk: `textured` (photo-like) under another
//! appearance (`--test-variant`, default `texture-swap`: every surface re-textured), standing in
//! for real photos of the building. As BIM-PoseNet turns real photos into edges or gradient
//! magnitude for the models trained on those renders, the test frames of the `edges` model
//! go through Canny and those of the `gradmag` model through the renderer's own Sobel
//! magnitude (`demo::scene::photo_as`). With `--quick` each mode trains half the quick demo's
//! steps (8000 frames for 4 epochs, views not jittered), so that the four trainings stay within
//! 15 minutes on two cores.

use super::common::ErrorColumns;
use crate::demo::{self, DemoConfig, Evaluation, FrameResult};
use crate::output::{print_json, print_text};
use crate::{Result, ensure};
use clap::Args;
use data::native::NativeDataset;
use learn::Task;
use report::{HtmlReport, Series, Table};
use serde::Serialize;
use std::path::PathBuf;

/// Training frames per mode with `--quick`.
const QUICK_TRAIN_FRAMES: usize = 8000;
/// Epochs per mode with `--quick` (half the quick demo's).
const QUICK_EPOCHS: usize = 4;

/// The render modes compared, in table order.
const MODES: [&str; 4] = ["shaded", "textured", "edges", "gradmag"];

/// Arguments of `indoorloc study render-types`.
#[derive(Args, Debug)]
pub struct RenderTypesConfig {
    /// Folder for the datasets and models (one sub-folder per mode) and `report.html`.
    #[arg(
        long,
        value_name = "DIR",
        default_value = "indoorloc-study-render-types"
    )]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// Render modes to train on (default: shaded, textured, edges, gradmag).
    #[arg(long, value_delimiter = ',', value_parser = MODES)]
    modes: Vec<String>,
    /// Appearance variant of the photo-like test walk.
    #[arg(long, default_value = "texture-swap")]
    test_variant: String,
    /// Monte-Carlo-dropout passes per test frame.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// The render mode trained on.
    mode: String,
    #[serde(flatten)]
    errors: ErrorColumns,
    /// Median validation error on the mode's own renders, metres.
    val_median_pos_m: f64,
}

/// What `study render-types` prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    test_variant: String,
    frames: usize,
    report: PathBuf,
}

/// Runs `indoorloc study render-types`.
pub fn run(args: &RenderTypesConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let modes: Vec<String> = if args.modes.is_empty() {
        MODES.iter().map(|m| m.to_string()).collect()
    } else {
        args.modes.clone()
    };
    // four trainings: --quick gives each half the demo's quick steps, to stay within 15 min
    let mut scale = args.scale.clone();
    if scale.quick {
        scale.train_frames = scale.train_frames.or(Some(QUICK_TRAIN_FRAMES));
        scale.epochs = scale.epochs.or(Some(QUICK_EPOCHS));
    }
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut frames = 0;
    for (k, mode) in modes.iter().enumerate() {
        say(&format!(
            "mode {} of {}: {mode} (test walk: textured, {})",
            k + 1,
            modes.len(),
            args.test_variant
        ));
        let demo_args = DemoConfig {
            render_mode: mode.to_string(),
            test_variant: args.test_variant.clone(),
            augment: Some(false),
            ..scale.demo(&args.out.join(mode))
        };
        let prepared = demo::render_and_train(&demo_args, &say)?;
        let ds = NativeDataset::open(&prepared.data_dir)?;
        let results = demo::localize_test(
            &ds,
            &prepared.model_dir,
            args.mc,
            true,
            prepared.scene().train_mode()?,
        )?;
        ensure!(!results.is_empty(), "{mode}: the test walk has no frames");
        frames = results.len();
        let task = learn::checkpoint::ModelMeta::read(&prepared.model_dir)?
            .coding
            .task;
        rows.push(row(mode, &results, task, &prepared)?);
        curves.push(results);
    }
    let report = args.out.join("report.html");
    write_report(&report, &rows, &modes, &curves, args)?;
    let out = StudyOutput {
        rows,
        test_variant: args.test_variant.clone(),
        frames,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{} test frames (textured, {}); report: {}\n",
                table(&out.rows).to_text(),
                out.frames,
                out.test_variant,
                out.report.display()
            ),
        )
    }
}

fn row(mode: &str, results: &[FrameResult], task: Task, prepared: &demo::Prepared) -> Result<Row> {
    let ev = Evaluation::of(results, task)?;
    Ok(Row {
        mode: mode.to_string(),
        errors: ErrorColumns::of(&ev),
        val_median_pos_m: prepared.val_median_pos_m(),
    })
}

fn table(rows: &[Row]) -> Table {
    let mut header = ErrorColumns::headers(&["trained on"], rows.iter().map(|r| &r.errors));
    header.push("own renders, val median (m)".into());
    let mut t = Table::new(
        "Trained on a render mode, tested on photo-like frames",
        header,
    );
    for r in rows {
        let mut cells = r.errors.cells(vec![r.mode.clone()]);
        cells.push(format!("{:.3}", r.val_median_pos_m));
        t.push_row(cells);
    }
    t
}

fn write_report(
    path: &std::path::Path,
    rows: &[Row],
    modes: &[String],
    results: &[Vec<FrameResult>],
    args: &RenderTypesConfig,
) -> Result<()> {
    let mut page = HtmlReport::new("Render types: synthetic-to-photo transfer");
    page.paragraph(format!(
        "The demo's network trained on walks rendered in each mode, tested on a held-out walk \
         rendered photo-like (textured) under the '{}' appearance. Frames for the edges model \
         are turned into Canny edges, frames for the gradmag model into the renderer's gradient \
         magnitude, as BIM-PoseNet treats real photos. The last column is each model's error \
         on validation frames of its own render mode.",
        args.test_variant
    ));
    page.table(&table(rows));
    let series = |f: fn(&FrameResult) -> f64| -> Vec<Series> {
        modes
            .iter()
            .zip(results)
            .map(|(m, r)| Series::new(m.clone(), r.iter().map(f).collect::<Vec<_>>()))
            .collect()
    };
    let cdf = report::error_cdf(
        "Error CDF per render mode",
        &series(|r| r.pos_err_m),
        &series(|r| r.rot_err_deg),
    );
    page.figure(
        &cdf,
        "Cumulative distribution of the test walk's errors, per mode trained on.",
    )?;
    page.write(path)?;
    Ok(())
}
