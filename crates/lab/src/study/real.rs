//! `indoorloc study real`: a user's own posed photos end to end, each localizer beside the
//! simplest baselines on the same held-out frames.
//!
//! Rows: the mean training pose (what a network that learnt nothing answers), image retrieval
//! (the pose of the most similar mapped frame, `map::retrieval`; and by the pretrained
//! backbone's pooled features when the network has one), the network trained with the
//! real-photo recipe ([`learn::TrainConfig::for_real_photos`]: a frozen ImageNet MobileNetV2
//! when its weights are in the cache, else the small network from scratch), and that network
//! with the CNN+LSTM sequence model over the held-out runs of consecutive frames; and, where
//! every mapped frame has depth, the keyframe map (`map`: local features lifted to 3-D, PnP)
//! alone from its own retrieval and refining the network's poses (the network's sigma gates
//! the refinement). The split is
//! the dataset's own, else blocks (`--blocks`); training chooses its epoch on validation
//! blocks cut from the training part, never on the test frames.

use crate::output::{print_json, print_text};
use crate::train::{train_sequence_with_progress, train_with_progress};
use crate::{Context, Result, bail};
use clap::Args;
use data::blocks::BlockSplit;
use data::native::SplitName;
use data::posed::{self, PosedImage, SplitPlan};
use geom::Pose;
use geom::metrics::{Stats, position_error, rotation_error_deg};
use image::DynamicImage;
use learn::seq::{SeqConfig, SeqLocalizer, SeqMeta};
use learn::{Estimate, Localizer, TrainConfig};
use map::retrieval::{Keyframe, RetrievalIndex};
use map::{BuildConfig, Coarse, KeyframeMap, RefineConfig};
use rayon::prelude::*;
use report::{HtmlReport, Series, Table, Track};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `indoorloc study real`.
#[derive(Args, Debug)]
pub struct RealConfig {
    /// A posed dataset in any layout `data` opens (7-Scenes, TUM RGB-D, COLMAP, Cambridge,
    /// NeRF, native).
    #[arg(long, value_name = "DATASET")]
    data: PathBuf,
    /// Blocks of consecutive frames, BLOCK:EVERY[:OFFSET], instead of the dataset's own split.
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
    /// Folder for the models and `report.html` (models trained before with the same settings
    /// are reused).
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-real")]
    out: PathBuf,
    /// Fewer epochs and a shorter sequence window (minutes).
    #[arg(long)]
    quick: bool,
    /// Override the network's epochs.
    #[arg(long)]
    epochs: Option<usize>,
    /// Frames per training window of the sequence model.
    #[arg(long)]
    window: Option<usize>,
    /// Monte-Carlo-dropout passes per frame for the networks.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// `mean-pose`, `retrieval`, `retrieval-features`, `network`, `network+sequence`, `map` or
    /// `network+map`.
    method: String,
    median_pos_m: f64,
    median_rot_deg: f64,
    mean_pos_m: f64,
    mean_rot_deg: f64,
    /// Share within (5 cm, 5°).
    acc_5cm_5deg: f64,
    /// Share within (0.25 m, 2°).
    acc_25cm_2deg: f64,
    /// Share within (0.5 m, 5°).
    acc_50cm_5deg: f64,
    /// Seconds to build the method (training, mapping), as measured when it was built.
    train_s: f64,
    /// Milliseconds per held-out frame (decoding excluded).
    ms_per_frame: f64,
}

/// What `study real` prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    dataset: String,
    split: String,
    train_frames: usize,
    test_frames: usize,
    /// The network's backbone and view.
    network: String,
    rows: Vec<Row>,
    report: PathBuf,
}

/// The poses one method gives the test frames, and what it cost.
struct Method {
    name: String,
    poses: Vec<Pose>,
    train_s: f64,
    ms_per_frame: f64,
}

/// Runs `indoorloc study real`.
pub fn run(args: &RealConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let ds = posed::open(&args.data)?;
    let plan = args.blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
    let parts = ds.parts(plan);
    let mapped = ds.mapped(plan);
    let test_index: Vec<usize> = (0..ds.images.len())
        .filter(|&i| parts[i] == Some(SplitName::Test))
        .collect();
    if mapped.is_empty() || test_index.is_empty() {
        bail!(
            "{}: the split leaves {} training and {} test frames ({})",
            args.data.display(),
            mapped.len(),
            test_index.len(),
            ds.describe_split(plan)
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let truth: Vec<Pose> = test_index
        .iter()
        .map(|&i| ds.images[i].frame.pose)
        .collect();

    say(&format!(
        "1/6 decoding {} test frames ({})",
        test_index.len(),
        ds.describe_split(plan)
    ));
    let test_images: Vec<DynamicImage> = test_index
        .par_iter()
        .map(|&i| data::frames::decode_image(&ds.images[i].image))
        .collect::<std::result::Result<_, _>>()?;

    say("2/6 baselines: mean training pose, image retrieval");
    let mut methods = vec![mean_pose(&mapped, test_index.len())?];
    let (retrieval, nearest) = retrieval(&mapped, &test_images)?;
    methods.push(retrieval);

    say("3/6 the network (real-photo recipe)");
    let model = args.out.join("model");
    let mut cfg = TrainConfig::for_real_photos(&args.data, &model);
    cfg.blocks = args.blocks;
    if args.quick {
        cfg.epochs = cfg.epochs.div_ceil(3);
    }
    if let Some(epochs) = args.epochs {
        cfg.epochs = epochs;
    }
    cfg.resume = true;
    let summary = train_with_progress(&cfg, !args.json)?;
    let network = format!(
        "{} ({} epochs, best {})",
        cfg.arch, summary.epochs, summary.best_epoch
    );
    let trained_s: f64 = summary.history.iter().map(|e| e.seconds).sum();
    let loc = Localizer::load(&model)?;
    let views = test_images
        .iter()
        .map(|img| loc.view(img))
        .collect::<learn::Result<Vec<_>>>()?;
    if let Some(by_features) = feature_retrieval(&loc, &mapped, &views)? {
        methods.push(by_features);
    }
    let t = Instant::now();
    let single = loc.predict_batch(&views, args.mc)?;
    methods.push(Method {
        name: "network".into(),
        poses: single.iter().map(|e| e.pose).collect(),
        train_s: trained_s,
        ms_per_frame: 1e3 * t.elapsed().as_secs_f64() / views.len() as f64,
    });

    say("4/6 the sequence model (CNN+LSTM) over runs of consecutive frames");
    let window = args.window.unwrap_or(if args.quick { 10 } else { 20 });
    let mut seq_cfg = SeqConfig::new(&args.data, &model);
    seq_cfg.window = window;
    if args.quick {
        seq_cfg.epochs = 4;
    }
    let unreadable = SeqMeta::exists(&model) && SeqMeta::read(&model).is_err();
    seq_cfg.resume = !unreadable;
    seq_cfg.force = unreadable;
    let seq_summary = train_sequence_with_progress(&seq_cfg, !args.json)?;
    let seq = SeqLocalizer::load(&model)?;
    let keys: Vec<(&str, u64)> = test_index
        .iter()
        .map(|&i| (ds.images[i].frame.seq.as_str(), i as u64))
        .collect();
    let cuts: Vec<u64> = ds.cuts.iter().map(|&c| c as u64).collect();
    let runs = learn::window::runs(&keys, &cuts);
    let t = Instant::now();
    let sequence = seq.predict_runs(&views, &runs, args.mc)?;
    methods.push(Method {
        name: "network+sequence".into(),
        poses: sequence.iter().map(|e| e.pose).collect(),
        train_s: trained_s + seq_summary.history.iter().map(|e| e.seconds).sum::<f64>(),
        ms_per_frame: 1e3 * t.elapsed().as_secs_f64() / views.len() as f64,
    });

    say("5/6 the keyframe map (local features + PnP): alone, and refining the network's poses");
    if let Some((km, build_s)) = keyframe_map(&ds, &mapped, !args.json)? {
        methods.push(refined("map", &km, &test_images, None, build_s)?);
        methods.push(refined(
            "network+map",
            &km,
            &test_images,
            Some(&single),
            trained_s + build_s,
        )?);
    } else {
        say("    (no depth for every mapped frame: no map rows)");
    }

    say("6/6 report");
    let rows = methods
        .iter()
        .map(|m| row(m, &truth))
        .collect::<Result<Vec<_>>>()?;
    let report = args.out.join("report.html");
    let out = StudyOutput {
        dataset: ds.name(),
        split: ds.describe_split(plan),
        train_frames: mapped.len(),
        test_frames: truth.len(),
        network,
        rows,
        report,
    };
    let evidence = Evidence {
        truth: &truth,
        methods: &methods,
        single: &single,
        test_images: &test_images,
        test_names: &test_index
            .iter()
            .map(|&i| ds.images[i].frame.name.clone())
            .collect::<Vec<_>>(),
        nearest: &nearest,
        mapped: &mapped,
    };
    write_report(&out, &evidence)?;
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{}: {} training and validation frames, {} test frames ({}); network {}\nreport: {}\n",
                table(&out.rows).to_text(),
                out.dataset,
                out.train_frames,
                out.test_frames,
                out.split,
                out.network,
                out.report.display()
            ),
        )
    }
}

/// The mean position and mean rotation (sign-aligned quaternion average) of the training
/// frames, for every test frame.
fn mean_pose(mapped: &[&PosedImage], tests: usize) -> Result<Method> {
    let t = Instant::now();
    let n = mapped.len() as f64;
    let mut position = [0.0; 3];
    let mut q = [0.0; 4];
    let first = mapped[0].frame.pose.quat_wxyz();
    for img in mapped {
        let p = img.frame.pose.position();
        for (a, b) in position.iter_mut().zip(p) {
            *a += b / n;
        }
        let qi = img.frame.pose.quat_wxyz();
        let sign = if qi.iter().zip(&first).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
            -1.0
        } else {
            1.0
        };
        for (a, b) in q.iter_mut().zip(qi) {
            *a += sign * b;
        }
    }
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let pose = Pose::from_t_wxyz(position, q.map(|v| v / norm))?;
    Ok(Method {
        name: "mean-pose".into(),
        poses: vec![pose; tests],
        train_s: t.elapsed().as_secs_f64(),
        ms_per_frame: 0.0,
    })
}

/// Retrieval from every training and validation frame, and each test frame's nearest one.
fn retrieval(mapped: &[&PosedImage], test_images: &[DynamicImage]) -> Result<(Method, Vec<usize>)> {
    let t = Instant::now();
    let index = RetrievalIndex::of_images(mapped)?;
    let train_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let found = test_images
        .iter()
        .map(|img| index.localize(img))
        .collect::<map::Result<Vec<_>>>()?;
    let ms_per_frame = 1e3 * t.elapsed().as_secs_f64() / test_images.len() as f64;
    Ok((
        Method {
            name: "retrieval".into(),
            poses: found.iter().map(|r| r.pose).collect(),
            train_s,
            ms_per_frame,
        },
        found.iter().map(|r| r.best.index).collect(),
    ))
}

/// Retrieval by the pretrained backbone's pooled features ([`Localizer::descriptors`]) from
/// every training and validation frame; `None` when the network has no pretrained layers.
fn feature_retrieval(
    loc: &Localizer,
    mapped: &[&PosedImage],
    test_views: &[imgproc::view::View],
) -> Result<Option<Method>> {
    let t = Instant::now();
    let mut keys: Vec<Vec<f32>> = Vec::with_capacity(mapped.len());
    for part in mapped.chunks(64) {
        let views = part
            .par_iter()
            .map(|img| -> Result<imgproc::view::View> {
                Ok(loc.view(&data::frames::decode_image(&img.image)?)?)
            })
            .collect::<Result<Vec<_>>>()?;
        match loc.descriptors(&views)? {
            Some(rows) => keys.extend(rows),
            None => return Ok(None),
        }
    }
    let index =
        RetrievalIndex::from_descriptors(mapped.iter().map(|i| Keyframe::of(i)).collect(), keys)?;
    let train_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let queries = loc.descriptors(test_views)?.unwrap_or_default();
    let poses = queries
        .iter()
        .map(|q| {
            let best = index.query(q, 1).first().map_or(0, |h| h.index);
            index.keyframes[best].pose
        })
        .collect();
    Ok(Some(Method {
        name: "retrieval-features".into(),
        poses,
        train_s,
        ms_per_frame: 1e3 * t.elapsed().as_secs_f64() / test_views.len().max(1) as f64,
    }))
}

/// The keyframe map of the mapped frames and its build time, when every one has depth.
pub(super) fn keyframe_map(
    ds: &posed::PosedDataset,
    mapped: &[&PosedImage],
    show: bool,
) -> Result<Option<(KeyframeMap, f64)>> {
    if mapped.iter().any(|i| i.depth.is_none()) {
        return Ok(None);
    }
    let t = Instant::now();
    let camera = ds.require_camera()?;
    let cfg = BuildConfig::default();
    let pb = crate::progress::bar(
        map::keyframes::select_keyframes(mapped, &cfg).len() as u64,
        "keyframes",
    );
    if !show {
        pb.hide();
    }
    let lifting = map::Lifting::depth_of(ds, &camera);
    let km = map::keyframes::build(mapped, &camera, &lifting, &cfg, &|| pb.inc(1))?;
    pb.finish_and_clear();
    Ok(Some((km, t.elapsed().as_secs_f64())))
}

/// The map's refinement of each test frame, from the network's estimate (its pose and sigma)
/// when given, else from the map's own retrieval.
fn refined(
    name: &str,
    km: &KeyframeMap,
    test_images: &[DynamicImage],
    coarse: Option<&[Estimate]>,
    train_s: f64,
) -> Result<Method> {
    let cfg = RefineConfig::default();
    let t = Instant::now();
    // One frame after another, as a live query runs.
    let poses = test_images
        .iter()
        .enumerate()
        .map(|(i, img)| {
            let c = coarse.map(|c| Coarse {
                pose: c[i].pose,
                sigma_pos_m: c[i].sigma_pos_m,
            });
            Ok(km.refine(img, c.as_ref(), &cfg)?.pose)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Method {
        name: name.into(),
        poses,
        train_s,
        ms_per_frame: 1e3 * t.elapsed().as_secs_f64() / test_images.len().max(1) as f64,
    })
}

/// Position and rotation errors of `poses` against `truth`.
fn errors(poses: &[Pose], truth: &[Pose]) -> (Vec<f64>, Vec<f64>) {
    poses
        .iter()
        .zip(truth)
        .map(|(e, gt)| (position_error(gt, e), rotation_error_deg(gt, e)))
        .unzip()
}

fn row(m: &Method, truth: &[Pose]) -> Result<Row> {
    let (pos, rot) = errors(&m.poses, truth);
    let within = |metres: f64, degrees: f64| {
        pos.iter()
            .zip(&rot)
            .filter(|(p, r)| **p <= metres && **r <= degrees)
            .count() as f64
            / pos.len() as f64
    };
    let (p, r) = (Stats::of(&pos)?, Stats::of(&rot)?);
    Ok(Row {
        method: m.name.clone(),
        median_pos_m: p.median,
        median_rot_deg: r.median,
        mean_pos_m: p.mean,
        mean_rot_deg: r.mean,
        acc_5cm_5deg: within(0.05, 5.0),
        acc_25cm_2deg: within(0.25, 2.0),
        acc_50cm_5deg: within(0.5, 5.0),
        train_s: m.train_s,
        ms_per_frame: m.ms_per_frame,
    })
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Real photos: baselines and networks on the held-out frames",
        [
            "method",
            "median (m)",
            "median (°)",
            "mean (m)",
            "mean (°)",
            "≤ 5 cm, 5°",
            "≤ 0.25 m, 2°",
            "≤ 0.5 m, 5°",
            "build (s)",
            "ms / frame",
        ],
    );
    let pct = |f: f64| format!("{:.1} %", 100.0 * f);
    for r in rows {
        t.push_row([
            r.method.clone(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.2}", r.median_rot_deg),
            format!("{:.3}", r.mean_pos_m),
            format!("{:.2}", r.mean_rot_deg),
            pct(r.acc_5cm_5deg),
            pct(r.acc_25cm_2deg),
            pct(r.acc_50cm_5deg),
            format!("{:.1}", r.train_s),
            format!("{:.2}", r.ms_per_frame),
        ]);
    }
    t
}

/// What the report shows besides the table.
struct Evidence<'a> {
    truth: &'a [Pose],
    methods: &'a [Method],
    single: &'a [Estimate],
    test_images: &'a [DynamicImage],
    /// The test frames' names.
    test_names: &'a [String],
    /// Each test frame's most similar mapped frame (index into `mapped`).
    nearest: &'a [usize],
    mapped: &'a [&'a PosedImage],
}

/// Worst frames of the network shown in the report.
const WORST: usize = 6;

/// Width of a frame in the worst-frames sheet, pixels.
const TILE_WIDTH: u32 = 240;

fn write_report(out: &StudyOutput, ev: &Evidence<'_>) -> Result<()> {
    let mut page = HtmlReport::new(format!("Real photos: {}", out.dataset));
    page.paragraph(format!(
        "{} training and validation frames, {} held-out test frames ({}). The network: {}; \
         its epoch was chosen on validation blocks of the training part. Retrieval answers the \
         pose of the most similar training frame (32x24 thumbnails); the mean pose is what a \
         model that learnt nothing would answer.",
        out.train_frames, out.test_frames, out.split, out.network
    ));
    page.table(&table(&out.rows));
    if let (Some(net), Some(ret)) = (
        out.rows.iter().find(|r| r.method == "network"),
        out.rows.iter().find(|r| r.method == "retrieval"),
    ) && net.median_pos_m >= ret.median_pos_m
    {
        page.paragraph(
            "Retrieval beats the network here. Short test blocks between training blocks are \
             retrieval's best case: a training frame a few centimetres away looks almost the \
             same. The network also trains without the validation blocks, which choose its \
             epoch. Geometric refinement (keyframes, local features, PnP) is what closes this \
             gap.",
        );
    }
    let errs: Vec<(Vec<f64>, Vec<f64>)> = ev
        .methods
        .iter()
        .map(|m| errors(&m.poses, ev.truth))
        .collect();
    let series = |rotation: bool| -> Vec<Series> {
        ev.methods
            .iter()
            .zip(&errs)
            .map(|(m, (pos, rot))| {
                Series::new(m.name.clone(), if rotation { rot } else { pos }.clone())
            })
            .collect()
    };
    page.figure(
        &report::error_cdf("Error CDF", &series(false), &series(true)),
        "Cumulative distribution of position and rotation errors on the test frames.",
    )?;
    page.figure(
        &report::error_over_time("Errors along the test frames", &series(false), &[], None),
        "Position error per test frame, in recording order (blocks follow each other).",
    )?;
    let xy = |p: &Pose| {
        let c = p.position();
        [c[0], c[1]]
    };
    let ground: Vec<[f64; 2]> = ev.truth.iter().map(xy).collect();
    let tracks: Vec<Track> = ev
        .methods
        .iter()
        .filter(|m| m.name.starts_with("network"))
        .map(|m| Track::new(m.name.clone(), m.poses.iter().map(xy).collect::<Vec<_>>()))
        .collect();
    page.figure(
        &report::trajectory_top_down("Test frames from above (x, y)", &ground, &tracks, true),
        "Ground truth and the networks' positions, each linked to its true position.",
    )?;
    page.png(
        &worst_sheet(ev)?,
        "The network's worst test frames (left) beside the most similar training frame by \
         retrieval (right), with the network's errors.",
    );
    page.write(&out.report)?;
    Ok(())
}

/// The network's [`WORST`] test frames beside their nearest training frames.
fn worst_sheet(ev: &Evidence<'_>) -> Result<Vec<u8>> {
    let (pos, rot) = errors(
        &ev.single.iter().map(|e| e.pose).collect::<Vec<_>>(),
        ev.truth,
    );
    let mut order: Vec<usize> = (0..pos.len()).collect();
    order.sort_by(|&a, &b| pos[b].total_cmp(&pos[a]));
    let tile = |img: &DynamicImage| {
        let h = TILE_WIDTH * img.height() / img.width().max(1);
        img.resize_exact(TILE_WIDTH, h.max(1), image::imageops::FilterType::Triangle)
            .to_rgb8()
    };
    let mut tiles = Vec::new();
    for &i in order.iter().take(WORST) {
        tiles.push(report::Tile {
            label: format!("{}: {:.2} m, {:.1}°", ev.test_names[i], pos[i], rot[i]),
            image: tile(&ev.test_images[i]),
        });
        let near = ev.mapped[ev.nearest[i]];
        tiles.push(report::Tile {
            label: format!("nearest: {}", near.frame.name),
            image: tile(&data::frames::decode_image(&near.image)?),
        });
    }
    Ok(report::contact_sheet("Worst frames", &tiles, 2)?)
}
