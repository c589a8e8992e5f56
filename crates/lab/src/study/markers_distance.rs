//! `indoorloc study markers-distance`: how far away and how obliquely a printed ArUco marker
//! still gives a metric fix.
//!
//! A marker hangs on the back wall of a rendered room (the renderer's own textured mode, with
//! sensor noise and vignetting); the camera stands at each distance and viewing angle (turned
//! about the marker's vertical axis), a little off-axis and at a random height, and looks
//! roughly at it. Every frame goes through detection and IPPE pose like a real photo, and the
//! marker's estimated position in the camera frame is compared with the truth: the error along
//! the line of sight (range) and across it (lateral), for two camera resolutions. Corners are
//! refined onto the square's sub-pixel edges (`DetectParams::refine_edges`).

use crate::output::{print_json, print_text};
use crate::{Context, Result, ensure};
use clap::Args;
use geom::{Camera, Pose};
use markers::{DetectParams, Dictionary, Marker};
use nalgebra::{Matrix3, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use report::{HtmlReport, Table, Tile};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;
use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};
use synth::world::{Light, Material, Pattern, Triangle, World};

/// Horizontal field of view of the study's camera (a typical webcam), degrees.
const HFOV_DEG: f64 = 60.0;
/// Height of the marker's centre above the floor, metres.
const MARKER_HEIGHT_M: f32 = 1.5;

/// Arguments of `indoorloc study markers-distance`.
#[derive(Args, Debug)]
pub struct MarkersDistanceConfig {
    /// Folder for `report.html` and example frames.
    #[arg(
        long,
        value_name = "DIR",
        default_value = "indoorloc-study-markers-distance"
    )]
    out: PathBuf,
    /// Dictionary of the marker (`4x4_50` … `7x7_1000`, `original`).
    #[arg(long, default_value = "4x4_50")]
    dict: String,
    /// Side of the printed black square, metres.
    #[arg(long, default_value_t = 0.2)]
    size: f64,
    /// Camera distances from the marker, metres.
    #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,3,4,5,6,8")]
    distances: Vec<f64>,
    /// Viewing angles from the marker's normal, degrees.
    #[arg(long, value_delimiter = ',', default_value = "0,30,45,60")]
    angles: Vec<f64>,
    /// Camera resolutions, WxH (the same 60° field of view).
    #[arg(long, value_delimiter = ',', value_parser = crate::parse::size, default_value = "640x480,1280x960")]
    resolutions: Vec<(u32, u32)>,
    /// Frames per (resolution, distance, angle), each with its own small offsets and noise.
    #[arg(long, default_value_t = 8)]
    trials: usize,
    /// Render each frame at N x N times the pixels and average them down in linear light, as a
    /// sensor integrates light over its pixels (the renderer alone point-samples: ±0.5 px
    /// aliasing on the marker's edges).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=8))]
    supersample: u32,
    /// Fewer frames per cell (3): a minute instead of several.
    #[arg(long)]
    quick: bool,
    /// Seed of the camera offsets and sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row: a camera resolution, distance and angle.
#[derive(Debug, Serialize)]
struct Row {
    resolution: String,
    distance_m: f64,
    angle_deg: f64,
    /// Fraction of frames in which the marker was found with its id.
    detected: f64,
    /// Median |estimated − true| distance to the marker, metres.
    range_err_m: f64,
    /// Median estimated − true distance (positive: the marker looks too far), metres.
    range_bias_m: f64,
    /// Median error across the line of sight, metres.
    lateral_err_m: f64,
    /// Median position error as a percentage of the distance.
    pos_err_pct: f64,
    /// Median error of the marker's orientation, degrees.
    rot_err_deg: f64,
    /// Fraction of detections whose two IPPE poses fit about equally well.
    ambiguous: f64,
    /// Side of the marker in the image, pixels (median).
    marker_px: f64,
}

/// What the study prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    dictionary: String,
    marker_size_m: f64,
    trials: usize,
    /// Largest median position error (% of distance) at the first resolution up to 5 m, over
    /// the cells where the marker was found.
    worst_pct_to_5m: f64,
    /// Cells at the first resolution up to 5 m where the marker was never found.
    missed_cells_to_5m: usize,
    report: PathBuf,
}

/// The outcome of one rendered frame.
struct Trial {
    found: Option<Found>,
}

struct Found {
    range_err: f64,
    range_bias: f64,
    lateral_err: f64,
    pos_err_pct: f64,
    rot_err_deg: f64,
    ambiguous: bool,
    side_px: f64,
}

/// Runs `indoorloc study markers-distance`.
pub fn run(args: &MarkersDistanceConfig, sink: &mut dyn crate::Output) -> Result<()> {
    ensure!(
        args.size > 0.0,
        "--size must be a positive number of metres"
    );
    ensure!(
        !args.distances.is_empty() && !args.angles.is_empty(),
        "no distances or angles"
    );
    ensure!(
        args.distances.iter().all(|d| *d > 0.05 && *d < 13.0),
        "--distances must lie between 0.05 and 13 m (the room is 14 m deep)"
    );
    ensure!(
        args.angles.iter().all(|a| a.abs() < 85.0),
        "--angles must lie within ±85°"
    );
    let dict = Dictionary::predefined(&args.dict)?;
    let trials = if args.quick { 3 } else { args.trials.max(1) };
    let id = 7.min(dict.len() as u32 - 1);
    let marker_img = markers::generate::marker_image(&dict, id, 64, 1)?;
    let n_cells = (dict.marker_size() + 2) as f32;
    // The picture includes a one-cell white quiet zone around the black square.
    let picture_m = args.size as f32 * (n_cells + 2.0) / n_cells;
    let (world, marker_pose) = room(marker_img, picture_m);
    let scene = RenderScene::new(&world)?;
    let cameras: Vec<(String, Camera)> = args
        .resolutions
        .iter()
        .map(|&(w, h)| {
            Ok((
                format!("{w}x{h}"),
                Camera::from_hfov(w, h, HFOV_DEG.to_radians())?,
            ))
        })
        .collect::<Result<_>>()?;
    let cells: Vec<(usize, f64, f64)> = (0..cameras.len())
        .flat_map(|c| {
            args.distances
                .iter()
                .flat_map(move |&d| args.angles.iter().map(move |&a| (c, d, a)))
        })
        .collect();
    let pb = crate::progress::bar((cells.len() * trials) as u64, "frames");
    let params = DetectParams {
        refine_edges: true,
        ..DetectParams::default()
    };
    let mut examples = Vec::new();
    let mut rows = Vec::new();
    for (ci, &(c, distance, angle)) in cells.iter().enumerate() {
        let (name, camera) = &cameras[c];
        let results: Vec<(Trial, Option<image::RgbImage>)> = (0..trials)
            .into_par_iter()
            .map_init(Renderer::new, |renderer, t| {
                let seed = args.seed ^ ((ci * 1000 + t) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                let keep = t == 0 && c == 0;
                let out = one_trial(
                    renderer,
                    &scene,
                    camera,
                    args.supersample,
                    &marker_pose,
                    &dict,
                    &params,
                    id,
                    args.size,
                    distance,
                    angle,
                    seed,
                    keep,
                );
                pb.inc(1);
                out
            })
            .collect::<Result<_>>()?;
        let mut trials_out = Vec::new();
        for (trial, img) in results {
            if let Some(img) = img {
                examples.push(Tile {
                    label: format!("{distance} m, {angle}°"),
                    image: img,
                });
            }
            trials_out.push(trial);
        }
        rows.push(summarise(name, distance, angle, &trials_out));
    }
    pb.finish_and_clear();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let report = args.out.join("report.html");
    let worst = rows
        .iter()
        .filter(|r| r.resolution == cameras[0].0 && r.distance_m <= 5.0)
        .filter(|r| r.detected > 0.0)
        .map(|r| r.pos_err_pct)
        .fold(0.0, f64::max);
    let missed = rows
        .iter()
        .filter(|r| r.resolution == cameras[0].0 && r.distance_m <= 5.0 && r.detected == 0.0)
        .count();
    write_report(&report, &rows, &examples, args, trials)?;
    let out = StudyOutput {
        rows,
        dictionary: dict.name().to_string(),
        marker_size_m: args.size,
        trials,
        worst_pct_to_5m: worst,
        missed_cells_to_5m: missed,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\nworst median position error up to 5 m at {}: {:.2} % of distance ({} cells never \
             detected); report: {}\n",
                table(&out.rows).to_text(),
                cameras[0].0,
                out.worst_pct_to_5m,
                out.missed_cells_to_5m,
                out.report.display()
            ),
        )
    }
}

/// Renders one frame of the marker from `distance` and `angle` (with small random offsets),
/// detects it and scores its pose; the frame comes back when `keep`.
#[allow(clippy::too_many_arguments)]
fn one_trial(
    renderer: &mut Renderer,
    scene: &RenderScene,
    camera: &Camera,
    supersample: u32,
    marker_pose: &Pose,
    dict: &Dictionary,
    params: &DetectParams,
    id: u32,
    size: f64,
    distance: f64,
    angle: f64,
    seed: u64,
    keep: bool,
) -> Result<(Trial, Option<image::RgbImage>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pose = camera_pose(marker_pose, distance, angle, &mut rng);
    let opts = RenderOptions {
        mode: RenderMode::Textured,
        seed,
        ..RenderOptions::default()
    };
    let fine = camera.resized(camera.width * supersample, camera.height * supersample);
    let out = renderer.render(scene, &fine, &pose, &opts, &[])?;
    let rgb = downsample_linear(&out.rgb, supersample);
    let gray = image::DynamicImage::ImageRgb8(rgb.clone()).to_luma8();
    let detections: Vec<Marker> = markers::detect(&gray, dict, params);
    let truth = pose.inverse().compose(marker_pose);
    let found = detections
        .iter()
        .find(|m| m.id == id)
        .and_then(|m| markers::estimate_marker_pose(m, size, camera).map(|p| (m, p)))
        .map(|(m, p)| {
            let est = &p.best.marker_in_camera;
            let t_true = Vector3::from(truth.position());
            let err = Vector3::from(est.position()) - t_true;
            let along = t_true.normalize();
            let side_px = (0..4)
                .map(|k| (m.corners[(k + 1) % 4] - m.corners[k]).norm())
                .sum::<f64>()
                / 4.0;
            Found {
                range_err: (Vector3::from(est.position()).norm() - t_true.norm()).abs(),
                range_bias: Vector3::from(est.position()).norm() - t_true.norm(),
                lateral_err: (err - along * err.dot(&along)).norm(),
                pos_err_pct: 100.0 * err.norm() / t_true.norm(),
                rot_err_deg: est.rotation.angle_to(&truth.rotation).to_degrees(),
                ambiguous: p.ambiguous,
                side_px,
            }
        });
    let example = keep.then(|| {
        let w = rgb.width().min(320);
        let h = (rgb.height() * w / rgb.width().max(1)).max(1);
        image::imageops::resize(&rgb, w, h, image::imageops::FilterType::Triangle)
    });
    Ok((Trial { found }, example))
}

/// Averages `factor` x `factor` blocks of sRGB pixels in linear light.
fn downsample_linear(img: &image::RgbImage, factor: u32) -> image::RgbImage {
    if factor <= 1 {
        return img.clone();
    }
    let to_linear: Vec<f32> = (0..256)
        .map(|v| {
            let c = v as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
        .collect();
    let to_srgb = |l: f32| {
        let c = if l <= 0.003_130_8 {
            12.92 * l
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        };
        (c * 255.0).round().clamp(0.0, 255.0) as u8
    };
    let (w, h) = (img.width() / factor, img.height() / factor);
    let n = (factor * factor) as f32;
    image::RgbImage::from_fn(w, h, |x, y| {
        let mut acc = [0.0f32; 3];
        for dy in 0..factor {
            for dx in 0..factor {
                let p = img.get_pixel(x * factor + dx, y * factor + dy);
                for k in 0..3 {
                    acc[k] += to_linear[p[k] as usize];
                }
            }
        }
        image::Rgb(acc.map(|a| to_srgb(a / n)))
    })
}

/// Camera-to-world pose `distance` metres from the marker, `angle` degrees off its normal
/// (turned about the vertical), up to ±0.15 m higher or lower, aimed a few degrees off the
/// marker so that it is not always at the image centre.
fn camera_pose(marker_pose: &Pose, distance: f64, angle: f64, rng: &mut ChaCha8Rng) -> Pose {
    let r = marker_pose.rotation_matrix();
    let (right, normal) = (r.column(0).into_owned(), r.column(2).into_owned());
    let a = angle.to_radians();
    let centre = Vector3::from(marker_pose.position());
    let mut position = centre + distance * (a.cos() * normal + a.sin() * right);
    position.z += rng.random_range(-0.15..0.15);
    // Look at a point beside the marker: up to 8° off in each direction.
    let off = 8f64.to_radians();
    let aim = centre
        + distance
            * (rng.random_range(-off..off)).tan()
            * (normal.cross(&Vector3::z()).normalize())
        + Vector3::z() * distance * (rng.random_range(-off..off)).tan();
    let forward = (aim - position).normalize();
    let x = forward.cross(&Vector3::z()).normalize();
    let y = forward.cross(&x);
    let rot = Matrix3::from_columns(&[x, y, forward]);
    Pose::from_rt(&rot, position.into()).expect("an orthonormal camera frame")
}

/// A 12 x 14 x 3 m room, lit from the ceiling, with the marker picture (`picture_m` square,
/// quiet zone included) on the middle of the back wall (y = 14) facing into the room. Returns
/// the world and the marker-to-world pose (OpenCV's marker frame: x right, y up, z out of the
/// wall).
fn room(marker: image::GrayImage, picture_m: f32) -> (World, Pose) {
    let mut world = World {
        name: "marker test room".into(),
        ..World::default()
    };
    let wall = world.add_material(Material {
        pattern: Pattern::Concrete,
        seed: 3,
        ..Material::plain("wall", [0.72, 0.7, 0.66])
    });
    let floor = world.add_material(Material {
        pattern: Pattern::Carpet,
        seed: 4,
        ..Material::plain("floor", [0.35, 0.33, 0.32])
    });
    let ceiling = world.add_material(Material {
        pattern: Pattern::Tiles { size: 0.6 },
        seed: 5,
        ..Material::plain("ceiling", [0.9, 0.9, 0.88])
    });
    let (x0, x1, y0, y1, h) = (-6.0f32, 6.0f32, 0.0f32, 14.0f32, 3.0f32);
    let p = Point3::new;
    // Each quad: corners counter-clockwise seen from inside the room.
    let quads = [
        (
            [p(x0, y1, 0.0), p(x1, y1, 0.0), p(x1, y1, h), p(x0, y1, h)],
            wall,
        ), // back
        (
            [p(x1, y0, 0.0), p(x0, y0, 0.0), p(x0, y0, h), p(x1, y0, h)],
            wall,
        ), // front
        (
            [p(x0, y0, 0.0), p(x0, y1, 0.0), p(x0, y1, h), p(x0, y0, h)],
            wall,
        ), // left
        (
            [p(x1, y1, 0.0), p(x1, y0, 0.0), p(x1, y0, h), p(x1, y1, h)],
            wall,
        ), // right
        (
            [
                p(x0, y0, 0.0),
                p(x1, y0, 0.0),
                p(x1, y1, 0.0),
                p(x0, y1, 0.0),
            ],
            floor,
        ),
        (
            [p(x0, y1, h), p(x1, y1, h), p(x1, y0, h), p(x0, y0, h)],
            ceiling,
        ),
    ];
    for (q, material) in quads {
        // uv in metres along the surface: u along the first edge, v along the last.
        let (eu, ev) = ((q[1] - q[0]).normalize(), (q[3] - q[0]).normalize());
        let uv = q.map(|c| [(c - q[0]).dot(&eu), (c - q[0]).dot(&ev)]);
        for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
            world.triangles.push(Triangle {
                v: [q[a], q[b], q[c]],
                uv: [uv[a], uv[b], uv[c]],
                material,
                plane: 0,
            });
        }
    }
    for (x, y) in [
        (-3.0, 4.0),
        (3.0, 4.0),
        (-3.0, 10.0),
        (3.0, 10.0),
        (0.0, 7.0),
    ] {
        world.lights.push(Light {
            position: p(x, y, h - 0.05),
            intensity: 0.8,
            on: true,
            fixture: None,
        });
    }
    // Marker frame: x right (seen from the room: world x), y up (world z), z into the room (-y).
    let (right, up) = (Vector3::x(), Vector3::z());
    let centre = p(0.0, y1 - 0.002, MARKER_HEIGHT_M);
    let rgb = image::DynamicImage::ImageLuma8(marker).to_rgb8();
    world.add_wall_picture(
        "aruco marker",
        Arc::new(rgb),
        centre,
        right,
        up,
        [picture_m; 2],
    );
    let rot = Matrix3::from_columns(&[
        right.cast::<f64>(),
        up.cast::<f64>(),
        right.cast::<f64>().cross(&up.cast::<f64>()),
    ]);
    let pose = Pose::from_rt(
        &rot,
        [0.0, f64::from(y1) - 0.002, f64::from(MARKER_HEIGHT_M)],
    )
    .expect("an orthonormal marker frame");
    (world, pose)
}

/// Medians over the frames of one cell.
fn summarise(resolution: &str, distance: f64, angle: f64, trials: &[Trial]) -> Row {
    let found: Vec<&Found> = trials.iter().filter_map(|t| t.found.as_ref()).collect();
    let med = |f: fn(&Found) -> f64| {
        crate::output::median(&found.iter().map(|x| f(x)).collect::<Vec<_>>())
    };
    let frac = |n: usize| {
        if trials.is_empty() {
            0.0
        } else {
            n as f64 / trials.len() as f64
        }
    };
    Row {
        resolution: resolution.to_string(),
        distance_m: distance,
        angle_deg: angle,
        detected: frac(found.len()),
        range_err_m: med(|f| f.range_err),
        range_bias_m: med(|f| f.range_bias),
        lateral_err_m: med(|f| f.lateral_err),
        pos_err_pct: med(|f| f.pos_err_pct),
        rot_err_deg: med(|f| f.rot_err_deg),
        ambiguous: if found.is_empty() {
            0.0
        } else {
            found.iter().filter(|f| f.ambiguous).count() as f64 / found.len() as f64
        },
        marker_px: med(|f| f.side_px),
    }
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Marker pose error against distance and viewing angle",
        [
            "camera",
            "distance (m)",
            "angle (°)",
            "detected",
            "marker (px)",
            "range err (m)",
            "range bias (m)",
            "lateral err (m)",
            "pos err (% dist)",
            "rot err (°)",
            "ambiguous",
        ],
    );
    for r in rows {
        t.push_row([
            r.resolution.clone(),
            format!("{:.1}", r.distance_m),
            format!("{:.0}", r.angle_deg),
            format!("{:.0} %", 100.0 * r.detected),
            format!("{:.0}", r.marker_px),
            format!("{:.4}", r.range_err_m),
            format!("{:+.4}", r.range_bias_m),
            format!("{:.4}", r.lateral_err_m),
            format!("{:.2}", r.pos_err_pct),
            format!("{:.2}", r.rot_err_deg),
            format!("{:.0} %", 100.0 * r.ambiguous),
        ]);
    }
    t
}

fn write_report(
    path: &std::path::Path,
    rows: &[Row],
    examples: &[Tile],
    args: &MarkersDistanceConfig,
    trials: usize,
) -> Result<()> {
    let mut page = HtmlReport::new("Marker pose against distance and viewing angle");
    page.paragraph(format!(
        "A {} m ArUco marker ({}) on the back wall of a rendered room, seen by a {HFOV_DEG}° \
         camera from each distance and angle ({trials} frames each, with random height and \
         aim offsets and sensor noise), each rendered at {ss}x{ss} samples per pixel and \
         averaged in linear light. Detection and IPPE pose run on the rendered frames as \
         on photos; errors are of the marker's position in the camera frame, medians over the \
         frames where the marker was found.",
        args.size,
        args.dict,
        ss = args.supersample
    ));
    page.table(&table(rows));
    let points: Vec<[f64; 2]> = rows
        .iter()
        .filter(|r| r.detected > 0.0 && r.resolution == rows[0].resolution)
        .map(|r| [r.distance_m, r.pos_err_pct])
        .collect();
    if points.len() >= 2 {
        let fig = report::scatter(
            &format!(
                "Position error against distance ({}, every angle)",
                rows[0].resolution
            ),
            "distance (m)",
            "median position error (% of distance)",
            &points,
        );
        page.figure(
            &fig,
            "One point per (distance, angle) cell, with the least-squares line.",
        )?;
    }
    if !examples.is_empty() {
        let sheet = report::contact_sheet("Example frames", examples, 4)?;
        page.png(
            &sheet,
            "The first frame of each cell at the first resolution.",
        );
    }
    page.write(path)?;
    Ok(())
}
