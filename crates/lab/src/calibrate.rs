//! `indoorloc calibrate`: camera intrinsics and lens distortion from photos of a checkerboard,
//! written as OpenCV YAML that every `--camera` option reads.

use crate::output::{print_json, print_text};
use crate::{Context, Result, ensure};
use calib::{Board, CalibOptions};
use clap::Args;
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `indoorloc calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateConfig {
    /// Photos of the board (PNG, JPEG, BMP), all from the same camera at the same size.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// Inner corners of the board, COLSxROWS (a board of 10x7 squares has 9x6).
    #[arg(long, value_parser = crate::parse::size, default_value = "9x6")]
    board: (u32, u32),
    /// Side of one square, metres (poses come out in the same unit).
    #[arg(long, default_value_t = 0.025)]
    square: f64,
    /// Where to write the camera (OpenCV YAML: camera_matrix, distortion_coefficients).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Fit k3 too (OpenCV's default); without it k3 stays 0, safer for few or central views.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    k3: bool,
    /// Keep every view, even one whose reprojection error is far above the rest.
    #[arg(long)]
    keep_all: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One photo in the output.
#[derive(Debug, Serialize)]
struct ViewOut {
    image: PathBuf,
    found: bool,
    /// Kept for the final fit (false: no board, or dropped as an outlier).
    used: bool,
    rms_px: Option<f64>,
}

/// What `calibrate` prints.
#[derive(Debug, Serialize)]
struct CalibrateOutput {
    rms: f64,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    /// k1, k2, p1, p2, k3.
    dist: [f64; 5],
    width: u32,
    height: u32,
    /// Photos used in the final fit.
    used: usize,
    views: Vec<ViewOut>,
    out: PathBuf,
}

/// A photo read: its file, its size and the board corners found in it.
type Photo = (PathBuf, (u32, u32), Option<Vec<nalgebra::Point2<f64>>>);

/// Runs `indoorloc calibrate`.
pub fn run(args: &CalibrateConfig, sink: &mut dyn crate::Output) -> Result<()> {
    ensure!(
        args.square > 0.0 && args.square.is_finite(),
        "--square must be a positive length in metres"
    );
    let (cols, rows) = (args.board.0 as usize, args.board.1 as usize);
    ensure!(
        cols >= 3 && rows >= 3,
        "--board {cols}x{rows}: at least 3x3 inner corners"
    );
    let pb = crate::progress::bar(args.images.len() as u64, "images");
    let found: Vec<Photo> = args
        .images
        .par_iter()
        .map(|path| {
            let gray = markers::load_gray(path)?;
            let corners = calib::find_chessboard(&gray, cols, rows);
            pb.inc(1);
            Ok((path.clone(), gray.dimensions(), corners))
        })
        .collect::<Result<_>>()?;
    pb.finish_and_clear();
    let (width, height) = found[0].1;
    if let Some((p, d, _)) = found.iter().find(|(_, d, _)| *d != (width, height)) {
        crate::bail!(
            "{}: {}x{} pixels, but {} is {width}x{height}; calibrate one camera at one size",
            p.display(),
            d.0,
            d.1,
            found[0].0.display()
        );
    }
    let with_board: Vec<usize> = (0..found.len()).filter(|&i| found[i].2.is_some()).collect();
    ensure!(
        with_board.len() >= 3,
        "the {cols}x{rows} board was found in {} of {} images; calibration needs at least 3",
        with_board.len(),
        found.len()
    );
    let views: Vec<Vec<nalgebra::Point2<f64>>> = with_board
        .iter()
        .map(|&i| found[i].2.clone().unwrap_or_default())
        .collect();
    let opts = CalibOptions {
        fix_k3: !args.k3,
        reject_outliers: !args.keep_all,
        ..CalibOptions::default()
    };
    let board = Board::new(cols, rows, args.square);
    let cal = calib::calibrate(&views, &board, width, height, &opts)?;
    cal.write_opencv_yaml(&args.out)
        .with_context(|| format!("{}: cannot write the camera", args.out.display()))?;
    let mut view_out: Vec<ViewOut> = found
        .iter()
        .map(|(p, _, c)| ViewOut {
            image: p.clone(),
            found: c.is_some(),
            used: false,
            rms_px: None,
        })
        .collect();
    for (k, &i) in with_board.iter().enumerate() {
        view_out[i].used = cal.used[k];
        view_out[i].rms_px = Some(cal.per_view_rms[k]);
    }
    let c = &cal.camera;
    let out = CalibrateOutput {
        rms: cal.rms,
        fx: c.fx,
        fy: c.fy,
        cx: c.cx,
        cy: c.cy,
        dist: c.dist.to_array(),
        width,
        height,
        used: cal.used.iter().filter(|u| **u).count(),
        views: view_out,
        out: args.out.clone(),
    };
    if args.json {
        return print_json(sink, &out);
    }
    let mut t = report::Table::new("Calibration views", ["image", "board", "used", "rms (px)"]);
    for v in &out.views {
        t.push_row([
            v.image.display().to_string(),
            if v.found { "found" } else { "not found" }.to_string(),
            if v.used { "yes" } else { "no" }.to_string(),
            v.rms_px.map_or("-".into(), |r| format!("{r:.3}")),
        ]);
    }
    print_text(
        sink,
        &format!(
            "{}rms {:.4} px over {} views; fx {:.3} fy {:.3} cx {:.3} cy {:.3}; k1 {:.5} k2 {:.5} p1 {:.6} p2 {:.6} k3 {:.5}\nwritten: {}\n",
            t.to_text(),
            out.rms,
            out.used,
            out.fx,
            out.fy,
            out.cx,
            out.cy,
            out.dist[0],
            out.dist[1],
            out.dist[2],
            out.dist[3],
            out.dist[4],
            out.out.display()
        ),
    )
}
