//! `indoorloc study synth-to-real`: a network trained only on renders of a scanned room, tested
//! on real photos of that room — BIM-PoseNet's claim (Acharya et al. 2019: trained on renders
//! of a BIM model, about 1.6 m / 9° on real images) with a scan for the model.
//!
//! 1. The training blocks' RGB-D frames are fused into a textured mesh (`recon`, `DIR/scan.glb`);
//!    the held-out blocks are never fused.
//! 2. For each render type (textured, shaded, gradmag, edges, as in `study render-types`) the
//!    scan is rendered at random poses near the training frames' path (within 0.3 m and 10°,
//!    `synth`'s near sampler) through the dataset's own colour camera, and the real-photo recipe
//!    ([`learn::TrainConfig::for_real_photos`]) trains on those renders alone; its epoch is chosen
//!    on held-out render sequences, never on photos.
//! 3. Each network localizes the real held-out photos (turned into gradient magnitude or Canny
//!    edges for those types, as BIM-PoseNet does), and again with each photo's roll taken from
//!    its straight lines ([`map::lines`]: the networks hardly see roll; the building's
//!    directions are fitted to the renders' lines at their poses). Beside them: the same recipe
//!    trained on the real training photos, and the textured renders-only network refined
//!    against a keyframe map built from renders with their rendered depth, at the training
//!    frames' poses and near them, at half the photos' size — so no real photo is used at all
//!    in that pipeline.
//!
//! Renders live in the scan's levelled frame; poses are mapped back to the dataset's frame
//! through the scan's `dataset_to_world` before they are compared with the ground truth.

use crate::output::{print_json, print_text};
use crate::train::train_with_progress;
use crate::{Context, Result, bail};
use clap::Args;
use data::blocks::BlockSplit;
use data::native::SplitName;
use data::posed::{self, PosedImage, SplitPlan};
use geom::metrics::{PoseEvaluation, position_error, rotation_error_deg};
use geom::{Camera, Pose};
use image::DynamicImage;
use learn::{Estimate, Localizer, TrainConfig};
use map::lines::{LineConfig, LineEdges, ManhattanFrame};
use map::{Coarse, KeyframeMap, RefineConfig};
use rayon::prelude::*;
use recon::{FuseConfig, ScanConfig};
use report::{HtmlReport, Table, Tile};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use synth::dataset::{Sampler, SynthConfig, WorldSource};
use synth::import::ImportOptions;
use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};

/// The render types compared, in table order.
const MODES: [&str; 4] = ["textured", "shaded", "gradmag", "edges"];
/// The render types of `--quick`: the one the map rows use. With all four, a quick run from an
/// empty folder took 9.9 min on two cores (five networks, each localizing the 200 photos with
/// test-time augmentation), past the 8.
const QUICK_MODES: [&str; 1] = ["textured"];
/// Side of the renders the networks train on (the photos' 4:3).
const RENDER_SIZE: (u32, u32) = (320, 240);
/// Largest distance of a rendered camera from a training frame's, metres.
const NEAR_RADIUS_M: f64 = 0.3;
/// Largest rotation of a rendered camera from a training frame's, degrees.
const NEAR_ANGLE_DEG: f64 = 10.0;
/// Sequences of the renders, each near its own run of consecutive training poses (whole
/// sequences are held out for validation and test). With 10 runs the networks trained near 60 %
/// of the path, and whole stretches of it were validation; with 40 short runs the held-out ones
/// are scattered along the path, the networks train near 70 % of it with no long gap, and their
/// validation renders lie between training renders as the test photos do.
const SEQUENCES: usize = 40;
/// Keyframes retrieved for each photo, each matched with its neighbours as a group of its own
/// ([`RefineConfig::grouped`]): thumbnails of renders find the right keyframes of a photo less
/// often than those of photos.
const MAP_GROUPS: usize = 10;
/// Renders of the map near each training frame's pose, besides the one at it: with them every
/// held-out photo refines (200 of 200 on the kitchen, against 175 without; median 0.050 m
/// against 0.055 m; 1 cm scan, scratch measurement over `KeyframeMap::refine`).
const MAP_NEAR: usize = 2;
/// Size of the map's renders against the photos': at half size 175 of the kitchen's 200
/// held-out photos refine against 131 at full size, median 0.055 m / 1.9° against 0.059 m /
/// 2.1° (the queries are reduced to the map's size, [`KeyframeMap::refine`]).
const MAP_SCALE: f64 = 0.5;
/// Test frames shown beside their renders in the report.
const SHOWN: usize = 6;

/// Arguments of `indoorloc study synth-to-real`.
#[derive(Args, Debug)]
pub struct SynthToRealConfig {
    /// A posed RGB-D dataset (7-Scenes, TUM RGB-D, native with depth).
    #[arg(long, value_name = "DATASET")]
    data: PathBuf,
    /// Blocks of consecutive frames, BLOCK:EVERY[:OFFSET], instead of the dataset's own split.
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
    /// Folder for the scan, the renders, the models and `report.html` (the scan and the renders
    /// are made again, the same for the same settings; models trained there before are resumed).
    #[arg(
        long,
        value_name = "DIR",
        default_value = "indoorloc-study-synth-to-real"
    )]
    out: PathBuf,
    /// Fewer renders and epochs, a coarser scan and one render type, textured, unless --modes
    /// names others (minutes).
    #[arg(long)]
    quick: bool,
    /// Render types to train on (default: textured, shaded, gradmag, edges; textured with
    /// --quick).
    #[arg(long, value_delimiter = ',', value_parser = MODES)]
    modes: Vec<String>,
    /// Renders per type, a fifth of them for validation and a fifth unused (default 1500, 400
    /// with --quick; extracting the frozen backbone's features is most of the study's time).
    #[arg(long)]
    renders: Option<usize>,
    /// Voxel of the scan, metres (default 0.01, 0.02 with --quick).
    #[arg(long)]
    voxel: Option<f64>,
    /// The networks' epochs (default 30, 10 with --quick; the real-photo recipe's 150 would
    /// take over an hour for five networks).
    #[arg(long)]
    epochs: Option<usize>,
    /// Monte-Carlo-dropout passes per frame.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// `network`, `network+lines` (the network's pose with its roll from the photo's straight
    /// lines, [`map::lines`]), `network+map` (the network's pose refined against the map of
    /// renders) or `map` (the map of renders alone, from its own retrieval).
    method: &'static str,
    /// `real` (the training photos) or `renders` (renders of the scan alone).
    training: &'static str,
    /// Render type of the training images (`photo` for the real photos).
    render_type: String,
    /// Refined against the keyframe map of the renders.
    refined: bool,
    median_pos_m: f64,
    median_rot_deg: f64,
    mean_pos_m: f64,
    mean_rot_deg: f64,
    /// Share within (0.25 m, 2°).
    acc_25cm_2deg: f64,
    /// Share within (0.5 m, 5°).
    acc_50cm_5deg: f64,
    /// Share within (5 m, 10°).
    acc_5m_10deg: f64,
    /// Training images.
    training_frames: usize,
    /// The network's validation median position error (on its own validation images), metres.
    val_median_pos_m: Option<f64>,
}

/// What the study prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    dataset: String,
    split: String,
    train_frames: usize,
    test_frames: usize,
    scan: PathBuf,
    scan_triangles: usize,
    scan_voxel_m: f64,
    network: String,
    rows: Vec<Row>,
    report: PathBuf,
    /// Seconds scanning, rendering (every type and the map's renders), training (every
    /// network, features included), building the map and refining, and in all.
    scan_s: f64,
    render_s: f64,
    train_s: f64,
    map_s: f64,
    total_s: f64,
}

/// One method's poses for the test frames (dataset frame).
struct Method {
    method: &'static str,
    training: &'static str,
    render_type: String,
    refined: bool,
    poses: Vec<Pose>,
    training_frames: usize,
    val_median_pos_m: Option<f64>,
}

/// Runs `indoorloc study synth-to-real`.
pub fn run(args: &SynthToRealConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let modes: Vec<&str> = if args.modes.is_empty() {
        if args.quick {
            QUICK_MODES.to_vec()
        } else {
            MODES.to_vec()
        }
    } else {
        args.modes.iter().map(String::as_str).collect()
    };
    let renders = args.renders.unwrap_or(if args.quick { 400 } else { 1500 });
    let voxel = args.voxel.unwrap_or(if args.quick { 0.02 } else { 0.01 });
    let start = Instant::now();
    let (mut render_s, mut train_s) = (0.0, 0.0);
    let ds = posed::open(&args.data)?;
    let plan = args.blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
    let parts = ds.parts(plan);
    let mapped = ds.mapped(plan);
    let test: Vec<&PosedImage> = ds
        .images
        .iter()
        .zip(&parts)
        .filter(|(_, p)| **p == Some(SplitName::Test))
        .map(|(i, _)| i)
        .collect();
    if mapped.is_empty() || test.is_empty() {
        bail!(
            "{}: the split leaves {} training and {} test frames ({})",
            args.data.display(),
            mapped.len(),
            test.len(),
            ds.describe_split(plan)
        );
    }
    let camera = ds.require_camera()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let truth: Vec<Pose> = test.iter().map(|i| i.frame.pose).collect();

    say(&format!(
        "1/5 scanning the {} training frames at {} cm voxels (the held-out blocks are not fused)",
        mapped.len(),
        100.0 * voxel
    ));
    let glb = args.out.join("scan.glb");
    let scan_cfg = ScanConfig {
        fuse: FuseConfig {
            voxel_m: voxel,
            ..FuseConfig::default()
        },
        ..ScanConfig::default()
    };
    let pb = crate::progress::bar(mapped.len() as u64, "frames fused");
    if args.json {
        pb.hide();
    }
    let t = Instant::now();
    let scan = recon::scan(&ds, &mapped, &scan_cfg, &|| pb.inc(1))?;
    pb.finish_and_clear();
    for w in &scan.report.warnings {
        say(&format!("    warning: {w}"));
    }
    scan.write(&glb, &args.data.display().to_string())?;
    let scan_s = t.elapsed().as_secs_f64();
    let to_world = scan.dataset_to_world;
    let from_world = to_world.inverse();
    let path: Vec<Pose> = mapped
        .iter()
        .map(|i| to_world.compose(&i.frame.pose))
        .collect();

    say("2/5 decoding the real held-out photos");
    let photos: Vec<DynamicImage> = test
        .par_iter()
        .map(|i| data::frames::decode_image(&i.image))
        .collect::<std::result::Result<_, _>>()?;

    let mut lines = PhotoLines::detect(&photos, &camera);

    let epochs = |cfg: &mut TrainConfig| {
        cfg.epochs = args.epochs.unwrap_or(if args.quick { 10 } else { 30 });
        cfg.resume = true;
    };
    let mut methods = Vec::new();
    let mut network = String::new();
    let mut textured: Option<(Vec<Estimate>, PathBuf)> = None;
    for (k, mode) in modes.iter().enumerate() {
        say(&format!(
            "3/5 [{}/{}] {renders} {mode} renders near the training path; the network on them",
            k + 1,
            modes.len()
        ));
        let render_mode: RenderMode = mode.parse().map_err(crate::LabError::msg)?;
        let data_dir = args.out.join(mode).join("renders");
        let synth_cfg = SynthConfig {
            world: WorldSource::File {
                path: glb.clone(),
                options: ImportOptions::default(),
            },
            sampler: Sampler::Near {
                poses: path.clone(),
                radius_m: NEAR_RADIUS_M,
                angle_deg: NEAR_ANGLE_DEG,
            },
            frames: renders,
            sequences: SEQUENCES,
            width: RENDER_SIZE.0,
            height: RENDER_SIZE.1,
            mode: render_mode,
            intrinsics: Some(camera),
            planes: false,
            depth: false,
            force: true,
            ..SynthConfig::default()
        };
        let t = Instant::now();
        render(&synth_cfg, &data_dir, args.json)?;
        render_s += t.elapsed().as_secs_f64();
        let model = args.out.join(mode).join("model");
        let mut cfg = TrainConfig::for_real_photos(&data_dir, &model);
        epochs(&mut cfg);
        let t = Instant::now();
        let summary = train_with_progress(&cfg, !args.json)?;
        train_s += t.elapsed().as_secs_f64();
        network = format!("{} ({} epochs)", cfg.arch, cfg.epochs);
        let loc = Localizer::load(&model)?;
        let estimates = predict(&loc, &photos, Some(render_mode), args.mc)?;
        if lines.frame.is_none() {
            lines.frame = Some(fit_frame(&data_dir, &lines.cfg)?);
        }
        let world: Vec<Pose> = estimates.iter().map(|e| e.pose).collect();
        methods.extend(lines.network_methods(
            &world,
            &from_world,
            Method {
                method: "network",
                training: "renders",
                render_type: (*mode).into(),
                refined: false,
                poses: Vec::new(),
                training_frames: renders,
                val_median_pos_m: Some(summary.val_median_pos_m),
            },
        ));
        if *mode == "textured" {
            textured = Some((estimates, model));
        }
    }

    say("4/5 the same recipe on the real training photos");
    let real_model = args.out.join("real").join("model");
    let mut cfg = TrainConfig::for_real_photos(&args.data, &real_model);
    cfg.blocks = args.blocks;
    epochs(&mut cfg);
    let t = Instant::now();
    let summary = train_with_progress(&cfg, !args.json)?;
    train_s += t.elapsed().as_secs_f64();
    let loc = Localizer::load(&real_model)?;
    let real = predict(&loc, &photos, None, args.mc)?;
    let world: Vec<Pose> = real.iter().map(|e| to_world.compose(&e.pose)).collect();
    methods.extend(lines.network_methods(
        &world,
        &from_world,
        Method {
            method: "network",
            training: "real",
            render_type: "photo".into(),
            refined: false,
            poses: Vec::new(),
            training_frames: mapped.len(),
            val_median_pos_m: Some(summary.val_median_pos_m),
        },
    ));

    let t = Instant::now();
    let mut map_render_s = 0.0;
    if let Some((estimates, _)) = &textured {
        say("5/5 a keyframe map of renders (rendered depth) refining the renders-only network");
        let (km, seconds) = render_map(args, &glb, &path, &camera)?;
        map_render_s = seconds;
        render_s += seconds;
        let cfg = RefineConfig::grouped(MAP_GROUPS);
        for (method, with_network) in [("map", false), ("network+map", true)] {
            let poses = photos
                .iter()
                .zip(estimates)
                .map(|(img, e)| {
                    let coarse = with_network.then_some(Coarse {
                        pose: e.pose,
                        sigma_pos_m: e.sigma_pos_m,
                    });
                    let refined = km.refine(img, coarse.as_ref(), &cfg)?;
                    Ok(from_world.compose(&refined.pose))
                })
                .collect::<Result<Vec<_>>>()?;
            methods.push(Method {
                method,
                training: "renders",
                render_type: "textured".into(),
                refined: true,
                poses,
                training_frames: if with_network { renders } else { path.len() },
                val_median_pos_m: None,
            });
        }
    }

    let map_s = t.elapsed().as_secs_f64() - map_render_s;
    let rows = methods
        .iter()
        .map(|m| row(m, &truth))
        .collect::<Result<Vec<_>>>()?;
    let mut out = StudyOutput {
        dataset: ds.name(),
        split: ds.describe_split(plan),
        train_frames: mapped.len(),
        test_frames: test.len(),
        scan: glb.clone(),
        scan_triangles: scan.textured.triangle_count(),
        scan_voxel_m: voxel,
        network,
        rows,
        report: args.out.join("report.html"),
        scan_s,
        render_s,
        train_s,
        map_s,
        total_s: 0.0,
    };
    let shown = textured.as_ref().map(|(e, _)| {
        e.iter()
            .map(|x| from_world.compose(&x.pose))
            .collect::<Vec<_>>()
    });
    write_report(
        &out,
        &Evidence {
            glb: &glb,
            to_world: &to_world,
            camera: &camera,
            photos: &photos,
            names: &test
                .iter()
                .map(|i| i.frame.name.clone())
                .collect::<Vec<_>>(),
            truth: &truth,
            estimates: shown.as_deref(),
        },
    )?;
    out.total_s = start.elapsed().as_secs_f64();
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{}: scan of {} training frames ({} triangles, {} cm voxels), {} real test \
                 frames ({}); network {}\nreport: {}\n",
                table(&out.rows).to_text(),
                out.dataset,
                out.train_frames,
                out.scan_triangles,
                100.0 * out.scan_voxel_m,
                out.test_frames,
                out.split,
                out.network,
                out.report.display()
            ),
        )
    }
}

/// Renders `cfg` into `dir` with a progress bar.
fn render(cfg: &SynthConfig, dir: &Path, quiet: bool) -> Result<()> {
    let pb = crate::progress::bar(cfg.frames as u64, "renders");
    if quiet {
        pb.hide();
    }
    synth::dataset::run(cfg, dir, &|done| pb.set_position(done as u64))?;
    pb.finish_and_clear();
    Ok(())
}

/// The network's estimates for the photos, turned into `mode`'s kind of image first.
fn predict(
    loc: &Localizer,
    photos: &[DynamicImage],
    mode: Option<RenderMode>,
    mc: usize,
) -> Result<Vec<Estimate>> {
    let views = photos
        .par_iter()
        .map(|img| -> Result<imgproc::view::View> {
            let img = match mode {
                Some(m) => crate::demo::scene::photo_as(img.clone(), m)?,
                None => img.clone(),
            };
            Ok(loc.view(&img)?)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(loc.predict_batch(&views, mc)?)
}

/// Renders whose lines the building's Manhattan frame is fitted to ([`ManhattanFrame::fit`]):
/// enough to find its two wall directions, in a few seconds.
const FRAME_RENDERS: usize = 100;

/// The building's three directions, fitted to the lines of up to [`FRAME_RENDERS`] renders in
/// `dir` (spread over them) at their known poses, about the scan's up (z): no photo is used.
fn fit_frame(dir: &Path, cfg: &LineConfig) -> Result<ManhattanFrame> {
    let rendered = posed::open(dir)?;
    let camera = rendered.require_camera()?;
    let step = rendered.images.len().div_ceil(FRAME_RENDERS).max(1);
    let views = rendered
        .images
        .par_iter()
        .step_by(step)
        .map(|i| {
            let img = data::frames::decode_image(&i.image)?;
            Ok((LineEdges::detect(&img, &camera, cfg), i.frame.pose.rotation))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(ManhattanFrame::fit(nalgebra::Vector3::z(), &views))
}

/// The test photos' straight edges and the building's frame they are aligned to (fitted once,
/// from the first render type's renders).
struct PhotoLines {
    cfg: LineConfig,
    edges: Vec<LineEdges>,
    frame: Option<ManhattanFrame>,
}

impl PhotoLines {
    fn detect(photos: &[DynamicImage], camera: &Camera) -> PhotoLines {
        let cfg = LineConfig::default();
        let edges = photos
            .par_iter()
            .map(|img| LineEdges::detect(img, camera, &cfg))
            .collect();
        PhotoLines {
            cfg,
            edges,
            frame: None,
        }
    }

    /// The poses (world frame) with their roll taken from each photo's lines where it has
    /// enough of them ([`ManhattanFrame::align_roll`]); the others as they were.
    fn apply(&self, poses: &[Pose]) -> Vec<Pose> {
        poses
            .par_iter()
            .zip(&self.edges)
            .map(|(pose, edges)| {
                let fix = self
                    .frame
                    .and_then(|f| f.align_roll(edges, &pose.rotation, &self.cfg));
                fix.map_or(*pose, |fix| Pose::new(fix.rotation, pose.translation))
            })
            .collect()
    }

    /// A network's two rows from its poses (world frame), mapped to the dataset's frame:
    /// `network` as they are and `network+lines` with the roll from the lines; `row` gives
    /// the rest of each row.
    fn network_methods(&self, world: &[Pose], from_world: &Pose, row: Method) -> [Method; 2] {
        let to_dataset = |poses: &[Pose]| poses.iter().map(|p| from_world.compose(p)).collect();
        let lined = Method {
            method: "network+lines",
            render_type: row.render_type.clone(),
            poses: to_dataset(&self.apply(world)),
            ..row
        };
        let plain = Method {
            poses: to_dataset(world),
            ..row
        };
        [plain, lined]
    }
}

/// The keyframe map of textured renders with their rendered depth: at the training frames' own
/// poses, and [`MAP_NEAR`] more near each of them (within [`NEAR_RADIUS_M`] and
/// [`NEAR_ANGLE_DEG`], as the networks' renders), where a held-out photo off the training path
/// finds a keyframe that saw its view; all at [`MAP_SCALE`] of the photos' size, the size whose
/// corners pair best with the photos' (the scan's texture is coarser than a photo's pixel).
fn render_map(
    args: &SynthToRealConfig,
    glb: &Path,
    path: &[Pose],
    camera: &Camera,
) -> Result<(KeyframeMap, f64)> {
    let small = camera.resized(
        (f64::from(camera.width) * MAP_SCALE).round() as u32,
        (f64::from(camera.height) * MAP_SCALE).round() as u32,
    );
    let mut km: Option<KeyframeMap> = None;
    let mut render_s = 0.0;
    for (name, radius_m, angle_deg, frames) in [
        ("map-renders", 0.0, 0.0, path.len()),
        (
            "map-renders-near",
            NEAR_RADIUS_M,
            NEAR_ANGLE_DEG,
            MAP_NEAR * path.len(),
        ),
    ] {
        let dir = args.out.join(name);
        let cfg = SynthConfig {
            world: WorldSource::File {
                path: glb.to_path_buf(),
                options: ImportOptions::default(),
            },
            sampler: Sampler::Near {
                poses: path.to_vec(),
                radius_m,
                angle_deg,
            },
            frames,
            sequences: 1,
            width: small.width,
            height: small.height,
            mode: RenderMode::Textured,
            intrinsics: Some(small),
            planes: false,
            depth: true,
            force: true,
            ..SynthConfig::default()
        };
        let t = Instant::now();
        render(&cfg, &dir, args.json)?;
        render_s += t.elapsed().as_secs_f64();
        let rendered = posed::open(&dir)?;
        let images: Vec<&PosedImage> = rendered.images.iter().collect();
        let Some((part, _)) = super::real::keyframe_map(&rendered, &images, !args.json)? else {
            bail!("{}: the renders of the map have no depth", dir.display());
        };
        match km.as_mut() {
            Some(km) => km.extend(part)?,
            None => km = Some(part),
        }
    }
    let km = km.context("the map has no renders")?;
    Ok((km, render_s))
}

fn row(m: &Method, truth: &[Pose]) -> Result<Row> {
    let ev = PoseEvaluation::of(truth, &m.poses)?;
    let (p, r) = (&ev.position, &ev.rotation_deg);
    Ok(Row {
        method: m.method,
        training: m.training,
        render_type: m.render_type.clone(),
        refined: m.refined,
        median_pos_m: p.median,
        median_rot_deg: r.median,
        mean_pos_m: p.mean,
        mean_rot_deg: r.mean,
        acc_25cm_2deg: ev.accuracy_at(0.25, 2.0),
        acc_50cm_5deg: ev.accuracy_at(0.5, 5.0),
        acc_5m_10deg: ev.accuracy_at(5.0, 10.0),
        training_frames: m.training_frames,
        val_median_pos_m: m.val_median_pos_m,
    })
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Trained on renders of a scan, tested on real photos",
        [
            "method",
            "training",
            "render type",
            "median (m)",
            "median (°)",
            "mean (m)",
            "≤ 0.25 m, 2°",
            "≤ 0.5 m, 5°",
            "≤ 5 m, 10°",
            "images",
        ],
    );
    let pct = |f: f64| format!("{:.1} %", 100.0 * f);
    for r in rows {
        t.push_row([
            r.method.to_string(),
            r.training.to_string(),
            r.render_type.clone(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.2}", r.median_rot_deg),
            format!("{:.3}", r.mean_pos_m),
            pct(r.acc_25cm_2deg),
            pct(r.acc_50cm_5deg),
            pct(r.acc_5m_10deg),
            r.training_frames.to_string(),
        ]);
    }
    t
}

/// What the report draws besides the table.
struct Evidence<'a> {
    glb: &'a Path,
    to_world: &'a Pose,
    camera: &'a Camera,
    photos: &'a [DynamicImage],
    names: &'a [String],
    truth: &'a [Pose],
    /// The textured renders-only network's poses (dataset frame), when it ran.
    estimates: Option<&'a [Pose]>,
}

fn write_report(out: &StudyOutput, ev: &Evidence<'_>) -> Result<()> {
    let mut page = HtmlReport::new(format!(
        "Renders of a scan, tested on photos: {}",
        out.dataset
    ));
    page.paragraph(format!(
        "The {} training frames were fused into a mesh ({} triangles at {} cm voxels); the \
         networks of the 'renders' rows never saw a real photo: they trained on renders of that \
         mesh near the training frames' path and chose their epoch on held-out renders. They are \
         tested on the {} real held-out frames ({}). The 'real' row is the same recipe trained \
         on the real training photos; the 'network+lines' rows keep each network's position, \
         pan and tilt and take the photo's roll from its straight lines (the vanishing points \
         of the building's three directions, fitted to the renders' lines); the refined rows \
         match each photo against a keyframe map built from renders and their rendered depth.",
        out.train_frames,
        out.scan_triangles,
        100.0 * out.scan_voxel_m,
        out.test_frames,
        out.split
    ));
    page.table(&table(&out.rows));
    if let Some(estimates) = ev.estimates {
        page.png(
            &render_sheet(ev, estimates)?,
            "Real held-out photos (left), the scan rendered at their true pose (middle) and at \
             the textured renders-only network's estimate (right).",
        );
    }
    page.write(&out.report)?;
    Ok(())
}

/// [`SHOWN`] evenly spaced test photos beside renders from their true and estimated poses.
fn render_sheet(ev: &Evidence<'_>, estimates: &[Pose]) -> Result<Vec<u8>> {
    let (world, _) = synth::import::load(ev.glb, &ImportOptions::default())?;
    let scene = RenderScene::new(&world)?;
    let camera = ev.camera.resized(RENDER_SIZE.0, RENDER_SIZE.1);
    let mut renderer = Renderer::new();
    let opts = RenderOptions::default();
    let mut tiles = Vec::new();
    let n = ev.photos.len();
    for s in 0..SHOWN.min(n) {
        let i = s * n / SHOWN.min(n);
        let photo = ev.photos[i]
            .resize_exact(
                RENDER_SIZE.0,
                RENDER_SIZE.1,
                image::imageops::FilterType::Triangle,
            )
            .to_rgb8();
        tiles.push(Tile {
            label: ev.names[i].clone(),
            image: photo,
        });
        for (label, pose) in [("true pose", ev.truth[i]), ("estimate", estimates[i])] {
            let world_pose = ev.to_world.compose(&pose);
            let img = renderer
                .render(&scene, &camera, &world_pose, &opts, &[])?
                .rgb
                .clone();
            let label = if label == "estimate" {
                format!(
                    "estimate: {:.2} m, {:.1}°",
                    position_error(&ev.truth[i], &pose),
                    rotation_error_deg(&ev.truth[i], &pose)
                )
            } else {
                label.to_string()
            };
            tiles.push(Tile { label, image: img });
        }
    }
    Ok(report::contact_sheet("Photos and renders", &tiles, 3)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dataset_without_depth_is_refused_before_anything_is_trained() -> Result<()> {
        let data = tempfile::tempdir()?;
        let cfg = SynthConfig {
            frames: 40,
            sequences: 1,
            width: 64,
            height: 48,
            depth: false,
            planes: false,
            ..SynthConfig::default()
        };
        synth::dataset::run(&cfg, data.path(), &|_| {})?;
        let out = tempfile::tempdir()?;
        let args = SynthToRealConfig {
            data: data.path().to_path_buf(),
            blocks: Some("10:4".parse().map_err(crate::LabError::msg)?),
            out: out.path().to_path_buf(),
            quick: true,
            modes: Vec::new(),
            renders: None,
            voxel: None,
            epochs: None,
            mc: 0,
            json: true,
        };
        let err = run(&args, &mut crate::output::Collected::default())
            .err()
            .ok_or_else(|| crate::LabError::msg("a scan without depth was accepted"))?;
        let msg = crate::error::chain(&err);
        assert!(msg.contains("no depth image"), "{msg}");
        assert!(!out.path().join("textured").exists());
        Ok(())
    }
}
