//! `indoorloc synth`: render a native dataset from the default building or a model file, or a
//! contact sheet of every render mode and appearance variant (`--preview`).

use crate::output::{print_json, print_text};
use crate::progress::bar;
use crate::{Context, Result, bail};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::path::PathBuf;
use synth::dataset::{self, CameraKind, Sampler, SynthConfig, WorldSource};
use synth::import::{ImportOptions, UpAxis};
use synth::render::RenderMode;
use synth::world::Variant;

/// Arguments of `indoorloc synth`.
#[derive(Args, Debug)]
pub struct SynthCommand {
    /// Output dataset folder (native layout: dataset.toml, poses.csv, frames/, ...).
    #[arg(long, required_unless_present = "preview")]
    out: Option<PathBuf>,
    /// `default` for the built-in procedural building, or an OBJ / glTF / GLB model file.
    #[arg(long, default_value = "default")]
    world: String,
    /// Model units: multiply coordinates by this (0.001 for a model in millimetres).
    #[arg(long, default_value_t = 1.0)]
    scale: f32,
    /// Up axis of a model file.
    #[arg(long, value_enum, default_value_t = Up::Y)]
    up: Up,
    /// Camera: hand-held looking ahead (6-DoF), or a robot's camera looking up (3-DoF).
    #[arg(long, value_enum, default_value_t = Cam::Forward)]
    camera: Cam,
    /// How poses are drawn: natural walks, walks joined by scene cuts, or random poses.
    #[arg(long, value_enum, default_value_t = Sample::Walk)]
    sampler: Sample,
    /// Total frames.
    #[arg(long, default_value_t = 600)]
    frames: usize,
    /// Sequences the frames are split into (splits are made of whole sequences).
    #[arg(long, default_value_t = 6)]
    sequences: usize,
    /// Frames per second of walks (default: the rig's, 10 for a person, 5 for a robot); a lower
    /// rate spreads the frames over more ground.
    #[arg(long)]
    fps: Option<f64>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240", value_parser = crate::parse::size)]
    size: (u32, u32),
    /// Render mode: shaded, textured, edges, gradmag.
    #[arg(long, default_value = "textured")]
    mode: RenderMode,
    /// Appearance variant: normal, some-lights-off, dim, daylight, people, furniture-moved,
    /// posters-changed, disaster, texture-swap.
    #[arg(long, default_value = "normal")]
    variant: Variant,
    /// Seed of the building layout, trajectories, variants and sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seed of the built-in building's layout alone (default: --seed): other walks through the
    /// same building.
    #[arg(long)]
    world_seed: Option<u64>,
    /// Skip depth images.
    #[arg(long)]
    no_depth: bool,
    /// Skip dominant-plane images.
    #[arg(long)]
    no_planes: bool,
    /// Finish an interrupted run into --out (the same settings; frames whose every image is on
    /// disk are kept).
    #[arg(long, conflicts_with = "force")]
    resume: bool,
    /// Replace the dataset --out holds (without --resume or --force, a folder holding one is
    /// refused).
    #[arg(long)]
    force: bool,
    /// Also write another layout beside the native one (`7scenes` → OUT/7scenes).
    #[arg(long, value_name = "FORMAT")]
    export: Option<String>,
    /// Write a contact sheet PNG of every mode and variant at one pose (and render nothing else
    /// unless --out is given).
    #[arg(long, value_name = "PNG")]
    preview: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Up {
    Y,
    Z,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Cam {
    Forward,
    Ceiling,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Sample {
    Walk,
    Cuts,
    Random,
}

/// The `--json` document.
#[derive(Debug, Serialize)]
struct SynthOutput {
    frames: usize,
    rendered: usize,
    fps: f64,
    seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    out: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    preview: Option<PathBuf>,
    warnings: Vec<String>,
}

/// Runs `indoorloc synth`.
pub fn run(args: &SynthCommand, sink: &mut dyn crate::Output) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting the thread count")?;
    }
    let cfg = config(args)?;
    let start = std::time::Instant::now();
    let mut output = SynthOutput {
        frames: 0,
        rendered: 0,
        fps: 0.0,
        seconds: 0.0,
        out: args.out.clone(),
        preview: None,
        warnings: Vec::new(),
    };
    if let Some(path) = &args.preview {
        let preview = synth::preview::render(&cfg)?;
        let columns = preview.columns();
        let tiles: Vec<report::Tile> = (preview.rows.into_iter().flatten())
            .map(|t| report::Tile {
                label: t.label,
                image: t.image,
            })
            .collect();
        let png = report::contact_sheet(&preview.title, &tiles, columns)?;
        report::write_atomic(path, &png)?;
        output.preview = Some(path.clone());
    }
    if let Some(out) = &args.out {
        let progress = bar(cfg.frames as u64, "rendering");
        let summary = dataset::run(&cfg, out, &|done| progress.set_position(done as u64))
            .with_context(|| format!("writing the dataset into {}", out.display()))?;
        progress.finish_and_clear();
        match args.export.as_deref() {
            None => {}
            Some("7scenes") => dataset::export_7scenes(out, &out.join("7scenes"))?,
            Some(other) => bail!("unknown --export '{other}' (known: 7scenes)"),
        }
        output.frames = summary.frames;
        output.rendered = summary.rendered;
        output.fps = summary.rendered as f64 / summary.render_seconds.max(1e-9);
        output.warnings = summary.warnings;
    }
    output.seconds = start.elapsed().as_secs_f64();
    if args.json {
        print_json(sink, &output)
    } else {
        let mut text = String::new();
        if let Some(out) = &output.out {
            text.push_str(&format!(
                "{} frames ({} rendered) at {:.1} frames/s into {}\n",
                output.frames,
                output.rendered,
                output.fps,
                out.display()
            ));
        }
        if let Some(p) = &output.preview {
            text.push_str(&format!("contact sheet: {}\n", p.display()));
        }
        for w in &output.warnings {
            text.push_str(&format!("warning: {w}\n"));
        }
        print_text(sink, &text)
    }
}

fn config(args: &SynthCommand) -> Result<SynthConfig> {
    let world = if args.world == "default" {
        WorldSource::Default {
            seed: args.world_seed.unwrap_or(args.seed),
        }
    } else {
        WorldSource::File {
            path: PathBuf::from(&args.world),
            options: ImportOptions {
                scale: args.scale,
                up: match args.up {
                    Up::Y => UpAxis::Y,
                    Up::Z => UpAxis::Z,
                },
                ..ImportOptions::default()
            },
        }
    };
    Ok(SynthConfig {
        world,
        camera: match args.camera {
            Cam::Forward => CameraKind::Forward,
            Cam::Ceiling => CameraKind::Ceiling,
        },
        sampler: match args.sampler {
            Sample::Walk => Sampler::Walk,
            Sample::Cuts => Sampler::WalkWithCuts,
            Sample::Random => Sampler::Random,
        },
        frames: args.frames,
        sequences: args.sequences,
        fps: args.fps,
        width: args.size.0,
        height: args.size.1,
        mode: args.mode,
        variant: args.variant,
        seed: args.seed,
        walk_seed: None,
        depth: !args.no_depth,
        planes: !args.no_planes,
        resume: args.resume,
        force: args.force,
    })
}
