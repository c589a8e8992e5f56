//! Depth images of posed datasets: how they relate to the colour camera, and lifting a colour
//! pixel to 3-D with them (the keyframe map's keypoints, the scan fusion's frames).
//!
//! A depth image may come from a camera other than the colour one. 7-Scenes' Kinect depth is not
//! registered to its colour (depth f = 585, colour f = 525, both centred): the two are taken to
//! share an optical centre and axes, so a colour pixel's ray meets the depth image at the same
//! normalised coordinates (what `sift_pnp.py` and the 7-Scenes literature assume). Where the
//! depth around that spot varies (a corner on an object's silhouette, where the two cameras'
//! small offset and the sensor's blur mix foreground and background), the point is left out:
//! corners often lie on such edges, and a point lifted from the wrong side of one is an outlier
//! that looks like an inlier from nearby viewpoints.

use crate::posed::{Layout, PosedDataset};
use crate::{DataError, Result};
use geom::{Camera, Pose};
use image::ImageBuffer;
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// A 16-bit depth image.
pub type DepthImage = ImageBuffer<image::Luma<u16>, Vec<u16>>;

/// How a dataset's depth images relate to its colour images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthModel {
    /// Intrinsics of the depth image (sharing the colour camera's centre and axes).
    pub camera: Camera,
    /// Metres per depth unit (millimetres: 0.001; TUM: 1/5000).
    pub metres_per_unit: f64,
    /// Nearest usable depth, metres.
    pub min_m: f64,
    /// Farthest usable depth, metres.
    pub max_m: f64,
    /// Largest depth step within the 3x3 neighbourhood of a lifted point, as a fraction of its
    /// depth (with a 1 cm floor).
    pub max_step: f64,
}

impl DepthModel {
    /// The depth model of a dataset's layout, its colour camera given: 7-Scenes' unregistered
    /// Kinect depth (f = 585 at the colour image's size, millimetres), TUM's registered depth
    /// (1/5000 m), and registered millimetres for the rest (indoorloc's rendered depth).
    pub fn for_dataset(ds: &PosedDataset, colour: &Camera) -> DepthModel {
        let (camera, metres_per_unit) = match ds.layout {
            Layout::SevenScenes => {
                let s = f64::from(colour.width) / 640.0;
                let mut depth = *colour;
                depth.fx = 585.0 * s;
                depth.fy = 585.0 * s;
                (depth, 0.001)
            }
            Layout::Tum => (*colour, 1.0 / 5000.0),
            _ => (*colour, 0.001),
        };
        DepthModel {
            camera,
            metres_per_unit,
            min_m: 0.1,
            max_m: 8.0,
            max_step: 0.02,
        }
    }

    /// The world point a colour pixel sees (colour camera `colour`, mapped frame at `pose`),
    /// or `None` where the depth is missing, out of range or uneven around the spot.
    pub fn lift(
        &self,
        depth: &DepthImage,
        colour: &Camera,
        pose: &Pose,
        u: f64,
        v: f64,
    ) -> Option<Point3<f64>> {
        let (xn, yn) = ((u - colour.cx) / colour.fx, (v - colour.cy) / colour.fy);
        let ud = (self.camera.cx + self.camera.fx * xn).round() as i64;
        let vd = (self.camera.cy + self.camera.fy * yn).round() as i64;
        let (w, h) = (i64::from(depth.width()), i64::from(depth.height()));
        if ud < 1 || vd < 1 || ud >= w - 1 || vd >= h - 1 {
            return None;
        }
        let at = |x: i64, y: i64| depth.as_raw()[(y * w + x) as usize];
        let raw = at(ud, vd);
        if raw == 0 || raw == u16::MAX {
            return None;
        }
        let z = f64::from(raw) * self.metres_per_unit;
        if !(self.min_m..=self.max_m).contains(&z) {
            return None;
        }
        let tolerance = (self.max_step * z).max(0.01);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let n = at(ud + dx, vd + dy);
                if n == 0 || n == u16::MAX {
                    return None;
                }
                if (f64::from(n) * self.metres_per_unit - z).abs() > tolerance {
                    return None;
                }
            }
        }
        Some(pose.transform_point(&Point3::from(Vector3::new(xn * z, yn * z, z))))
    }
}

/// Reads a 16-bit depth PNG; errors name the file.
pub fn read_depth(path: &Path) -> Result<DepthImage> {
    let img = crate::frames::decode_image(path)?;
    match img {
        image::DynamicImage::ImageLuma16(d) => Ok(d),
        other => Err(DataError::Invalid {
            path: path.to_path_buf(),
            msg: format!(
                "a depth image must be 16-bit grey, this one is {:?}",
                other.color()
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            width: 64,
            height: 48,
            fx: 50.0,
            fy: 50.0,
            cx: 32.0,
            cy: 24.0,
            dist: Default::default(),
        }
    }

    fn model() -> DepthModel {
        DepthModel {
            camera: cam(),
            metres_per_unit: 0.001,
            min_m: 0.1,
            max_m: 8.0,
            max_step: 0.02,
        }
    }

    #[test]
    fn a_pixel_is_lifted_along_its_ray_and_edges_are_refused() {
        let mut depth = DepthImage::from_pixel(64, 48, image::Luma([2000]));
        // A step to 3 m right of column 40.
        for y in 0..48 {
            for x in 40..64 {
                depth.put_pixel(x, y, image::Luma([3000]));
            }
        }
        let pose = Pose::from_t_wxyz([1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
        let p = model().lift(&depth, &cam(), &pose, 42.0, 24.0).unwrap();
        assert!(
            (p - Point3::new(1.0 + 0.2 * 3.0, 0.0, 3.0)).norm() < 1e-9,
            "{p}"
        );
        // At the step, and at the border, nothing.
        assert!(model().lift(&depth, &cam(), &pose, 40.0, 24.0).is_none());
        assert!(model().lift(&depth, &cam(), &pose, 0.0, 24.0).is_none());
        depth.put_pixel(20, 20, image::Luma([0]));
        assert!(model().lift(&depth, &cam(), &pose, 21.0, 21.0).is_none());
    }

    #[test]
    fn an_unregistered_depth_camera_is_looked_up_at_the_same_ray() {
        // Depth camera with a longer focal length: the colour ray at x_n = 0.2 meets it at
        // 32 + 60 * 0.2 = 44.
        let mut m = model();
        m.camera.fx = 60.0;
        m.camera.fy = 60.0;
        let mut depth = DepthImage::from_pixel(64, 48, image::Luma([1000]));
        for y in 0..48 {
            for x in 43..46 {
                depth.put_pixel(x, y, image::Luma([1500]));
            }
        }
        // Colour pixel 42 → x_n 0.2 → depth pixel 44: 1.5 m, with an even 3x3 around it.
        let p = m
            .lift(&depth, &cam(), &Pose::identity(), 42.0, 24.0)
            .unwrap();
        assert!((p.z - 1.5).abs() < 1e-9 && (p.x - 0.3).abs() < 1e-9, "{p}");
    }
}
