//! The demo's report: one self-contained HTML page (`report.html`) plus the figures as PNG and
//! SVG beside it, so a person sees at a glance how well the network localizes the test walk.

use super::evaluate::{Evaluation, FrameResult, UncertaintyFigures};
use super::scene::{self, ScenePlan};
use crate::{Context, Result};
use data::native::NativeDataset;
use learn::TrainSummary;
use report::{ErrorCdf, ErrorMap, Figure, HtmlReport, Series, Tile};
use std::path::{Path, PathBuf};
use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};

/// What the page shows.
pub struct PageInput<'a> {
    /// The rendered scene.
    pub scene: &'a ScenePlan,
    /// The dataset (for the test images).
    pub dataset: &'a NativeDataset,
    /// Per test frame results.
    pub results: &'a [FrameResult],
    /// Headline figures.
    pub eval: &'a Evaluation,
    /// Uncertainty against error.
    pub uncertainty: &'a UncertaintyFigures,
    /// The network also predicts each image's error scale (part of sigma_pos_m).
    pub scale: bool,
    /// The test frames were seen with test-time augmentation (its spread is part of sigma).
    pub tta: bool,
    /// The weights of sigma's parts (fitted on the validation walk).
    pub weights: learn::SigmaWeights,
    /// How training went.
    pub summary: &'a TrainSummary,
    /// The walk with scene cuts through the temporal filter.
    pub cuts: &'a crate::demo::cuts::CutFigures,
    /// The trained model (for the Grad-CAM maps).
    pub model_dir: &'a Path,
    /// The test walk refined against the keyframe map, when it was.
    pub refined: Option<&'a (super::refine::RefinedFigures, Vec<geom::Pose>)>,
}

/// Writes `report.html` and the figures into `dir`; returns the page's path.
pub fn write(dir: &Path, input: &PageInput) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let r = input.results;
    let ceiling = input.scene.camera == "ceiling";
    let angle = if ceiling { "heading" } else { "rotation" };
    let mut page = HtmlReport::new("indoorloc demo");
    page.subtitle(format!(
        "Default building, building {} storey {}: a network trained on {} rendered frames \
         ({} camera, appearance variants {}) localizes a held-out walk of {} frames.",
        input.scene.building,
        input.scene.storey,
        input.summary.train_frames,
        input.scene.camera,
        input.scene.train_variants.join(", "),
        r.len()
    ));
    page.highlights([
        (
            "median position error".to_string(),
            format!("{:.3} m", input.eval.pos_median),
        ),
        (
            format!("median {angle} error"),
            format!("{:.2}°", input.eval.rot_median),
        ),
        (
            "uncertainty–error R".to_string(),
            format!("{:.2}", input.uncertainty.pearson_r),
        ),
    ]);
    page.table(&input.eval.table);

    let mut pos = vec![Series::new("test walk", errors(r, |f| f.pos_err_m))];
    let mut rot = vec![Series::new("test walk", errors(r, |f| f.rot_err_deg))];
    if let Some((fig, poses)) = input.refined {
        let mut t = report::Table::new(
            "Refined against the keyframe map (local features + PnP, from the network's pose)",
            ["metric", "value"],
        );
        for (k, v) in [
            ("frames refined", format!("{:.1} %", 100.0 * fig.refined)),
            (
                "median position error",
                format!("{:.4} m", fig.median_pos_m),
            ),
            (
                "median rotation error",
                format!("{:.3}°", fig.median_rot_deg),
            ),
            ("mean position error", format!("{:.3} m", fig.mean_pos_m)),
            (
                "accuracy (0.05 m, 1°)",
                format!("{:.1} %", 100.0 * fig.acc_5cm_1deg),
            ),
            (
                "accuracy (0.25 m, 2°)",
                format!("{:.1} %", 100.0 * fig.acc_25cm_2deg),
            ),
            (
                "map",
                format!(
                    "{} keyframes, {} points, built in {:.1} s",
                    fig.keyframes, fig.points, fig.build_s
                ),
            ),
            ("ms per query (640x480)", format!("{:.1}", fig.ms_per_frame)),
        ] {
            t.push_row([k.to_string(), v]);
        }
        page.table(&t);
        let err = |f: &dyn Fn(&FrameResult, &geom::Pose) -> f64| {
            r.iter()
                .zip(poses)
                .map(|(x, p)| f(x, p))
                .collect::<Vec<f64>>()
        };
        pos.push(Series::new(
            "refined",
            err(&|x, p| geom::metrics::position_error(&x.truth, p)),
        ));
        rot.push(Series::new(
            "refined",
            err(&|x, p| geom::metrics::rotation_error_deg(&x.truth, p)),
        ));
    }
    let cdf: Figure = ErrorCdf {
        title: "Cumulative error distribution".into(),
        position_m: pos,
        rotation_deg: rot,
        thresholds_m: vec![0.25, 0.5],
        thresholds_deg: vec![2.0, 5.0],
    }
    .into();
    figure(
        &mut page,
        dir,
        "cdf",
        &cdf,
        "Share of test frames whose error is at most x.",
    )?;

    let floor_plan = scene::floor_plan(input.scene)?;
    let world = scene::world(input.scene, synth::Variant::Normal)?;
    let map: Figure = ErrorMap {
        title: "Test walk seen from above, coloured by position error".into(),
        ground_truth: r.iter().map(|f| xy(&f.truth)).collect(),
        estimates: r.iter().map(|f| xy(&f.estimate.pose)).collect(),
        errors_m: errors(r, |f| f.pos_err_m),
        color_max_m: None,
        links: true,
        floor_plan,
    }
    .into();
    figure(
        &mut page,
        dir,
        "error_map",
        &map,
        "Estimates as dots coloured by their position error, linked to the true position (grey \
         line: the true walk; outlines: the storey's rooms and corridors).",
    )?;

    page.section("Uncertainty");
    let w = &input.weights;
    let mut parts = vec![format!(
        "the spread of {} Monte-Carlo dropout passes (weight {:.3})",
        r.first().map_or(0, |f| f.estimate.passes),
        w.mc
    )];
    if input.tta {
        parts.push(format!(
            "the spread of the five test-time-augmented views (the frame and four copies \
             shifted by a pixel; weight {:.3})",
            w.tta
        ));
    }
    if input.scale {
        parts.push(format!(
            "the error scale the network predicts for each image (weight {:.3})",
            w.scale
        ));
    }
    page.paragraph(format!(
        "Each estimate's sigma_pos_m adds, as variances, {}; the weights were fitted on the \
         validation walk when training ended. Pearson R between sigma_pos_m and the position \
         error: {:.2}. The 10 % of frames with the largest sigma have a median error of \
         {:.3} m, the rest {:.3} m.",
        parts.join(", "),
        input.uncertainty.pearson_r,
        input.uncertainty.top10_median_m,
        input.uncertainty.rest_median_m
    ));
    let points: Vec<[f64; 2]> = r
        .iter()
        .map(|f| [f.estimate.sigma_pos_m, f.pos_err_m])
        .collect();
    let sc = report::scatter(
        "Uncertainty against error",
        "sigma_pos_m (m)",
        "position error (m)",
        &points,
    );
    figure(
        &mut page,
        dir,
        "uncertainty",
        &sc,
        "One dot per test frame; the line is the least-squares fit.",
    )?;

    page.section("Frames");
    let sheet = frames_sheet(input, &world)?;
    report::write_atomic(&dir.join("frames.png"), &sheet)?;
    page.png(
        &sheet,
        "Test frames (left) beside the building rendered from the estimated pose (right), at \
         the best, median and worst errors.",
    );

    page.section("What the network looks at");
    let sheet = saliency_sheet(input)?;
    report::write_atomic(&dir.join("saliency.png"), &sheet)?;
    page.png(
        &sheet,
        "Grad-CAM maps of the position estimate over six test frames spread along the walk:          bright where the features that move the estimate away from the centre of the training          poses are (`indoorloc explain` draws them for any frames).",
    );

    crate::demo::cuts::section(&mut page, input.cuts)?;

    page.section("Training");
    let mut t = report::Table::new(
        "Epochs",
        ["epoch", "loss", "val median m", "val median °", "seconds"],
    );
    for m in &input.summary.history {
        t.push_row([
            m.epoch.to_string(),
            format!("{:.4}", m.train_loss),
            format!("{:.3}", m.val_median_pos_m),
            format!("{:.2}", m.val_median_rot_deg),
            format!("{:.1}", m.seconds),
        ]);
    }
    page.table(&t);
    let path = dir.join("report.html");
    page.write(&path)?;
    Ok(path)
}

fn errors(r: &[FrameResult], f: impl Fn(&FrameResult) -> f64) -> Vec<f64> {
    r.iter().map(f).collect()
}

fn xy(p: &geom::Pose) -> [f64; 2] {
    [p.translation.x, p.translation.y]
}

/// Adds `fig` to the page and saves it as `stem.png` / `stem.svg`.
fn figure(
    page: &mut HtmlReport,
    dir: &Path,
    stem: &str,
    fig: &Figure,
    caption: &str,
) -> Result<()> {
    fig.save_both(dir, stem)?;
    page.figure(fig, caption)?;
    Ok(())
}

/// Pairs of (test frame, render from its estimate) at the smallest, median and largest errors.
/// Frames of the Grad-CAM sheet.
const SALIENCY_FRAMES: usize = 6;

/// Grad-CAM maps over test frames spread evenly along the walk, as one contact sheet.
fn saliency_sheet(input: &PageInput) -> Result<Vec<u8>> {
    let model = crate::explain::Explained::load(input.model_dir, learn::CamLayer::Mid)?;
    let mode = input.scene.train_mode()?;
    let r = input.results;
    let mut tiles = Vec::new();
    for k in 0..SALIENCY_FRAMES.min(r.len()) {
        let f = &r[k * r.len() / SALIENCY_FRAMES.min(r.len())];
        let number = input
            .dataset
            .frame_number(f.index)
            .unwrap_or(f.index as u64);
        let photo = data::frames::decode_image(&input.dataset.frame_path(number))?;
        let (_, _, overlay) =
            crate::explain::explain_image(&model, &scene::photo_as(photo, mode)?)?;
        tiles.push(Tile {
            label: format!("frame {number}: {:.2} m", f.pos_err_m),
            image: overlay,
        });
    }
    Ok(report::contact_sheet(
        "Grad-CAM of the position",
        &tiles,
        3,
    )?)
}

fn frames_sheet(input: &PageInput, world: &synth::World) -> Result<Vec<u8>> {
    let r = input.results;
    let mut order: Vec<usize> = (0..r.len()).collect();
    order.sort_by(|&a, &b| r[a].pos_err_m.total_cmp(&r[b].pos_err_m));
    let picks = [
        0,
        order.len() / 4,
        order.len() / 2,
        3 * order.len() / 4,
        order.len() - 1,
    ];
    let scene = RenderScene::new(world)?;
    let camera = scene::camera(input.scene)?;
    let mut renderer = Renderer::new();
    let opts = RenderOptions {
        mode: RenderMode::Textured,
        ..RenderOptions::default()
    };
    let mut tiles = Vec::new();
    for &k in &picks {
        let f = &r[order[k]];
        let number = input
            .dataset
            .frame_number(f.index)
            .unwrap_or(f.index as u64);
        let path = input.dataset.frame_path(number);
        let photo = data::frames::decode_image(&path)?.to_rgb8();
        let guess = renderer
            .render(&scene, &camera, &f.estimate.pose, &opts, &[])?
            .rgb
            .clone();
        tiles.push(Tile {
            label: format!("frame {number}"),
            image: photo,
        });
        tiles.push(Tile {
            label: format!("estimate: {:.2} m, {:.1}°", f.pos_err_m, f.rot_err_deg),
            image: guess,
        });
    }
    Ok(report::contact_sheet(
        "Test frames and renders from their estimates",
        &tiles,
        4,
    )?)
}
