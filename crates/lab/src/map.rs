//! `indoorloc map build`: the keyframe map of a posed dataset (`map::keyframes`), its features
//! lifted to 3-D by depth or triangulated between keyframes, which `localize --map` refines
//! poses against.

use crate::output::{print_json, print_text};
use crate::progress;
use crate::{Result, bail};
use clap::{Args, Subcommand};
use data::blocks::BlockSplit;
use data::posed::{self, SplitPlan};
use map::triangulate::TriangulationConfig;
use map::{BuildConfig, Lifting};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `indoorloc map`.
#[derive(Args, Debug)]
pub struct MapConfig {
    #[command(subcommand)]
    action: Action,
}

#[derive(Subcommand, Debug)]
enum Action {
    /// Build the map of a posed dataset: RGB-D (7-Scenes, TUM RGB-D, native with depth) or
    /// photos alone (COLMAP, NeRF transforms, Cambridge), triangulated.
    Build(MapBuildConfig),
}

/// Arguments of `indoorloc map build`.
#[derive(Args, Debug)]
pub struct MapBuildConfig {
    /// A posed dataset, in any layout `data` opens.
    #[arg(long, value_name = "DATASET")]
    data: PathBuf,
    /// The map file to write (atomically).
    #[arg(long, value_name = "MAP")]
    out: PathBuf,
    /// Blocks of consecutive frames, BLOCK:EVERY[:OFFSET], as `train --blocks`: the map holds
    /// the training and validation blocks, never the held-out ones.
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
    /// Map every frame, held-out ones included (a map to use, not to evaluate on).
    #[arg(long, conflicts_with = "blocks")]
    all: bool,
    /// A frame becomes a keyframe when the camera has moved this far since the last, metres.
    #[arg(long, default_value_t = BuildConfig::default().spacing_m)]
    spacing: f64,
    /// …or turned this far, degrees.
    #[arg(long, default_value_t = BuildConfig::default().spacing_deg)]
    spacing_deg: f64,
    /// Local features per keyframe.
    #[arg(long, default_value_t = BuildConfig::default().extract.max_features)]
    features: usize,
    /// How features get their 3-D points: `depth` (each frame's depth image), `triangulation`
    /// (between keyframes, from their poses) or `auto` (depth when every frame has it).
    #[arg(long, value_enum, default_value_t = LiftArg::Auto)]
    lift: LiftArg,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// `--lift`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum LiftArg {
    Auto,
    Depth,
    Triangulation,
}

/// What `map build` prints.
#[derive(Debug, Serialize)]
struct BuildOutput {
    map: PathBuf,
    dataset: String,
    /// The frames mapped (split description).
    frames: String,
    keyframes: usize,
    /// `depth` or `triangulation`.
    lifting: &'static str,
    points: usize,
    bytes: u64,
    seconds: f64,
}

/// Runs `indoorloc map`.
pub fn run(args: &MapConfig, sink: &mut dyn crate::Output) -> Result<()> {
    match &args.action {
        Action::Build(b) => build(b, sink),
    }
}

fn build(args: &MapBuildConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let t = Instant::now();
    if !(args.spacing >= 0.0 && args.spacing_deg >= 0.0) || args.features == 0 {
        bail!("--spacing and --spacing-deg must be ≥ 0 and --features ≥ 1");
    }
    let ds = posed::open(&args.data)?;
    let camera = ds.require_camera()?;
    let plan = args.blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
    let (images, frames): (Vec<_>, String) = if args.all {
        (ds.images.iter().collect(), "all frames".into())
    } else {
        (
            ds.mapped(plan),
            format!("training and validation part: {}", ds.describe_split(plan)),
        )
    };
    if images.is_empty() {
        bail!("{}: no frames to map ({frames})", args.data.display());
    }
    let mut cfg = BuildConfig {
        spacing_m: args.spacing,
        spacing_deg: args.spacing_deg,
        ..BuildConfig::default()
    };
    cfg.extract.max_features = args.features;
    let lifting = match args.lift {
        LiftArg::Auto => Lifting::for_images(&images, &ds, &camera),
        LiftArg::Depth => Lifting::depth_of(&ds, &camera),
        LiftArg::Triangulation => Lifting::Triangulation(TriangulationConfig::default()),
    };
    let keyframes = map::keyframes::select_keyframes(&images, &cfg).len();
    let passes = match lifting {
        Lifting::Depth(_) => 1,
        Lifting::Triangulation(_) => 2,
    };
    let pb = progress::bar(passes * keyframes as u64, "keyframes");
    if args.json {
        pb.hide();
    }
    let km = map::keyframes::build(&images, &camera, &lifting, &cfg, &|| pb.inc(1))?;
    pb.finish_and_clear();
    map::file::save(&km, &args.out)?;
    let out = BuildOutput {
        map: args.out.clone(),
        dataset: ds.name(),
        frames,
        keyframes: km.len(),
        lifting: lifting.name(),
        points: km.points(),
        bytes: std::fs::metadata(&args.out)?.len(),
        seconds: t.elapsed().as_secs_f64(),
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "map {}: {} keyframes, {} points ({}), {:.1} MB, {:.1} s ({}, {})\n",
                out.map.display(),
                out.keyframes,
                out.points,
                out.lifting,
                out.bytes as f64 / 1e6,
                out.seconds,
                out.dataset,
                out.frames
            ),
        )
    }
}
