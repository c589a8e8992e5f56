//! `indoorloc synth`: render a native dataset from the default building or a model file, or a
//! contact sheet of every render mode and appearance variant (`--preview`). A scan (a GLB fused
//! from a posed RGB-D dataset) is rendered near its own camera path with `--near DATASET`.

use crate::output::{print_json, print_text};
use crate::progress::bar;
use crate::{Context, Result, bail, ensure};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::path::{Path, PathBuf};
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
    /// How poses are drawn: natural walks, walks joined by scene cuts, or random poses (walks
    /// need the model's walk graph; a scan without a walkable floor has none).
    #[arg(long, value_enum, default_value_t = Sample::Walk)]
    sampler: Sample,
    /// Draw poses near the camera path of this posed dataset instead (any layout `train` reads:
    /// 7-Scenes, TUM, native, ...): each frame takes one of its poses at random, moved by up to
    /// --near-radius and turned by up to --near-angle; sequences are runs of consecutive poses.
    /// The poses are placed in the model by the transform a scan's GLB records
    /// (asset.extras.indoorloc_scan.dataset_to_world; a model without it is refused), and the
    /// dataset's camera, scaled to --size, replaces the random intrinsics.
    #[arg(long, value_name = "DATASET", conflicts_with = "sampler")]
    near: Option<PathBuf>,
    /// With --near: largest distance of a drawn camera from the dataset's, metres.
    #[arg(long, value_name = "M", default_value_t = 0.3)]
    near_radius: f64,
    /// With --near: largest rotation of a drawn camera from the dataset's, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 10.0)]
    near_angle: f64,
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
    let (sampler, intrinsics) = match &args.near {
        Some(dataset) => {
            let (sampler, camera) = near(args, dataset)?;
            (sampler, Some(camera))
        }
        None => (
            match args.sampler {
                Sample::Walk => Sampler::Walk,
                Sample::Cuts => Sampler::WalkWithCuts,
                Sample::Random => Sampler::Random,
            },
            None,
        ),
    };
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
        sampler,
        frames: args.frames,
        sequences: args.sequences,
        fps: args.fps,
        width: args.size.0,
        height: args.size.1,
        mode: args.mode,
        variant: args.variant,
        seed: args.seed,
        walk_seed: None,
        intrinsics,
        depth: !args.no_depth,
        planes: !args.no_planes,
        resume: args.resume,
        force: args.force,
    })
}

/// The `--near` sampler and camera: the dataset's poses placed in the model by the transform
/// its GLB records, and the dataset's camera. The transform holds for the model as it is
/// written (metres, Y up), so other --scale or --up are refused.
fn near(args: &SynthCommand, dataset: &Path) -> Result<(Sampler, geom::Camera)> {
    ensure!(
        args.world != "default",
        "--near places a dataset's camera path in a scan: give the scan's model with --world"
    );
    let model = Path::new(&args.world);
    ensure!(
        args.scale == 1.0 && matches!(args.up, Up::Y),
        "{}: --near places the dataset's poses by the transform the model records, which \
         holds for the model as written; leave --scale and --up at their defaults",
        model.display()
    );
    let Some(to_world) = synth::import::scan_frame(model)? else {
        bail!(
            "{}: the model records no asset.extras.indoorloc_scan.dataset_to_world, so the \
             poses of --near {} cannot be placed in it (a scan's GLB records it)",
            model.display(),
            dataset.display()
        );
    };
    let ds = data::posed::open(dataset)
        .with_context(|| format!("reading the --near dataset {}", dataset.display()))?;
    let camera = ds.require_camera()?;
    let poses = ds
        .images
        .iter()
        .map(|i| to_world.compose(&i.frame.pose))
        .collect();
    let sampler = Sampler::Near {
        poses,
        radius_m: args.near_radius,
        angle_deg: args.near_angle,
    };
    Ok((sampler, camera))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use data::{PoseFrame, Trajectory};
    use geom::Pose;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        synth: SynthCommand,
    }

    fn args(extra: &[&str]) -> std::result::Result<SynthCommand, clap::Error> {
        let mut argv = vec!["synth", "--out", "o"];
        argv.extend_from_slice(extra);
        Ok(Wrap::try_parse_from(argv)?.synth)
    }

    /// `--near`: the dataset's poses placed in the model by the transform it records, its
    /// camera as the intrinsics; refused without a model, without the record, with another
    /// scale, and beside `--sampler`.
    #[test]
    fn near_places_the_dataset_path_by_the_model_record()
    -> std::result::Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let seq = dir.path().join("kitchen");
        let frames = (0..3)
            .map(|i| {
                let pose =
                    Pose::from_euler_ypr(0.1 * f64::from(i), 0.0, 0.0, [f64::from(i), 0.0, 1.0])?;
                Ok(PoseFrame {
                    name: format!("frame-{i:06}"),
                    seq: "seq-01".into(),
                    t: None,
                    pose,
                })
            })
            .collect::<geom::Result<Vec<_>>>()?;
        data::sevenscenes::write(&Trajectory::new(frames.clone()), &seq)?;
        for f in &frames {
            let png = seq.join("seq-01").join(format!("{}.color.png", f.name));
            image::RgbImage::new(8, 6).save(png)?;
        }
        // Only the model's JSON is read for the record.
        let to_world = Pose::from_euler_ypr(0.5, 0.0, 0.0, [1.0, 2.0, 3.0])?;
        let m = to_world.to_matrix4();
        let numbers: Vec<String> = (0..16)
            .map(|i| format!("{:?}", m[(i / 4, i % 4)]))
            .collect();
        let model = dir.path().join("scan.gltf");
        std::fs::write(
            &model,
            format!(
                r#"{{"asset": {{"version": "2.0", "extras": {{"indoorloc_scan":
                    {{"dataset_to_world": [{}]}}}}}}}}"#,
                numbers.join(", ")
            ),
        )?;
        let (model_arg, seq_arg) = (model.to_string_lossy(), seq.to_string_lossy());
        let near = ["--world", &model_arg, "--near", &seq_arg];
        let cfg = config(&args(&[&near[..], &["--near-radius", "0.2"]].concat())?)?;
        let Sampler::Near {
            poses,
            radius_m,
            angle_deg,
        } = &cfg.sampler
        else {
            return Err("not the near sampler".into());
        };
        assert_eq!((*radius_m, *angle_deg), (0.2, 10.0));
        assert_eq!(poses.len(), 3);
        for (p, f) in poses.iter().zip(&frames) {
            let want = to_world.compose(&f.pose);
            assert!((p.translation - want.translation).norm() < 1e-9);
            assert!(p.rotation.angle_to(&want.rotation) < 1e-9);
        }
        assert_eq!(cfg.intrinsics, Some(data::sevenscenes::rgb_camera()));

        let err = |extra: &[&str]| -> std::result::Result<String, Box<dyn std::error::Error>> {
            Ok(config(&args(extra)?).err().ok_or("accepted")?.to_string())
        };
        assert!(err(&["--near", &seq_arg])?.contains("--world"));
        assert!(err(&[&near[..], &["--scale", "0.01"]].concat())?.contains("--scale"));
        let bare = dir.path().join("bare.gltf");
        std::fs::write(&bare, r#"{"asset": {"version": "2.0"}}"#)?;
        let msg = err(&["--world", &bare.to_string_lossy(), "--near", &seq_arg])?;
        assert!(
            msg.contains("bare.gltf") && msg.contains("dataset_to_world"),
            "{msg}"
        );
        assert!(args(&[&near[..], &["--sampler", "random"]].concat()).is_err());
        Ok(())
    }
}
