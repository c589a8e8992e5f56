//! Marker maps: where each marker hangs in the building, and the camera pose from every marker
//! in view.
//!
//! A map is a TOML file:
//!
//! ```toml
//! dictionary = "6x6_250"          # optional: the dictionary the ids belong to
//! [[markers]]
//! id = 3
//! size = 0.15                     # side of the black square, metres
//! position = [4.0, 1.2, 1.5]      # marker centre in the building frame, metres
//! quaternion = [0.5, 0.5, -0.5, -0.5]  # marker-to-building rotation (w, x, y, z)
//! ```
//!
//! The marker frame is OpenCV's: x right, y up, z out of the wall towards the viewer.
//!
//! Locating: every marker in view gives two camera poses (IPPE's pair); the hypothesis that the
//! most other markers agree with wins, so one wrong id (a misread or a moved marker) is outvoted
//! when two or more correct markers are in view; then all corners of the agreeing markers refine
//! one pose by Gauss-Newton, whose covariance gives the uncertainty.

use crate::error::MarkersError;
use crate::pose::{self, estimate_marker_pose, marker_corners_3d};
use crate::types::Marker;
use geom::{Camera, Pose};
use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// One marker of a map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapMarker {
    /// Dictionary id.
    pub id: u32,
    /// Side of the black square, metres.
    pub size: f64,
    /// Marker centre in the building frame, metres.
    pub position: [f64; 3],
    /// Marker-to-building rotation, quaternion (w, x, y, z).
    pub quaternion: [f64; 4],
}

impl MapMarker {
    /// The marker-to-building transform.
    pub fn pose(&self) -> Result<Pose, geom::GeomError> {
        Pose::from_t_wxyz(self.position, self.quaternion)
    }
}

/// Markers with known poses in a building.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerMap {
    /// The dictionary the ids belong to, when the map says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dictionary: Option<String>,
    /// The markers.
    #[serde(default)]
    pub markers: Vec<MapMarker>,
}

impl MarkerMap {
    /// Reads a TOML map; errors name the file and the problem (bad TOML, a repeated id, a size
    /// that is not positive, a quaternion of zero length).
    pub fn read(path: &Path) -> Result<Self, MarkersError> {
        let bad = |problem: String| MarkersError::Map {
            path: path.to_path_buf(),
            problem,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let map: MarkerMap = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        map.validate().map_err(bad)?;
        Ok(map)
    }

    /// Checks ids are unique, sizes positive and poses valid.
    pub fn validate(&self) -> Result<(), String> {
        let mut seen = std::collections::BTreeSet::new();
        for m in &self.markers {
            if !seen.insert(m.id) {
                return Err(format!("marker id {} appears twice", m.id));
            }
            if !(m.size > 0.0 && m.size.is_finite()) {
                return Err(format!(
                    "marker {}: size must be a positive number of metres",
                    m.id
                ));
            }
            m.pose().map_err(|e| format!("marker {}: {e}", m.id))?;
        }
        Ok(())
    }

    /// Writes the map as TOML, atomically.
    pub fn write(&self, path: &Path) -> Result<(), MarkersError> {
        let text = toml::to_string_pretty(self).map_err(|e| MarkersError::Map {
            path: path.to_path_buf(),
            problem: e.to_string(),
        })?;
        crate::io::write_atomic(path, text.as_bytes())
    }

    fn by_id(&self) -> BTreeMap<u32, &MapMarker> {
        self.markers.iter().map(|m| (m.id, m)).collect()
    }
}

/// The camera pose from the markers in one image.
#[derive(Clone, Debug, Serialize)]
pub struct Located {
    /// Camera-to-building pose.
    pub pose: Pose,
    /// `sqrt(trace(Σ_position))`, metres, from the Gauss-Newton covariance with the corner noise
    /// taken as the fit's RMS (at least 0.3 px).
    pub sigma_pos_m: f64,
    /// `sqrt(trace(Σ_rotation))`, degrees.
    pub sigma_rot_deg: f64,
    /// Ids of the markers whose corners made the pose.
    pub markers_used: Vec<u32>,
    /// Ids in the map that were seen but disagree with the others (wrong id or moved marker).
    pub markers_rejected: Vec<u32>,
    /// RMS reprojection error of the used corners, pixels.
    pub rms_px: f64,
    /// True when a single marker made the pose and its two IPPE poses fit about equally well.
    pub ambiguous: bool,
}

/// The camera pose from the `detected` markers that are in `map`; `None` when no map marker is
/// in view or no pose fits.
pub fn locate(detected: &[Marker], map: &MarkerMap, camera: &Camera) -> Option<Located> {
    let by_id = map.by_id();
    let seen: Vec<(&Marker, &MapMarker, [Point3<f64>; 4])> = detected
        .iter()
        .filter_map(|d| {
            let m = *by_id.get(&d.id)?;
            let pose = m.pose().ok()?;
            let world = marker_corners_3d(m.size).map(|p| pose.transform_point(&p));
            Some((d, m, world))
        })
        .collect();
    if seen.is_empty() {
        return None;
    }
    // Hypotheses: world-to-camera transforms from each marker's two IPPE poses.
    let mut hypotheses = Vec::new();
    let mut single_ambiguous = false;
    for (d, m, _) in &seen {
        let Some(mp) = estimate_marker_pose(d, m.size, camera) else {
            continue;
        };
        let marker_to_world = m.pose().ok()?;
        for cand in [&mp.best, &mp.second] {
            let camera_to_world = marker_to_world.compose(&cand.marker_in_camera.inverse());
            hypotheses.push(camera_to_world.inverse());
        }
        single_ambiguous |= mp.ambiguous;
    }
    let (best, _) = hypotheses
        .iter()
        .map(|h| {
            let (r, t) = (h.rotation_matrix(), Vector3::from(h.position()));
            let inliers = agreeing(&seen, camera, &r, &t);
            let err: f64 = inliers.iter().map(|(_, e)| e).sum();
            ((r, t), (inliers.len(), err))
        })
        .max_by(|a, b| a.1.0.cmp(&b.1.0).then(b.1.1.total_cmp(&a.1.1)))?;
    let (mut r, mut t) = best;
    let mut used = agreeing(&seen, camera, &r, &t);
    for _ in 0..2 {
        if used.is_empty() {
            return None;
        }
        let (object, normalized) = stack(&seen, &used, camera);
        (r, t) = pose::refine_pose(&object, &normalized, r, t, 30);
        let next = agreeing(&seen, camera, &r, &t);
        if next.iter().map(|u| u.0).eq(used.iter().map(|u| u.0)) {
            break;
        }
        used = next;
    }
    if used.is_empty() {
        return None;
    }
    let (object, normalized) = stack(&seen, &used, camera);
    let pixels: Vec<_> = used.iter().flat_map(|(i, _)| seen[*i].0.corners).collect();
    let rms_px = pose::reprojection_rms(camera, &object, &pixels, &r, &t)?;
    let (sigma_pos_m, sigma_rot_deg) = covariance(&object, &normalized, &r, &t, rms_px, camera);
    let world_to_camera = Pose::new(
        UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix(&r)),
        t,
    );
    let used_ids: Vec<u32> = used.iter().map(|(i, _)| seen[*i].0.id).collect();
    let rejected: Vec<u32> = (0..seen.len())
        .filter(|i| !used.iter().any(|u| u.0 == *i))
        .map(|i| seen[i].0.id)
        .collect();
    Some(Located {
        pose: world_to_camera.inverse(),
        sigma_pos_m,
        sigma_rot_deg,
        ambiguous: used_ids.len() == 1 && single_ambiguous,
        markers_used: used_ids,
        markers_rejected: rejected,
        rms_px,
    })
}

/// Indices (into `seen`) of the markers whose corners reproject within tolerance under the
/// world-to-camera transform `(r, t)`, with their mean corner error in pixels. The tolerance is
/// 3 px or a tenth of the marker's side in the image, whichever is larger.
fn agreeing(
    seen: &[(&Marker, &MapMarker, [Point3<f64>; 4])],
    camera: &Camera,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> Vec<(usize, f64)> {
    seen.iter()
        .enumerate()
        .filter_map(|(i, (d, _, world))| {
            let mut err = 0.0;
            for (w, px) in world.iter().zip(&d.corners) {
                let proj = camera.project(&Point3::from(r * w.coords + t))?;
                err += (proj - px).norm() / 4.0;
            }
            let side = (d.corners[1] - d.corners[0]).norm();
            (err <= (0.1 * side).max(3.0)).then_some((i, err))
        })
        .collect()
}

/// World corners and their normalised image points for the markers in `used`.
fn stack(
    seen: &[(&Marker, &MapMarker, [Point3<f64>; 4])],
    used: &[(usize, f64)],
    camera: &Camera,
) -> (Vec<Point3<f64>>, Vec<Vector2<f64>>) {
    used.iter()
        .flat_map(|(i, _)| {
            let (d, _, world) = &seen[*i];
            world
                .iter()
                .zip(&d.corners)
                .map(|(w, px)| (*w, camera.normalized(px)))
        })
        .unzip()
}

/// Position and rotation sigmas of the camera from the Gauss-Newton normal equations.
fn covariance(
    object: &[Point3<f64>],
    normalized: &[Vector2<f64>],
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    rms_px: f64,
    camera: &Camera,
) -> (f64, f64) {
    let (jtj, _) = pose::normal_equations(object, normalized, r, t);
    let sigma_n = rms_px.max(0.3) / (0.5 * (camera.fx + camera.fy));
    let Some(inv) = jtj.try_inverse() else {
        return (f64::INFINITY, f64::INFINITY);
    };
    let cov = inv * sigma_n * sigma_n;
    // Camera centre c = -Rᵀ t; under R ← exp(ω) R, t ← t + δ: dc/dω = -Rᵀ[t]×, dc/dδ = -Rᵀ.
    let mut jc = nalgebra::Matrix3x6::zeros();
    jc.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-r.transpose() * t.cross_matrix()));
    jc.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-r.transpose()));
    let cov_c = jc * cov * jc.transpose();
    let rot = cov.fixed_view::<3, 3>(0, 0).trace();
    (
        cov_c.trace().max(0.0).sqrt(),
        rot.max(0.0).sqrt().to_degrees(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::tests::camera;

    /// Three markers on a wall at y = 3 facing -y (towards a camera at the origin looking +y).
    fn wall_map() -> MarkerMap {
        // marker x → world x, marker y (up) → world z, marker z (out of the wall) → world -y.
        let r = Matrix3::from_columns(&[Vector3::x(), Vector3::z(), -Vector3::y()]);
        let q = UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix(&r));
        let wxyz = [q.w, q.i, q.j, q.k];
        let markers = [(1, -0.6), (2, 0.0), (3, 0.6)]
            .into_iter()
            .map(|(id, x)| MapMarker {
                id,
                size: 0.2,
                position: [x, 3.0, 0.1],
                quaternion: wxyz,
            })
            .collect();
        MarkerMap {
            dictionary: Some("4x4_50".into()),
            markers,
        }
    }

    /// Camera at `c` looking along +y (OpenCV axes: x right = world x, y down = world -z).
    fn camera_pose(c: [f64; 3]) -> Pose {
        let r = Matrix3::from_columns(&[Vector3::x(), -Vector3::z(), Vector3::y()]);
        Pose::from_rt(&r, c).unwrap()
    }

    fn observe(map: &MarkerMap, cam: &Camera, pose: &Pose) -> Vec<Marker> {
        map.markers
            .iter()
            .map(|m| {
                let mp = m.pose().unwrap();
                let corners = marker_corners_3d(m.size)
                    .map(|p| cam.project_world(pose, &mp.transform_point(&p)).unwrap());
                Marker { id: m.id, corners }
            })
            .collect()
    }

    #[test]
    fn locates_the_camera_from_three_markers() {
        let (map, cam) = (wall_map(), camera());
        let truth = camera_pose([0.3, 0.2, 0.0]);
        let located = locate(&observe(&map, &cam, &truth), &map, &cam).unwrap();
        let err = (Vector3::from(located.pose.position()) - Vector3::from(truth.position())).norm();
        assert!(err < 1e-6, "position error {err}");
        assert_eq!(located.markers_used, vec![1, 2, 3]);
        assert!(
            located.sigma_pos_m > 0.0 && located.sigma_pos_m < 0.2,
            "{located:?}"
        );
    }

    #[test]
    fn one_wrong_id_is_outvoted() {
        let (map, cam) = (wall_map(), camera());
        let truth = camera_pose([-0.2, 0.0, 0.1]);
        let mut seen = observe(&map, &cam, &truth);
        // Marker 3 is misread as marker 1's neighbour on the other side: swap two ids.
        seen[2].id = 1;
        seen[0].id = 3;
        seen.push(observe(&map, &cam, &truth)[1].clone());
        let located = locate(&seen, &map, &cam).unwrap();
        let err = (Vector3::from(located.pose.position()) - Vector3::from(truth.position())).norm();
        assert!(err < 1e-6, "position error {err}");
        assert_eq!(located.markers_used, vec![2, 2]);
        assert_eq!(located.markers_rejected, vec![3, 1]);
    }

    #[test]
    fn no_map_marker_in_view_gives_none() {
        let (map, cam) = (wall_map(), camera());
        let mut seen = observe(&map, &cam, &camera_pose([0.0, 0.0, 0.0]));
        for m in &mut seen {
            m.id += 100;
        }
        assert!(locate(&seen, &map, &cam).is_none());
    }

    #[test]
    fn map_round_trips_and_bad_maps_name_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.toml");
        let map = wall_map();
        map.write(&path).unwrap();
        assert_eq!(MarkerMap::read(&path).unwrap(), map);
        std::fs::write(
            &path,
            "[[markers]]\nid = 1\nsize = -1\nposition = [0,0,0]\nquaternion = [1,0,0,0]\n",
        )
        .unwrap();
        let err = MarkerMap::read(&path).unwrap_err().to_string();
        assert!(err.contains("map.toml") && err.contains("size"), "{err}");
    }
}
