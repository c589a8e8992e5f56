//! `indoorloc scenecut`: visual-rhythm hard cuts and gradual transitions in a video, an image
//! folder or a native dataset; optionally scored against gold cuts and drawn as a picture.

use crate::output::{print_json, print_text};
use crate::progress::bar;
use crate::{Context, Result};
use clap::Args;
use scenecut::{Collect, Config, Detection, Gold, PathKind, Score, TransitionKind};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `indoorloc scenecut`.
#[derive(Args, Debug)]
pub struct ScenecutConfig {
    /// A video file, a folder of images, or a native dataset (its `frames/`).
    input: PathBuf,
    /// Draw the visual rhythm, the difference series and the cuts into this PNG.
    #[arg(long, value_name = "PNG")]
    plot: Option<PathBuf>,
    /// Write the cuts as a `cuts.csv` list (header `frame`) for `eval --cuts`.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Score against gold cuts: a `cuts.csv` / list of frames, `{"cuts": [...]}`, or a
    /// `gold.json` with a `videos` list (the entry named like INPUT).
    #[arg(long, value_name = "FILE")]
    gold: Option<PathBuf>,
    /// Frames a detection may be off a gold cut and still count.
    #[arg(long, default_value_t = 2)]
    tol: u64,
    /// Pixel path of the visual rhythm: grid (every 4th row and column), gridN, diagonal,
    /// cross (centre row + column), star (diagonals + cross).
    #[arg(long, default_value = "grid")]
    path: String,
    /// Least ratio of a frame's difference to its neighbours' (low-passed) level for a cut.
    #[arg(long, default_value_t = Config::default().ratio)]
    ratio: f32,
    /// Least margin of a cut's difference over its neighbours' level, grey levels.
    #[arg(long, default_value_t = Config::default().min_jump)]
    min_jump: f32,
    /// Least frames between two cuts.
    #[arg(long, default_value_t = Config::default().min_gap)]
    min_gap: u64,
    /// Thumbnail width the frames are shrunk to before sampling the path.
    #[arg(long, default_value_t = Config::default().thumb_width)]
    width: u32,
    /// Hard cuts only: do not look for fades and dissolves.
    #[arg(long)]
    no_gradual: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One gradual transition in the output.
#[derive(Debug, Serialize)]
struct GradualOut {
    first: u64,
    last: u64,
    kind: TransitionKind,
}

/// What `scenecut` prints.
#[derive(Debug, Serialize)]
struct ScenecutOutput {
    input: PathBuf,
    /// First frame of each new scene.
    cuts: Vec<u64>,
    /// Frames read.
    frames: u64,
    /// Frames processed per second, decoding included.
    fps: f64,
    /// The video's own frame rate, where it has one.
    video_fps: Option<f64>,
    gradual: Vec<GradualOut>,
    /// Frames that could not be read.
    skipped: u64,
    seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    gold: Option<GoldOut>,
}

#[derive(Debug, Serialize)]
struct GoldOut {
    file: PathBuf,
    tol_frames: u64,
    gold_cuts: Vec<u64>,
    #[serde(flatten)]
    score: Score,
}

/// The detector settings the arguments ask for.
fn config(args: &ScenecutConfig) -> Result<Config> {
    let cfg = Config {
        thumb_width: args.width,
        path: args.path.parse::<PathKind>()?,
        ratio: args.ratio,
        min_jump: args.min_jump,
        min_gap: args.min_gap,
        gradual: if args.no_gradual {
            None
        } else {
            Config::default().gradual
        },
        ..Config::default()
    };
    cfg.validate()?;
    Ok(cfg)
}

/// Runs `indoorloc scenecut`.
pub fn run(args: &ScenecutConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let cfg = config(args)?;
    let gold = args
        .gold
        .as_ref()
        .map(|g| Gold::read(g, &args.input))
        .transpose()?;
    let pb = bar(0, "frames");
    let det = scenecut::detect_input(
        &args.input,
        &cfg,
        Collect {
            trace: args.plot.is_some(),
            rhythm: args.plot.is_some(),
        },
        &mut |done, expected| {
            if let Some(n) = expected {
                pb.set_length(n.max(done));
            }
            pb.set_position(done);
        },
    )?;
    pb.finish_and_clear();
    if let Some(e) = &det.first_error {
        crate::progress::note(&format!(
            "indoorloc: warning: {} frame(s) could not be read and were skipped; first: {e}",
            det.skipped
        ));
    }
    if let Some(out) = &args.out {
        data::cuts::write(&det.cut_frames(), out)?;
    }
    if let Some(png) = &args.plot {
        write_plot(&det, &args.input, gold.as_ref(), png)?;
    }
    let output = ScenecutOutput {
        input: args.input.clone(),
        cuts: det.cut_frames(),
        frames: det.frames,
        fps: det.frames as f64 / det.seconds.max(1e-9),
        video_fps: det.video_fps,
        gradual: det
            .gradual
            .iter()
            .map(|g| GradualOut {
                first: g.first,
                last: g.last,
                kind: g.kind,
            })
            .collect(),
        skipped: det.skipped,
        seconds: det.seconds,
        gold: match (&gold, &args.gold) {
            (Some(g), Some(file)) => Some(GoldOut {
                file: file.clone(),
                tol_frames: args.tol,
                gold_cuts: g.hard_cuts.clone(),
                score: scenecut::score_hard(&det.cut_frames(), g, args.tol),
            }),
            _ => None,
        },
    };
    if args.json {
        print_json(sink, &output)
    } else {
        print_text(sink, &table(&output))
    }
}

fn table(o: &ScenecutOutput) -> String {
    let mut t = format!(
        "{}: {} frames in {:.2} s ({:.0} frames/s)\nhard cuts ({}): {:?}\n",
        o.input.display(),
        o.frames,
        o.seconds,
        o.fps,
        o.cuts.len(),
        o.cuts
    );
    if !o.gradual.is_empty() {
        t.push_str(&format!("gradual transitions ({}):\n", o.gradual.len()));
        for g in &o.gradual {
            t.push_str(&format!("  {:>7} – {:<7} {:?}\n", g.first, g.last, g.kind));
        }
    }
    if let Some(g) = &o.gold {
        t.push_str(&format!(
            "against {} (±{} frames): precision {:.3}  recall {:.3}  F1 {:.3}  missed {:?}  false {:?}\n",
            g.file.display(),
            g.tol_frames,
            g.score.precision,
            g.score.recall,
            g.score.f1,
            g.score.missed,
            g.score.false_positives
        ));
    }
    t
}

fn write_plot(det: &Detection, input: &Path, gold: Option<&Gold>, png: &Path) -> Result<()> {
    let (Some(trace), Some(rhythm)) = (&det.trace, &det.rhythm) else {
        crate::bail!("the detector kept no series to plot");
    };
    let image = rhythm
        .to_image()
        .context("no frame to draw in the visual rhythm")?;
    let title = format!(
        "Visual rhythm of {}",
        input.file_name().map_or_else(
            || input.display().to_string(),
            |n| n.to_string_lossy().into()
        )
    );
    let cuts = det.cut_frames();
    let gradual: Vec<[u64; 2]> = det.gradual.iter().map(|g| [g.first, g.last]).collect();
    let bytes = report::rhythm_png(&report::RhythmPlot {
        title: &title,
        rhythm: &image,
        stride: rhythm.stride(),
        frames: &trace.frames,
        score: &trace.score,
        threshold: &trace.threshold,
        cuts: &cuts,
        gradual: &gradual,
        gold: gold.map_or(&[][..], |g| &g.hard_cuts),
    })?;
    report::write_atomic(png, &bytes)?;
    Ok(())
}
