//! Pinhole camera with OpenCV's radial/tangential distortion (`k1, k2, p1, p2, k3`).

use crate::error::{GeomError, Result};
use crate::pose::Pose;
use nalgebra::{Matrix2, Point2, Point3, Vector2};
use serde::{Deserialize, Serialize};

/// OpenCV's five-parameter lens distortion, applied to normalised image coordinates
/// `(x, y) = (X/Z, Y/Z)`:
/// `x' = x(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²)`,
/// `y' = y(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Distortion {
    /// Radial r² coefficient.
    pub k1: f64,
    /// Radial r⁴ coefficient.
    pub k2: f64,
    /// Tangential coefficient 1.
    pub p1: f64,
    /// Tangential coefficient 2.
    pub p2: f64,
    /// Radial r⁶ coefficient.
    pub k3: f64,
}

impl Distortion {
    /// From `[k1, k2, p1, p2, k3]`, OpenCV's order.
    pub fn from_array(d: [f64; 5]) -> Self {
        let [k1, k2, p1, p2, k3] = d;
        Self { k1, k2, p1, p2, k3 }
    }

    /// `[k1, k2, p1, p2, k3]`, OpenCV's order.
    pub fn to_array(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// True when the lens has no distortion.
    pub fn is_zero(&self) -> bool {
        self.to_array().iter().all(|&c| c == 0.0)
    }

    /// Distorts normalised coordinates.
    pub fn apply(&self, p: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian of [`Distortion::apply`] at `p`.
    fn jacobian(&self, p: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let dxx = radial + x * d_radial * 2.0 * x + 2.0 * self.p1 * y + self.p2 * 6.0 * x;
        let dxy = x * d_radial * 2.0 * y + 2.0 * self.p1 * x + self.p2 * 2.0 * y;
        let dyx = y * d_radial * 2.0 * x + self.p1 * 2.0 * x + 2.0 * self.p2 * y;
        let dyy = radial + y * d_radial * 2.0 * y + self.p1 * 6.0 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxx, dxy, dyx, dyy)
    }

    /// Inverts [`Distortion::apply`] by Gauss-Newton from the distorted point (converges in a
    /// few steps for real lenses; OpenCV's fixed-point iteration needs more and stops short
    /// at the image corners of wide lenses).
    pub fn remove(&self, distorted: Vector2<f64>) -> Vector2<f64> {
        if self.is_zero() {
            return distorted;
        }
        let mut p = distorted;
        for _ in 0..30 {
            let residual = self.apply(p) - distorted;
            if residual.norm() < 1e-14 {
                break;
            }
            match self.jacobian(p).try_inverse() {
                Some(j_inv) => p -= j_inv * residual,
                None => break,
            }
        }
        p
    }
}

/// A camera: image size, pinhole intrinsics (pixels) and lens distortion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (OpenCV: pixel centres at integer coordinates).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Lens distortion.
    #[serde(default)]
    pub dist: Distortion,
}

impl Camera {
    /// A validated camera: positive size and focal lengths, finite numbers.
    pub fn new(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        dist: Distortion,
    ) -> Result<Self> {
        let cam = Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            dist,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// Checks the invariants [`Camera::new`] promises (for cameras read with serde).
    pub fn validate(&self) -> Result<()> {
        let numbers = [self.fx, self.fy, self.cx, self.cy];
        if !numbers
            .iter()
            .chain(self.dist.to_array().iter())
            .all(|v| v.is_finite())
        {
            return Err(GeomError::NonFinite { what: "camera" });
        }
        if self.width == 0 || self.height == 0 {
            return Err(GeomError::BadCamera {
                reason: format!("image size {}x{}", self.width, self.height),
            });
        }
        if self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(GeomError::BadCamera {
                reason: format!("focal lengths fx={} fy={} must be > 0", self.fx, self.fy),
            });
        }
        Ok(())
    }

    /// A pinhole camera with its principal point at the image centre and a horizontal field of
    /// view in radians.
    pub fn from_hfov(width: u32, height: u32, hfov: f64) -> Result<Self> {
        let f = width as f64 / 2.0 / (hfov / 2.0).tan();
        Self::new(
            width,
            height,
            f,
            f,
            (width as f64 - 1.0) / 2.0,
            (height as f64 - 1.0) / 2.0,
            Distortion::default(),
        )
    }

    /// Horizontal field of view, radians (of the pinhole part).
    pub fn hfov(&self) -> f64 {
        2.0 * (self.width as f64 / 2.0 / self.fx).atan()
    }

    /// The same camera for an image resized to `width` x `height` (OpenCV's pixel-centre rule:
    /// `c' = (c + 0.5)·s − 0.5`).
    pub fn resized(&self, width: u32, height: u32) -> Camera {
        let sx = width as f64 / self.width as f64;
        let sy = height as f64 / self.height as f64;
        Camera {
            width,
            height,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: (self.cx + 0.5) * sx - 0.5,
            cy: (self.cy + 0.5) * sy - 0.5,
            dist: self.dist,
        }
    }

    /// Pixel of a point in camera coordinates; `None` behind the camera (z ≤ 0).
    pub fn project(&self, p_cam: &Point3<f64>) -> Option<Point2<f64>> {
        if p_cam.z <= 0.0 {
            return None;
        }
        let d = self
            .dist
            .apply(Vector2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z));
        Some(Point2::new(
            self.fx * d.x + self.cx,
            self.fy * d.y + self.cy,
        ))
    }

    /// Pixel of a world point seen by a camera at `pose` (camera-to-world).
    pub fn project_world(&self, pose: &Pose, p_world: &Point3<f64>) -> Option<Point2<f64>> {
        self.project(&pose.inverse().transform_point(p_world))
    }

    /// Undistorted normalised coordinates `(X/Z, Y/Z)` of a pixel.
    pub fn normalized(&self, pixel: &Point2<f64>) -> Vector2<f64> {
        let d = Vector2::new((pixel.x - self.cx) / self.fx, (pixel.y - self.cy) / self.fy);
        self.dist.remove(d)
    }

    /// The camera-frame point at depth `z` (along the optical axis, metres) seen at `pixel`.
    pub fn unproject(&self, pixel: &Point2<f64>, z: f64) -> Point3<f64> {
        let n = self.normalized(pixel);
        Point3::new(n.x * z, n.y * z, z)
    }

    /// Where `pixel` would be for the same camera without lens distortion.
    pub fn undistort_pixel(&self, pixel: &Point2<f64>) -> Point2<f64> {
        let n = self.normalized(pixel);
        Point2::new(self.fx * n.x + self.cx, self.fy * n.y + self.cy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fox() -> Result<Camera> {
        // The phone camera of ../shared/data/fox_posed (transforms.json), a real lens.
        Camera::new(
            1080,
            1920,
            1375.52,
            1374.49,
            554.558,
            965.268,
            Distortion::from_array([0.0578421, -0.0805099, -0.000980296, 0.00015575, 0.0]),
        )
    }

    #[test]
    fn project_hand_checked() -> Result<()> {
        let cam = Camera::new(640, 480, 500.0, 500.0, 320.0, 240.0, Distortion::default())?;
        let px = cam
            .project(&Point3::new(1.0, -0.5, 2.0))
            .ok_or(GeomError::BadInput("behind".into()))?;
        assert!((px.x - 570.0).abs() < 1e-12 && (px.y - 115.0).abs() < 1e-12);
        assert!(cam.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
        Ok(())
    }

    #[test]
    fn unproject_inverts_project_with_distortion() -> Result<()> {
        let cam = fox()?;
        for &(u, v) in &[
            (0.0, 0.0),
            (1079.0, 1919.0),
            (554.0, 965.0),
            (100.0, 1800.0),
        ] {
            let p = cam.unproject(&Point2::new(u, v), 3.0);
            let back = cam
                .project(&p)
                .ok_or(GeomError::BadInput("behind".into()))?;
            assert!(
                (back.x - u).abs() < 1e-8 && (back.y - v).abs() < 1e-8,
                "{u},{v} -> {back}"
            );
        }
        Ok(())
    }

    #[test]
    fn distortion_hand_checked() {
        // k1 = 0.1 only: (0.5, 0) -> 0.5 (1 + 0.1 · 0.25) = 0.5125
        let d = Distortion {
            k1: 0.1,
            ..Default::default()
        };
        let v = d.apply(Vector2::new(0.5, 0.0));
        assert!((v.x - 0.5125).abs() < 1e-15 && v.y == 0.0);
        let back = d.remove(v);
        assert!((back.x - 0.5).abs() < 1e-13);
    }

    #[test]
    fn resize_and_validation() -> Result<()> {
        let cam = Camera::from_hfov(640, 480, 60f64.to_radians())?;
        assert!((cam.hfov() - 60f64.to_radians()).abs() < 1e-12);
        let half = cam.resized(320, 240);
        assert!((half.fx - cam.fx / 2.0).abs() < 1e-12);
        assert!((half.cx - 159.5).abs() < 1e-12);
        assert!(Camera::new(0, 480, 1.0, 1.0, 0.0, 0.0, Distortion::default()).is_err());
        assert!(Camera::new(10, 10, -1.0, 1.0, 0.0, 0.0, Distortion::default()).is_err());
        Ok(())
    }

    #[test]
    fn world_projection_uses_camera_to_world() -> Result<()> {
        let cam = Camera::new(640, 480, 500.0, 500.0, 320.0, 240.0, Distortion::default())?;
        let pose = Pose::from_t_wxyz([0.0, 0.0, -5.0], [1.0, 0.0, 0.0, 0.0])?;
        let px = cam
            .project_world(&pose, &Point3::new(0.0, 0.0, 0.0))
            .ok_or(GeomError::BadInput("behind".into()))?;
        assert!((px.x - 320.0).abs() < 1e-12 && (px.y - 240.0).abs() < 1e-12);
        Ok(())
    }
}
