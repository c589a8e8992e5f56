//! `indoorloc study cuts`: what a scene cut costs a temporal localizer, and what detecting it
//! saves (the scene-change impact table of the CNN+LSTM indoor APR work).
//!
//! 1. The demo's network (rendered and trained as `demo` does, reused when `--out` already
//!    holds it).
//! 2. A held-out walk through the same zone, joined by hard cuts to other places, with gold cuts.
//! 3. Every frame localized by the network (MC-dropout uncertainty), and cuts detected by
//!    `scenecut` on the rendered frames.
//! 4. The frames fed through the temporal filter (`track::PoseFilter`: constant velocity,
//!    gating) three ways: cuts not handled, reset at the gold cuts, reset at the detected cuts;
//!    and the network alone for reference. Errors are split into frames just after a cut (the
//!    cut frame and the `--cut-window` frames after it, as `eval --cuts` splits them) and the
//!    others.
//! 5. When the model folder holds a sequence model (`train --window`, `study sequence`), its
//!    LSTM runs the walk the same three ways: its state never reset, reset at the gold cuts,
//!    reset at the detected cuts ("starts" counts the runs).

use crate::Result;
use crate::demo::{
    self,
    cuts::{StudyOutput, measure, section, text},
};
use crate::output::{print_json, print_text};
use clap::Args;
use report::HtmlReport;
use std::path::PathBuf;

/// Arguments of `indoorloc study cuts`.
#[derive(Args, Debug)]
pub struct CutsConfig {
    /// Folder for the data, the model and `report.html` (a demo folder is reused as it is).
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-cuts")]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// Walk segments joined by cuts in the test walk (default: 8 with --quick, else 16; at
    /// least 2).
    #[arg(long)]
    segments: Option<usize>,
    /// A frame counts as "after a cut" when it is at most this many frames after one.
    #[arg(long, default_value_t = 10)]
    cut_window: u64,
    /// Monte-Carlo-dropout passes per frame.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs `indoorloc study cuts`.
pub fn run(args: &CutsConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let demo_args = args.scale.demo(&args.out);
    let prepared = demo::render_and_train(&demo_args, &say)?;
    let segments = args
        .segments
        .unwrap_or(if args.scale.quick { 8 } else { 16 });
    crate::ensure!(segments >= 2, "--segments must be at least 2 (one cut)");
    let cut_dir = args.out.join("cut-walk");
    say(&format!(
        "3/4 a held-out walk of {segments} segments joined by cuts ({}): rendering, localizing, \
         detecting cuts, filtering",
        cut_dir.display()
    ));
    let figs = measure(
        prepared.scene(),
        &prepared.model_dir,
        &cut_dir,
        segments,
        args.cut_window,
        args.mc,
    )?;
    say("4/4 writing the report");
    let mut page = HtmlReport::new("Scene cuts and temporal localization");
    section(&mut page, &figs)?;
    let report = args.out.join("report.html");
    page.write(&report)?;
    let out = StudyOutput {
        frames: figs.frames,
        frames_after_cut: figs.frames_after_cut,
        gold_cuts: figs.gold,
        detected_cuts: figs.detected,
        detection: figs.score,
        rows: figs.rows,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(sink, &text(&out))
    }
}
