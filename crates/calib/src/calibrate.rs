//! Camera calibration from several views of a planar board.

use crate::error::{CalibError, Result};
use crate::lm::{self, Free, N_INTR, Params, View};
use crate::zhang;
use geom::{Camera, Distortion, Pose};
use nalgebra::{Matrix3, Point2, Rotation3, UnitQuaternion, Vector2, Vector3};

/// A chessboard target: inner corners and square size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Board {
    /// Inner corners along a row (OpenCV's pattern width, e.g. 9).
    pub cols: usize,
    /// Rows of inner corners (e.g. 6).
    pub rows: usize,
    /// Side of a square, metres (any unit works; the poses come out in it).
    pub square: f64,
}

impl Board {
    /// A board of `cols x rows` inner corners and squares of `square` metres.
    pub fn new(cols: usize, rows: usize, square: f64) -> Self {
        Self { cols, rows, square }
    }

    /// Board-frame points of the corners in [`crate::find_chessboard`]'s order:
    /// corner `i` is `(i % cols, i / cols, 0) * square`.
    pub fn object_points(&self) -> Vec<Vector3<f64>> {
        (0..self.cols * self.rows)
            .map(|i| {
                Vector3::new(
                    (i % self.cols) as f64 * self.square,
                    (i / self.cols) as f64 * self.square,
                    0.0,
                )
            })
            .collect()
    }
}

/// Calibration options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibOptions {
    /// Keep `k3` at zero (OpenCV's `CALIB_FIX_K3`). Default false: all five coefficients.
    pub fix_k3: bool,
    /// Keep `p1 = p2 = 0` (OpenCV's `CALIB_ZERO_TANGENT_DIST`). Default false.
    pub zero_tangent: bool,
    /// Drop views whose RMS is far above the rest and solve again. Default true.
    pub reject_outliers: bool,
    /// A view is dropped when its RMS exceeds this multiple of the median view RMS ...
    pub reject_factor: f64,
    /// ... and this many pixels.
    pub reject_min_px: f64,
    /// Levenberg-Marquardt iterations at most.
    pub max_iterations: usize,
}

impl Default for CalibOptions {
    fn default() -> Self {
        Self {
            fix_k3: false,
            zero_tangent: false,
            reject_outliers: true,
            reject_factor: 5.0,
            reject_min_px: 2.0,
            max_iterations: 200,
        }
    }
}

/// A board pose, OpenCV's `rvec` / `tvec`: `p_cam = R(rvec) · p_board + tvec`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPose {
    /// Rodrigues rotation vector (axis times angle, radians), board to camera.
    pub rvec: Vector3<f64>,
    /// Translation, board to camera, in the board's unit.
    pub tvec: Vector3<f64>,
}

impl BoardPose {
    /// The rotation matrix of `rvec`.
    pub fn rotation(&self) -> Matrix3<f64> {
        *Rotation3::from_scaled_axis(self.rvec).matrix()
    }

    /// The camera's pose in the board frame (camera-to-board, the project's pose convention;
    /// its translation is the camera centre in board coordinates).
    pub fn camera_in_board(&self) -> Pose {
        let q = UnitQuaternion::from_scaled_axis(self.rvec);
        Pose::new(q, self.tvec).inverse()
    }
}

/// The result of [`calibrate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// Intrinsics, distortion and image size.
    pub camera: Camera,
    /// RMS reprojection error over all points of the used views (OpenCV's figure), pixels.
    pub rms: f64,
    /// RMS reprojection error of each input view, pixels. A dropped view's figure is with the
    /// final camera and its own pose refitted to it.
    pub per_view_rms: Vec<f64>,
    /// Whether each input view was kept (false: dropped as an outlier).
    pub used: Vec<bool>,
    /// Board pose of each input view (dropped views too, fitted to the final camera);
    /// `None` only when a dropped view could not be fitted.
    pub poses: Vec<Option<BoardPose>>,
}

/// Calibrates a camera from views of a planar [`Board`].
///
/// `views[k]` holds the image corners of view `k` in [`crate::find_chessboard`]'s order
/// (`board.cols * board.rows` points). Zhang's closed form (normalised-DLT homographies,
/// zero skew) gives the start; Levenberg-Marquardt then refines fx, fy, cx, cy, k1, k2, p1,
/// p2, k3 and every view's pose against the reprojection error. With
/// [`CalibOptions::reject_outliers`], views whose RMS is above `reject_factor` times the
/// median and above `reject_min_px` are dropped and the rest solved again.
///
/// # Errors
/// [`CalibError::TooFewViews`] below 3 views (or below 3 left after rejection is not allowed:
/// rejection then keeps all views), [`CalibError::PointCount`] for a view of the wrong size,
/// [`CalibError::Degenerate`] for a bad board or image size, non-finite or collinear points,
/// or a solve that breaks down.
pub fn calibrate(
    views: &[Vec<Point2<f64>>],
    board: &Board,
    width: u32,
    height: u32,
    opts: &CalibOptions,
) -> Result<Calibration> {
    let degenerate = |reason: String| CalibError::Degenerate { reason };
    if board.cols < 2 || board.rows < 2 || !(board.square.is_finite() && board.square > 0.0) {
        return Err(degenerate(format!(
            "board {}x{} with square {}",
            board.cols, board.rows, board.square
        )));
    }
    if width == 0 || height == 0 {
        return Err(degenerate(format!("image size {width}x{height}")));
    }
    if views.len() < 3 {
        return Err(CalibError::TooFewViews {
            needed: 3,
            got: views.len(),
        });
    }
    let expected = board.cols * board.rows;
    for (k, v) in views.iter().enumerate() {
        if v.len() != expected {
            return Err(CalibError::PointCount {
                view: k,
                got: v.len(),
                cols: board.cols,
                rows: board.rows,
                expected,
            });
        }
        if !v.iter().all(|p| p.x.is_finite() && p.y.is_finite()) {
            return Err(degenerate(format!("view {k} has non-finite points")));
        }
    }
    let obj = board.object_points();
    let obj2: Vec<Vector2<f64>> = obj.iter().map(|p| p.xy()).collect();
    let mut homographies = Vec::with_capacity(views.len());
    for (k, v) in views.iter().enumerate() {
        homographies.push(zhang::homography(&obj2, v).ok_or_else(|| {
            degenerate(format!(
                "view {k}: no homography (corners collinear or repeated)"
            ))
        })?);
    }
    let (w, h) = (width as f64, height as f64);
    let k0 = zhang::intrinsics(&homographies, w, h).ok_or_else(|| {
        degenerate("no plausible intrinsics from the views (all boards parallel?)".into())
    })?;
    let kmat = k0.k();
    let mut poses = Vec::with_capacity(views.len());
    for (k, hm) in homographies.iter().enumerate() {
        poses.push(
            zhang::pose_from_homography(hm, &kmat)
                .ok_or_else(|| degenerate(format!("view {k}: no pose from its homography")))?,
        );
    }
    // parallel boards (all views alike) leave the focal length open
    let normals: Vec<Vector3<f64>> = poses
        .iter()
        .map(|(r, _)| Rotation3::from_scaled_axis(*r) * Vector3::z())
        .collect();
    let spread = normals
        .iter()
        .flat_map(|a| normals.iter().map(move |b| a.angle(b)))
        .fold(0.0, f64::max);
    if spread < 2f64.to_radians() {
        return Err(degenerate(format!(
            "the board's orientation hardly changes between views ({:.2} deg at most); tilt it",
            spread.to_degrees()
        )));
    }
    let mut free = Free {
        intrinsics: [true; N_INTR],
    };
    if opts.zero_tangent {
        free.intrinsics[6] = false;
        free.intrinsics[7] = false;
    }
    if opts.fix_k3 {
        free.intrinsics[8] = false;
    }
    let mut params = Params {
        intr: [k0.fx, k0.fy, k0.cx, k0.cy, 0.0, 0.0, 0.0, 0.0, 0.0],
        poses,
    };
    let all: Vec<View> = views
        .iter()
        .map(|v| View {
            obj: &obj,
            img: v.as_slice(),
        })
        .collect();
    // poses first with the start intrinsics fixed, then everything
    let poses_only = Free {
        intrinsics: [false; N_INTR],
    };
    lm::refine(&mut params, &all, &poses_only, 20)
        .ok_or_else(|| degenerate("pose refinement broke down".into()))?;
    lm::refine(&mut params, &all, &free, opts.max_iterations)
        .ok_or_else(|| degenerate("Levenberg-Marquardt broke down".into()))?;

    let n = expected as f64;
    let rms_of =
        |p: &Params, k: usize, i: usize| (lm::view_sse(&p.intr, &p.poses[i], &all[k]) / n).sqrt();
    let mut used = vec![true; views.len()];
    if opts.reject_outliers {
        let errs: Vec<f64> = (0..views.len()).map(|k| rms_of(&params, k, k)).collect();
        let mut sorted = errs.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let bad: Vec<bool> = errs
            .iter()
            .map(|&e| e > opts.reject_factor * median && e > opts.reject_min_px)
            .collect();
        let kept = bad.iter().filter(|b| !**b).count();
        if kept >= 3 && kept < views.len() {
            used = bad.iter().map(|b| !b).collect();
            let kept_views: Vec<View> = all
                .iter()
                .zip(&used)
                .filter(|(_, u)| **u)
                .map(|(v, _)| View {
                    obj: v.obj,
                    img: v.img,
                })
                .collect();
            let mut sub = Params {
                intr: params.intr,
                poses: params
                    .poses
                    .iter()
                    .zip(&used)
                    .filter(|(_, u)| **u)
                    .map(|(p, _)| *p)
                    .collect(),
            };
            lm::refine(&mut sub, &kept_views, &free, opts.max_iterations)
                .ok_or_else(|| degenerate("Levenberg-Marquardt broke down".into()))?;
            // refit the dropped views' poses to the final intrinsics
            let mut it = sub.poses.into_iter();
            for (k, u) in used.iter().enumerate() {
                if *u {
                    params.poses[k] = it.next().expect("one pose per kept view");
                } else {
                    let mut one = Params {
                        intr: sub.intr,
                        poses: vec![params.poses[k]],
                    };
                    let view = [View {
                        obj: &obj,
                        img: views[k].as_slice(),
                    }];
                    if lm::refine(&mut one, &view, &poses_only, 50).is_some() {
                        params.poses[k] = one.poses[0];
                    }
                }
            }
            params.intr = sub.intr;
        }
    }
    let per_view_rms: Vec<f64> = (0..views.len()).map(|k| rms_of(&params, k, k)).collect();
    let (mut sse, mut count) = (0.0, 0.0);
    for (k, u) in used.iter().enumerate() {
        if *u {
            sse += per_view_rms[k].powi(2) * n;
            count += n;
        }
    }
    let rms = (sse / count).sqrt();
    if !rms.is_finite() {
        return Err(degenerate("reprojection error is not finite".into()));
    }
    let [fx, fy, cx, cy, k1, k2, p1, p2, k3] = params.intr;
    let camera = Camera::new(
        width,
        height,
        fx,
        fy,
        cx,
        cy,
        Distortion::from_array([k1, k2, p1, p2, k3]),
    )?;
    let poses = params
        .poses
        .iter()
        .zip(&per_view_rms)
        .map(|(&(rvec, tvec), e)| e.is_finite().then_some(BoardPose { rvec, tvec }))
        .collect();
    Ok(Calibration {
        camera,
        rms,
        per_view_rms,
        used,
        poses,
    })
}
