//! The demo's centimetre stage: a keyframe map of the zone from survey walks rendered at
//! 640x480 with depth (`ScenePlan::for_map`), and each held-out test frame (the same walk
//! rendered at 640x480) refined against it from the network's estimate of its 160x120 frame,
//! the network's sigma gating the refinement (`map::refine`).

use super::evaluate::FrameResult;
use super::scene::{self, ScenePlan};
use crate::progress::bar;
use crate::{Context, Result, bail};
use data::native::SplitName;
use data::posed::{self, SplitPlan};
use geom::Pose;
use geom::metrics::{position_error, rotation_error_deg};
use map::{BuildConfig, Coarse, RefineConfig};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// Folder of the map's survey and query frames in a demo folder.
pub const MAP_DATA: &str = "map-data";
/// The map file in a demo folder.
pub const MAP_FILE: &str = "zone.map";

/// The refined test walk's figures.
#[derive(Clone, Debug, Serialize)]
pub struct RefinedFigures {
    /// Median position error of the refined walk (fallbacks keep the network's), metres.
    pub median_pos_m: f64,
    /// Median rotation error, degrees.
    pub median_rot_deg: f64,
    /// Mean position error, metres.
    pub mean_pos_m: f64,
    /// Share within (5 cm, 1°).
    pub acc_5cm_1deg: f64,
    /// Share within (0.25 m, 2°).
    pub acc_25cm_2deg: f64,
    /// Share of frames the map refined.
    pub refined: f64,
    /// Keyframes of the map.
    pub keyframes: usize,
    /// 3-D points of the map.
    pub points: usize,
    /// Seconds to render the survey (0 when reused).
    pub render_s: f64,
    /// Seconds to build the map.
    pub build_s: f64,
    /// Median ms per refined query (one thread each).
    pub ms_per_frame: f64,
}

/// Renders the survey (reused when an earlier run left it), builds the map into
/// `out/zone.map` and refines each test result; the refined poses in the results' order.
pub fn refine_test(
    plan: &ScenePlan,
    survey_frames: usize,
    out: &Path,
    results: &[FrameResult],
    show: bool,
) -> Result<(RefinedFigures, Vec<Pose>)> {
    let map_plan = plan.for_map(survey_frames);
    let dir = out.join(MAP_DATA);
    let t = Instant::now();
    let pb = bar(map_plan.total_frames() as u64, "render");
    if !show {
        pb.hide();
    }
    let rendered = scene::render(&map_plan, &dir, &|n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    let render_s = if rendered {
        t.elapsed().as_secs_f64()
    } else {
        0.0
    };

    let t = Instant::now();
    let ds = posed::open(&dir)?;
    let camera = ds.require_camera()?;
    let mapped = ds.mapped(SplitPlan::Auto);
    let cfg = BuildConfig::default();
    let pb = bar(
        map::keyframes::select_keyframes(&mapped, &cfg).len() as u64,
        "keyframes",
    );
    if !show {
        pb.hide();
    }
    let lifting = map::Lifting::depth_of(&ds, &camera);
    let km = map::keyframes::build(&mapped, &camera, &lifting, &cfg, &|| pb.inc(1))?;
    pb.finish_and_clear();
    map::file::save(&km, &out.join(MAP_FILE))?;
    let build_s = t.elapsed().as_secs_f64();

    let queries = ds.split(SplitPlan::Auto, SplitName::Test);
    if queries.len() != results.len() {
        bail!(
            "{}: {} test frames at the map's resolution, {} localized",
            dir.display(),
            queries.len(),
            results.len()
        );
    }
    let refine_cfg = RefineConfig::default();
    let refined: Vec<(map::Refinement, f64)> = queries
        .par_iter()
        .zip(results)
        .map(|(q, r)| {
            if position_error(&q.frame.pose, &r.truth) > 1e-6 {
                bail!(
                    "{}: test frame {} is not the localized walk's",
                    dir.display(),
                    q.frame.name
                );
            }
            let img = data::frames::decode_image(&q.image)?;
            let coarse = Coarse {
                pose: r.estimate.pose,
                sigma_pos_m: r.estimate.sigma_pos_m,
            };
            let t = Instant::now();
            let out = km
                .refine(&img, Some(&coarse), &refine_cfg)
                .with_context(|| format!("refining {}", q.image.display()))?;
            Ok((out, t.elapsed().as_secs_f64() * 1e3))
        })
        .collect::<Result<_>>()?;
    let poses: Vec<Pose> = refined.iter().map(|(r, _)| r.pose).collect();
    let (pos, rot): (Vec<f64>, Vec<f64>) = results
        .iter()
        .zip(&poses)
        .map(|(r, p)| (position_error(&r.truth, p), rotation_error_deg(&r.truth, p)))
        .unzip();
    let median = |v: &[f64]| crate::output::median(v);
    let ms: Vec<f64> = refined.iter().map(|(_, ms)| *ms).collect();
    Ok((
        RefinedFigures {
            median_pos_m: median(&pos),
            median_rot_deg: median(&rot),
            mean_pos_m: pos.iter().sum::<f64>() / pos.len().max(1) as f64,
            acc_5cm_1deg: geom::metrics::accuracy(&pos, &rot, 0.05, 1.0),
            acc_25cm_2deg: geom::metrics::accuracy(&pos, &rot, 0.25, 2.0),
            refined: refined.iter().filter(|(r, _)| r.refined).count() as f64
                / refined.len().max(1) as f64,
            keyframes: km.len(),
            points: km.points(),
            render_s,
            build_s,
            ms_per_frame: median(&ms),
        },
        poses,
    ))
}
