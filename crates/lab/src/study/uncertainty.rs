//! `indoorloc study uncertainty`: does a pose's covariance mean what it claims?
//!
//! For each held-out set (the demo's forward test walk, the same zone under an appearance
//! variant no training walk had, the ceiling camera's test walk and, with `--data`, a real
//! dataset's held-out frames) and each source (the network alone; the temporal filter's fused
//! track fed with the network's covariances), the coverage of the 50 / 90 / 95 / 99 % regions,
//! the mean negative log-likelihood, the expected calibration error and the sharpness (median
//! σ), before calibration (the network's parts added with unit weights, the filter's own
//! covariance, read as Gaussians) and after it (the model's fitted weights, scale and
//! Mahalanobis quantiles, [`geom::uncertainty::Calibration`]; the fused track's calibration
//! fitted the same way on the filter run over the validation walk). Every calibration is fitted
//! on validation frames; every figure is on held-out frames. The ranking figures (Pearson R of
//! σ against the error, the error of the 10 % most uncertain frames over the rest) sit beside
//! the coverage, so a calibration that buys coverage with ranking shows.

use crate::demo::{self, DemoConfig, Prepared};
use crate::output::{median, print_json, print_text};
use crate::train::train_with_progress;
use crate::{Context, Result, bail};
use clap::Args;
use data::blocks::BlockSplit;
use data::native::{NativeDataset, SplitName};
use data::posed::{self, SplitPlan};
use geom::Pose;
use geom::metrics::pearson;
use geom::uncertainty::{Calibration, Standardised, UncertaintyFigures};
use imgproc::view::View;
use learn::calibrate::{CALIBRATION_MC, rot_dims, rotation_error};
use learn::{Estimate, Localizer, SigmaParts, SigmaWeights, TrainConfig, UncertaintyCalibration};
use rayon::prelude::*;
use report::{HtmlReport, ReliabilityCurve, Table};
use serde::Serialize;
use std::path::{Path, PathBuf};
use synth::Variant;
use track::FilterConfig;

/// Arguments of `indoorloc study uncertainty`.
#[derive(Args, Debug)]
pub struct UncertaintyConfig {
    /// Folder for the data, the models and `report.html` (reused by a second run).
    #[arg(
        long,
        value_name = "DIR",
        default_value = "indoorloc-study-uncertainty"
    )]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// A real posed dataset too (any layout `data` opens): the network trained with `study
    /// real`'s recipe on its training part, scored on its held-out frames.
    #[arg(long, value_name = "DATASET")]
    data: Option<PathBuf>,
    /// Blocks of consecutive frames for --data, BLOCK:EVERY[:OFFSET], instead of its own split.
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
    /// Appearance variant of the held-out walk that no training walk has.
    #[arg(long, default_value = "people")]
    variant: Variant,
    /// Also the ceiling camera (3-DoF: x, y, heading); `false` leaves it out.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set, value_name = "BOOL")]
    ceiling: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row: a source on a held-out set, before or after calibration.
#[derive(Debug, Serialize)]
struct Row {
    /// `network` or `fused`.
    source: &'static str,
    /// The held-out set: `forward`, `forward-<variant>`, `ceiling` or the real dataset's name.
    dataset: String,
    /// `none` (unit weights / the filter's own covariance, read as Gaussian) or `calibrated`.
    calibration: &'static str,
    frames: usize,
    coverage_50: f64,
    coverage_90: f64,
    coverage_95: f64,
    coverage_99: f64,
    /// Mean negative log-likelihood of the position errors, nats.
    nll: f64,
    /// Mean |observed − nominal| coverage over the levels 5 … 95 %.
    ece: f64,
    /// Median `sqrt(trace Σ)`, metres.
    median_sigma_m: f64,
    /// Median position error, metres.
    median_pos_m: f64,
    /// Pearson R between σ and the position error.
    pearson_r: f64,
    /// Median error of the 10 % of frames with the largest σ over that of the rest.
    top10_ratio: f64,
    /// Coverage of the 95 % region of the rotation error (network rows with MC passes).
    #[serde(skip_serializing_if = "Option::is_none")]
    rot_coverage_95: Option<f64>,
    /// Observed coverage at the nominal levels 5, 10, … 95, 99 % (the reliability diagram).
    reliability: Vec<f64>,
}

#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    /// Rows of the acceptance band (95 % region in 93–97 %, 50 % region in 45–55 %) among the
    /// calibrated ones.
    calibrated_in_band: usize,
    calibrated_rows: usize,
    report: PathBuf,
}

/// Frames of one set in time order, with what the filter needs.
struct FrameSet {
    views: Vec<View>,
    truth: Vec<Pose>,
    /// Time, seconds.
    t: Vec<f64>,
    /// Run of consecutive frames each belongs to: the filter starts over where it changes.
    run: Vec<usize>,
}

/// What the network says of each frame of a set.
struct NetworkPass {
    poses: Vec<Pose>,
    parts: Vec<SigmaParts>,
    /// RMS angle of the MC samples, radians.
    rot_spread: Vec<f64>,
}

/// A trained model with what it was calibrated with.
struct Model {
    dir: PathBuf,
    loc: Localizer,
    weights: SigmaWeights,
    calibration: UncertaintyCalibration,
}

impl Model {
    fn load(dir: &Path) -> Result<Model> {
        let loc = Localizer::load(dir)?.with_tta(true);
        let meta = loc.meta();
        let Some(calibration) = meta.uncertainty.clone() else {
            bail!(
                "{}: the model has no uncertainty calibration (too few validation frames?)",
                dir.display()
            );
        };
        Ok(Model {
            dir: dir.to_path_buf(),
            weights: meta.sigma_weights(),
            calibration,
            loc,
        })
    }

    fn dims(&self) -> usize {
        self.loc.meta().coding.task.pos_dims()
    }

    fn pass(&self, set: &FrameSet) -> Result<NetworkPass> {
        let out = self.loc.sigma_parts(&set.views, CALIBRATION_MC)?;
        Ok(NetworkPass {
            poses: out.iter().map(|o| o.0).collect(),
            parts: out.iter().map(|o| o.1).collect(),
            rot_spread: out.iter().map(|o| o.2.to_radians()).collect(),
        })
    }
}

/// Runs `indoorloc study uncertainty`.
pub fn run(args: &UncertaintyConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let mut rows = Vec::new();
    let mut diagrams = Vec::new();

    say("forward camera: the demo's network (rendered and trained as `demo` does)");
    let demo_args = args.scale.demo(&args.out.join("forward"));
    let forward = demo::render_and_train(&demo_args, &say)?;
    let (model, fused_cal, test) = demo_test_walk(&forward)?;
    score_set(&model, &test, "forward", fused_cal.as_ref(), &mut rows)?;
    diagrams.push("forward".to_string());

    let walks = args.out.join("forward").join("variant-walk");
    say(&format!(
        "the held-out walk under '{}', which no training walk had",
        args.variant.name()
    ));
    demo::scene::render_variant_walks(forward.scene(), &walks, &[args.variant], &|_| {})?;
    let vds = NativeDataset::open(&walks)?;
    let photo_as = forward.scene().train_mode()?;
    let variant = native_set(&vds, SplitName::Test, &model.loc, photo_as)?;
    let name = format!("forward-{}", args.variant.name());
    score_set(&model, &variant, &name, fused_cal.as_ref(), &mut rows)?;
    diagrams.push(name);

    if args.ceiling {
        say("ceiling camera (x, y, heading): the demo's ceiling networks");
        let demo_args = DemoConfig {
            camera: demo::DemoCamera::Ceiling,
            ..args.scale.demo(&args.out.join("ceiling"))
        };
        let ceiling = demo::render_and_train(&demo_args, &say)?;
        let (model, fused_cal, test) = demo_test_walk(&ceiling)?;
        score_set(&model, &test, "ceiling", fused_cal.as_ref(), &mut rows)?;
        diagrams.push("ceiling".to_string());
    }

    if let Some(data) = &args.data {
        say(&format!(
            "{}: the network of `study real` (real-photo recipe)",
            data.display()
        ));
        let dir = args.out.join("real").join("model");
        let mut cfg = TrainConfig::for_real_photos(data, &dir);
        cfg.blocks = args.blocks;
        if args.scale.quick {
            cfg.epochs = cfg.epochs.div_ceil(3);
        }
        if let Some(epochs) = args.scale.epochs {
            cfg.epochs = epochs;
        }
        cfg.resume = true;
        train_with_progress(&cfg, !args.json)?;
        let model = Model::load(&dir)?;
        let ds = posed::open(data)?;
        let plan = args.blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
        let fused_cal = fused_calibration(&model, data, plan)?;
        let test = posed_set(&ds, plan, SplitName::Test, &model.loc)?;
        let name = ds.name();
        score_set(&model, &test, &name, fused_cal.as_ref(), &mut rows)?;
        diagrams.push(name);
    }

    let report = args.out.join("report.html");
    write_report(&report, &rows, &diagrams)?;
    let calibrated: Vec<&Row> = rows
        .iter()
        .filter(|r| r.calibration == "calibrated")
        .collect();
    let out = StudyOutput {
        calibrated_in_band: calibrated.iter().filter(|r| in_band(r)).count(),
        calibrated_rows: calibrated.len(),
        rows,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\ncalibrated rows with the 95 % region in 93–97 % and the 50 % region in 45–55 %: \
             {} of {}\nreport: {}\n",
                table(&out.rows).to_text(),
                out.calibrated_in_band,
                out.calibrated_rows,
                out.report.display()
            ),
        )
    }
}

/// A demo folder's model, its fused calibration and its held-out test walk.
fn demo_test_walk(prepared: &Prepared) -> Result<(Model, Option<Calibration>, FrameSet)> {
    let model = Model::load(&prepared.model_dir)?;
    let ds = NativeDataset::open(&prepared.data_dir)?;
    let photo_as = prepared.scene().train_mode()?;
    let fused_cal = fused_calibration(&model, &prepared.data_dir, SplitPlan::Auto)?;
    let test = native_set(&ds, SplitName::Test, &model.loc, photo_as)?;
    Ok((model, fused_cal, test))
}

/// Whether a row's coverage is in the acceptance band.
fn in_band(r: &Row) -> bool {
    (0.93..=0.97).contains(&r.coverage_95) && (0.45..=0.55).contains(&r.coverage_50)
}

/// The frames of one split of a rendered dataset, in file order, as the model sees them.
fn native_set(
    ds: &NativeDataset,
    which: SplitName,
    loc: &Localizer,
    photo_as: synth::render::RenderMode,
) -> Result<FrameSet> {
    let frames = &ds.trajectory.frames;
    let index = ds.split_frames(which);
    if index.is_empty() {
        bail!("{}: no {which:?} frames", ds.root.display());
    }
    let views = demo::views_of(ds, &index, loc, photo_as)?;
    let rate = ds.info.frame_rate.max(1e-3);
    Ok(FrameSet {
        views,
        truth: index.iter().map(|&i| frames[i].pose).collect(),
        t: index
            .iter()
            .map(|&i| frames[i].t.unwrap_or(i as f64 / rate))
            .collect(),
        run: track::calibrate::runs(&index, |i| frames[i].seq.as_str()),
    })
}

/// The frames of one part of a posed dataset under `plan`, as the model sees them.
fn posed_set(
    ds: &posed::PosedDataset,
    plan: SplitPlan,
    which: SplitName,
    loc: &Localizer,
) -> Result<FrameSet> {
    let parts = ds.parts(plan);
    let index: Vec<usize> = (0..ds.images.len())
        .filter(|&i| parts[i] == Some(which))
        .collect();
    if index.is_empty() {
        bail!(
            "{}: no {which:?} frames ({})",
            ds.root.display(),
            ds.describe_split(plan)
        );
    }
    let views = index
        .par_iter()
        .map(|&i| {
            let path = &ds.images[i].image;
            let img = data::frames::decode_image(path)?;
            loc.view(&img)
                .with_context(|| format!("{}: cannot make the view", path.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    // 7-Scenes and most posed sets carry no clock: 30 frames per second, Kinect's rate.
    Ok(FrameSet {
        views,
        truth: index.iter().map(|&i| ds.images[i].frame.pose).collect(),
        t: index
            .iter()
            .map(|&i| ds.images[i].frame.t.unwrap_or(i as f64 / 30.0))
            .collect(),
        run: track::calibrate::runs(&index, |i| ds.images[i].frame.seq.as_str()),
    })
}

/// The fused calibration stored with the model; fitted now (and stored) for a model trained
/// before there was one, on the validation part of `data` split by `plan`.
fn fused_calibration(model: &Model, data: &Path, plan: SplitPlan) -> Result<Option<Calibration>> {
    if let Some(c) = &model.calibration.fused {
        return Ok(Some(c.clone()));
    }
    Ok(track::calibrate::calibrate_model(
        &model.dir, data, plan, None,
    )?)
}

/// The four rows of one held-out set: network and fused track, before and after calibration.
fn score_set(
    model: &Model,
    set: &FrameSet,
    dataset: &str,
    fused_cal: Option<&Calibration>,
    rows: &mut Vec<Row>,
) -> Result<()> {
    let dims = model.dims();
    let task = model.loc.meta().coding.task;
    let mount = model.loc.meta().coding.mount;
    let pass = model.pass(set)?;
    let errors: Vec<_> = pass
        .poses
        .iter()
        .zip(&set.truth)
        .map(|(p, t)| p.translation - t.translation)
        .collect();
    let err_m: Vec<f64> = errors.iter().map(|e| e.rows(0, dims).norm()).collect();
    let standardise = |weights: &SigmaWeights| -> Result<(Vec<Standardised>, Vec<f64>)> {
        errors
            .iter()
            .zip(&pass.parts)
            .map(|(e, p)| {
                let cov = weights.covariance(p, dims);
                let s = Standardised::of(e, &cov, dims).with_context(|| {
                    format!("{}: a covariance is singular", model.dir.display())
                })?;
                Ok((s, cov.trace().sqrt()))
            })
            .collect::<Result<Vec<_>>>()
            .map(|v| v.into_iter().unzip())
    };
    let rot: Vec<Standardised> = pass
        .poses
        .iter()
        .zip(&set.truth)
        .zip(&pass.rot_spread)
        .filter_map(|((p, t), spread)| {
            let e = rotation_error(task, mount, t, p);
            Standardised::isotropic(e * e, spread * spread, rot_dims(task))
        })
        .collect();
    let rot_cov = |cal: Option<&Calibration>| {
        (!rot.is_empty())
            .then(|| UncertaintyFigures::of(&rot, &vec![0.0; rot.len()], cal))
            .flatten()
            .map(|f| f.coverage[2])
    };

    let (raw, raw_sigma) = standardise(&SigmaWeights::UNIT)?;
    let (weighed, weighed_sigma) = standardise(&model.weights)?;
    let position = &model.calibration.position;
    rows.push(row(
        ("network", dataset, "none"),
        (&raw, &raw_sigma, None),
        &err_m,
        rot_cov(None),
    )?);
    rows.push(row(
        ("network", dataset, "calibrated"),
        (&weighed, &weighed_sigma, Some(position)),
        &err_m,
        rot_cov(model.calibration.rotation.as_ref()),
    )?);

    let estimates: Vec<Estimate> = pass
        .poses
        .iter()
        .zip(&pass.parts)
        .zip(&pass.rot_spread)
        .map(|((&pose, parts), spread)| {
            model
                .loc
                .estimate_from_parts(pose, parts, spread.to_degrees(), CALIBRATION_MC)
        })
        .collect();
    let walk = track::calibrate::Walk {
        estimates: &estimates,
        truth: &set.truth,
        t: &set.t,
        run: &set.run,
    };
    let fused = track::calibrate::fuse(&walk, FilterConfig::default());
    let (fs, fsigma) = track::calibrate::standardised(&fused, &set.truth, dims);
    let ferr: Vec<f64> = fused
        .iter()
        .zip(&set.truth)
        .map(|(f, t)| (f.pose.translation - t.translation).rows(0, dims).norm())
        .collect();
    rows.push(row(
        ("fused", dataset, "none"),
        (&fs, &fsigma, None),
        &ferr,
        None,
    )?);
    if let Some(cal) = fused_cal {
        rows.push(row(
            ("fused", dataset, "calibrated"),
            (&fs, &fsigma, Some(cal)),
            &ferr,
            None,
        )?);
    }
    Ok(())
}

/// One row's figures.
fn row(
    (source, dataset, calibration): (&'static str, &str, &'static str),
    (frames, sigma, cal): (&[Standardised], &[f64], Option<&Calibration>),
    err_m: &[f64],
    rot_coverage_95: Option<f64>,
) -> Result<Row> {
    let f = UncertaintyFigures::of(frames, sigma, cal).context("no frames to score")?;
    let mut order: Vec<usize> = (0..sigma.len()).collect();
    order.sort_by(|&a, &b| sigma[b].total_cmp(&sigma[a]));
    let top = (order.len() / 10).max(1);
    let pick = |idx: &[usize]| median(&idx.iter().map(|&i| err_m[i]).collect::<Vec<_>>());
    let levels = geom::uncertainty::KNOT_LEVELS;
    Ok(Row {
        source,
        dataset: dataset.to_string(),
        calibration,
        frames: f.frames,
        coverage_50: f.coverage[0],
        coverage_90: f.coverage[1],
        coverage_95: f.coverage[2],
        coverage_99: f.coverage[3],
        nll: f.nll,
        ece: f.ece,
        median_sigma_m: f.median_sigma_m,
        median_pos_m: median(err_m),
        pearson_r: pearson(sigma, err_m).unwrap_or(f64::NAN),
        top10_ratio: pick(&order[..top]) / pick(&order[top..]),
        rot_coverage_95,
        reliability: UncertaintyFigures::reliability(frames, cal, &levels),
    })
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Coverage of the position uncertainty on held-out frames",
        [
            "set",
            "source",
            "calibration",
            "50 %",
            "90 %",
            "95 %",
            "99 %",
            "NLL",
            "ECE",
            "median σ (m)",
            "median err (m)",
            "R",
            "top 10 %",
            "rot 95 %",
        ],
    );
    let pct = |v: f64| format!("{:.1}", 100.0 * v);
    for r in rows {
        t.push_row([
            r.dataset.clone(),
            r.source.to_string(),
            r.calibration.to_string(),
            pct(r.coverage_50),
            pct(r.coverage_90),
            pct(r.coverage_95),
            pct(r.coverage_99),
            format!("{:.2}", r.nll),
            format!("{:.3}", r.ece),
            format!("{:.3}", r.median_sigma_m),
            format!("{:.3}", r.median_pos_m),
            format!("{:.2}", r.pearson_r),
            format!("{:.2}x", r.top10_ratio),
            r.rot_coverage_95.map_or_else(|| "–".into(), pct),
        ]);
    }
    t
}

fn write_report(path: &Path, rows: &[Row], sets: &[String]) -> Result<()> {
    let mut page = HtmlReport::new("Uncertainty you can bet on: coverage of the covariance");
    page.paragraph(
        "Each pose leaves indoorloc with a 3x3 position covariance. Its p region (the \
         ellipsoid eᵀΣ⁻¹e ≤ r²) should hold the true position in a share p of frames. \
         \"none\": the network's MC-dropout, test-time-augmentation and predicted-scale \
         covariances added with unit weights, and the filter's own covariance, read as \
         Gaussians. \"calibrated\": the weights, scale and Mahalanobis quantiles fitted on the \
         validation walk (for the fused track: the filter run over the validation walk). Every \
         figure is on held-out frames; the acceptance band is 93–97 % for the 95 % region and \
         45–55 % for the 50 % region."
            .to_string(),
    );
    page.table(&table(rows));
    let levels = geom::uncertainty::KNOT_LEVELS;
    for set in sets {
        let curves: Vec<ReliabilityCurve> = rows
            .iter()
            .filter(|r| &r.dataset == set)
            .map(|r| ReliabilityCurve {
                name: format!("{}, {}", r.source, r.calibration),
                points: levels
                    .iter()
                    .zip(&r.reliability)
                    .map(|(&p, &c)| [p, c])
                    .collect(),
            })
            .collect();
        page.figure(
            &report::reliability(&format!("Reliability: {set}"), curves),
            "Share of held-out errors inside each region against the region's nominal \
             probability; the diagonal is perfect calibration, below it the regions are too small.",
        )?;
    }
    page.write(path)?;
    Ok(())
}
