//! Camera calibration: checkerboard corners, Zhang's method refined by Levenberg-Marquardt,
//! OpenCV-compatible YAML.
//!
//! # Entry points
//! - [`find_chessboard`]: the inner corners of a `cols x rows` chessboard in a gray image,
//!   sub-pixel refined ([`refine_corners`], OpenCV's `cornerSubPix`).
//! - [`calibrate`]: intrinsics and lens distortion from several views of a [`Board`]
//!   (Zhang's closed form, then Levenberg-Marquardt over all parameters, bad views dropped).
//! - [`write_opencv_yaml`] / [`read_camera_yaml`]: OpenCV `FileStorage` YAML.
//!
//! # Conventions
//! - Pixel `(0, 0)` is the centre of the top-left pixel (OpenCV).
//! - Corners are row-major, `cols` per row; corner `i` is the board point
//!   `(i % cols, i / cols, 0) * square` (metres), as OpenCV's calibration samples.
//! - Board poses are OpenCV's `rvec` / `tvec`: board-to-camera, `p_cam = R(rvec) p_board + tvec`.
#![deny(missing_docs)]

mod calibrate;
mod chessboard;
mod error;
mod lm;
mod subpix;
mod yaml;
mod zhang;

pub use calibrate::{Board, BoardPose, CalibOptions, Calibration, calibrate};
pub use chessboard::find_chessboard;
pub use error::{CalibError, Result};
pub use subpix::refine_corners;
pub use yaml::{read_camera_yaml, write_opencv_yaml};
