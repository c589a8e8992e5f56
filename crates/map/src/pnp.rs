//! Camera pose from 2-D–3-D correspondences: P3P inside RANSAC, then Levenberg-Marquardt on
//! the reprojection error of the inliers, with the pose's covariance from that last step.
//!
//! # P3P
//! Grunert's formulation (Haralick et al., IJCV 1994, "Review and analysis of solutions of the
//! three point perspective pose estimation problem"): with the distances along the three rays
//! `s2 = u s1`, `s3 = v s1`, the law of cosines on the three sides gives `u` as a rational
//! function of `v` and a quartic in `v`. Its coefficients are made here by multiplying the
//! small polynomials the derivation names (no transcribed closed forms to get wrong), its real
//! roots are the eigenvalues of the companion matrix polished by Newton's method, and each root
//! gives the points in the camera frame, from which the rotation and translation follow by the
//! SVD alignment of two point triples (Kabsch). Up to four poses per triple.
//!
//! # Why written here
//! The Rust P3P crates (`lambda-twist`, `p3p`) are archived since 2020, under MPL-2.0, and
//! pinned to nalgebra versions five years old; no maintained crate solves PnP with RANSAC. The
//! whole solver is some 300 lines on nalgebra, checked below against poses it must recover.

use geom::{Camera, Pose};
use nalgebra::{Matrix3, Matrix4, Matrix6, Rotation3, UnitQuaternion, Vector2, Vector3, Vector6};
use rand::{Rng, SeedableRng};

/// A pixel of the query and the world point it sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correspondence {
    /// The point in world coordinates, metres.
    pub world: Vector3<f64>,
    /// Its pixel in the query (undistorted), pixels.
    pub pixel: Vector2<f64>,
    /// The pixel's standard error, pixels (a keypoint found on a coarser pyramid level is
    /// placed less precisely): its residual is divided by it in the refinement.
    pub sigma_px: f64,
}

/// Settings of [`solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PnpConfig {
    /// Reprojection error of an inlier, pixels.
    pub threshold_px: f64,
    /// Most RANSAC samples.
    pub max_iterations: usize,
    /// Stop sampling when a better set would have been found with this probability.
    pub confidence: f64,
    /// Seed of the sampling (a fixed seed makes a query's answer reproducible).
    pub seed: u64,
    /// Where the camera is known to be, roughly: hypotheses whose centre lies outside this
    /// ball are not scored. In a building whose parts look alike (a corridor's repeated bays,
    /// tiled textures), a pose one repetition away fits the matches almost as well as the true
    /// one; a coarse pose better than half a repetition picks the right one.
    pub prior: Option<Prior>,
}

/// A ball the camera centre lies in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// Its centre, world metres.
    pub centre: Vector3<f64>,
    /// Its radius, metres.
    pub radius_m: f64,
}

impl Default for PnpConfig {
    /// 4 px (as `sift_pnp.py` runs OpenCV), up to 2000 samples, 99.9 % confidence.
    fn default() -> Self {
        PnpConfig {
            threshold_px: 4.0,
            max_iterations: 2000,
            confidence: 0.999,
            seed: 0x5eed,
            prior: None,
        }
    }
}

/// World-to-camera rotation and translation: `p_cam = r * p_world + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldToCamera {
    /// Rotation.
    pub r: Matrix3<f64>,
    /// Translation.
    pub t: Vector3<f64>,
}

impl WorldToCamera {
    /// The camera-to-world pose.
    pub fn to_pose(&self) -> Pose {
        let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            self.r.transpose(),
        ));
        Pose::new(rot, -(self.r.transpose() * self.t))
    }

    /// The camera centre in the world.
    pub fn centre(&self) -> Vector3<f64> {
        -(self.r.transpose() * self.t)
    }

    /// The world-to-camera transform of a camera-to-world pose.
    pub fn of_pose(pose: &Pose) -> WorldToCamera {
        let r = pose.rotation_matrix().transpose();
        let c = Vector3::from(pose.position());
        WorldToCamera { r, t: -(r * c) }
    }

    /// The pixel a world point projects to, when it lies in front of the camera.
    fn project(&self, camera: &Camera, x: &Vector3<f64>) -> Option<Vector2<f64>> {
        let p = self.r * x + self.t;
        (p.z > 1e-6).then(|| {
            Vector2::new(
                camera.fx * p.x / p.z + camera.cx,
                camera.fy * p.y / p.z + camera.cy,
            )
        })
    }
}

/// What [`solve`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct PnpSolution {
    /// The camera pose.
    pub pose: WorldToCamera,
    /// Indices of the inlier correspondences.
    pub inliers: Vec<usize>,
    /// Covariance of the camera centre, m² (from the last refinement's Jacobian).
    pub cov_pos_m2: Matrix3<f64>,
    /// Covariance of the rotation (a small rotation vector in the camera frame), rad².
    pub cov_rot_rad2: Matrix3<f64>,
    /// RMS reprojection error of the inliers, in their standard errors (pixels at full
    /// resolution).
    pub rms_px: f64,
}

/// The camera pose that sees the most correspondences within the threshold (see the module
/// docs), refined on its inliers; `None` with fewer than four correspondences or no pose.
pub fn solve(camera: &Camera, corr: &[Correspondence], cfg: &PnpConfig) -> Option<PnpSolution> {
    if corr.len() < 4 {
        return None;
    }
    let bearings: Vec<Vector3<f64>> = corr
        .iter()
        .map(|c| {
            Vector3::new(
                (c.pixel.x - camera.cx) / camera.fx,
                (c.pixel.y - camera.cy) / camera.fy,
                1.0,
            )
            .normalize()
        })
        .collect();
    let thr2 = cfg.threshold_px * cfg.threshold_px;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(cfg.seed);
    let n = corr.len();
    let mut best: Option<(WorldToCamera, usize)> = None;
    let mut needed = cfg.max_iterations;
    let mut iteration = 0;
    while iteration < needed.min(cfg.max_iterations) {
        iteration += 1;
        let i = rng.random_range(0..n);
        let j = rng.random_range(0..n);
        let k = rng.random_range(0..n);
        if i == j || j == k || i == k {
            continue;
        }
        let sample = [i, j, k];
        for hyp in p3p(sample.map(|s| bearings[s]), sample.map(|s| corr[s].world)) {
            if let Some(p) = &cfg.prior
                && (hyp.centre() - p.centre).norm() > p.radius_m
            {
                continue;
            }
            let bar = best.map_or(0, |b| b.1);
            let count = count_inliers(camera, corr, &hyp, thr2, bar);
            if count > bar {
                best = Some((hyp, count));
                let w = count as f64 / n as f64;
                needed = iterations_for(w, cfg.confidence);
            }
        }
    }
    let (mut pose, _) = best?;
    let mut inliers = inliers_of(camera, corr, &pose, thr2);
    // Refine, take the inliers of the refined pose, refine again on them.
    for _ in 0..2 {
        if inliers.len() < 4 {
            return None;
        }
        pose = refine(camera, corr, &inliers, pose);
        inliers = inliers_of(camera, corr, &pose, thr2);
    }
    if inliers.len() < 4 {
        return None;
    }
    let (cov_rot_rad2, cov_pos_m2, rms_px) = covariance(camera, corr, &inliers, &pose)?;
    Some(PnpSolution {
        pose,
        inliers,
        cov_pos_m2,
        cov_rot_rad2,
        rms_px,
    })
}

/// RANSAC samples needed to draw an all-inlier triple with probability `confidence` when a
/// fraction `w` are inliers.
fn iterations_for(w: f64, confidence: f64) -> usize {
    let p_good = w.powi(3).clamp(1e-12, 1.0 - 1e-12);
    ((1.0 - confidence).ln() / (1.0 - p_good).ln())
        .ceil()
        .max(1.0) as usize
}

/// Inliers of a pose, stopping early once it cannot beat `bar`.
fn count_inliers(
    camera: &Camera,
    corr: &[Correspondence],
    pose: &WorldToCamera,
    thr2: f64,
    bar: usize,
) -> usize {
    let n = corr.len();
    let mut count = 0;
    for (i, c) in corr.iter().enumerate() {
        if pose
            .project(camera, &c.world)
            .is_some_and(|p| (p - c.pixel).norm_squared() < thr2)
        {
            count += 1;
        } else if count + (n - i - 1) <= bar {
            return count;
        }
    }
    count
}

fn inliers_of(
    camera: &Camera,
    corr: &[Correspondence],
    pose: &WorldToCamera,
    thr2: f64,
) -> Vec<usize> {
    corr.iter()
        .enumerate()
        .filter(|(_, c)| {
            pose.project(camera, &c.world)
                .is_some_and(|p| (p - c.pixel).norm_squared() < thr2)
        })
        .map(|(i, _)| i)
        .collect()
}

/// Polynomial product (coefficients by rising power).
fn mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Polynomial sum of scaled terms.
fn add(terms: &[(f64, Vec<f64>)]) -> Vec<f64> {
    let len = terms.iter().map(|t| t.1.len()).max().unwrap_or(0);
    let mut out = vec![0.0; len];
    for (s, p) in terms {
        for (i, c) in p.iter().enumerate() {
            out[i] += s * c;
        }
    }
    out
}

fn eval(p: &[f64], x: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, c| acc * x + c)
}

/// Real roots of a polynomial of degree ≤ 4 (companion-matrix eigenvalues, Newton-polished).
fn real_roots(p: &[f64]) -> Vec<f64> {
    let scale = p.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if scale == 0.0 {
        return Vec::new();
    }
    let mut deg = p.len() - 1;
    while deg > 0 && p[deg].abs() < 1e-12 * scale {
        deg -= 1;
    }
    let roots: Vec<f64> = match deg {
        0 => Vec::new(),
        1 => vec![-p[0] / p[1]],
        _ => {
            // Companion matrix padded to 4x4 with zero roots that are then dropped.
            let mut m = Matrix4::<f64>::zeros();
            for i in 1..deg {
                m[(i, i - 1)] = 1.0;
            }
            for i in 0..deg {
                m[(i, deg - 1)] = -p[i] / p[deg];
            }
            let ev = m.complex_eigenvalues();
            ev.iter()
                .take(4)
                .filter(|z| z.im.abs() < 1e-6 * (1.0 + z.re.abs()))
                .map(|z| z.re)
                .collect()
        }
    };
    let dp: Vec<f64> = p
        .iter()
        .enumerate()
        .skip(1)
        .map(|(i, c)| i as f64 * c)
        .collect();
    roots
        .into_iter()
        .map(|mut x| {
            for _ in 0..3 {
                let d = eval(&dp, x);
                if d.abs() > 1e-14 {
                    x -= eval(p, x) / d;
                }
            }
            x
        })
        .collect()
}

/// The world-to-camera poses that put three world points on three unit bearings (see the module
/// docs): none, or up to four.
pub fn p3p(f: [Vector3<f64>; 3], x: [Vector3<f64>; 3]) -> Vec<WorldToCamera> {
    let a2 = (x[1] - x[2]).norm_squared();
    let b2 = (x[0] - x[2]).norm_squared();
    let c2 = (x[0] - x[1]).norm_squared();
    if a2 < 1e-12 || b2 < 1e-12 || c2 < 1e-12 {
        return Vec::new();
    }
    let (ca, cb, cg) = (f[1].dot(&f[2]), f[0].dot(&f[2]), f[0].dot(&f[1]));
    let (k1, k2) = (c2 / b2, a2 / b2);
    let dk = k2 - k1;
    // u = N(v) / D(v); then D² + N² − 2cγ N D − K1 Q D² = 0 with Q = 1 − 2cβ v + v².
    let n = vec![dk + 1.0, -2.0 * cb * dk, dk - 1.0];
    let d = vec![2.0 * cg, -2.0 * ca];
    let q = vec![1.0, -2.0 * cb, 1.0];
    let dd = mul(&d, &d);
    let quartic = add(&[
        (1.0, dd.clone()),
        (1.0, mul(&n, &n)),
        (-2.0 * cg, mul(&n, &d)),
        (-k1, mul(&q, &dd)),
    ]);
    let mut out = Vec::new();
    for v in real_roots(&quartic) {
        let dv = eval(&d, v);
        let qv = eval(&q, v);
        if v <= 0.0 || dv.abs() < 1e-12 || qv <= 0.0 {
            continue;
        }
        let u = eval(&n, v) / dv;
        if u <= 0.0 {
            continue;
        }
        let s1 = (b2 / qv).sqrt();
        let p = [f[0] * s1, f[1] * (u * s1), f[2] * (v * s1)];
        if let Some(pose) = align(&x, &p) {
            out.push(pose);
        }
    }
    out
}

/// The rotation and translation taking three world points onto three camera points (Kabsch).
fn align(x: &[Vector3<f64>; 3], p: &[Vector3<f64>; 3]) -> Option<WorldToCamera> {
    let xc = (x[0] + x[1] + x[2]) / 3.0;
    let pc = (p[0] + p[1] + p[2]) / 3.0;
    let mut h = Matrix3::zeros();
    for i in 0..3 {
        h += (x[i] - xc) * (p[i] - pc).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut r = vt.transpose() * u.transpose();
    if r.determinant() < 0.0 {
        let mut fix = Matrix3::identity();
        fix[(2, 2)] = -1.0;
        r = vt.transpose() * fix * u.transpose();
    }
    let t = pc - r * xc;
    Some(WorldToCamera { r, t })
}

/// Huber threshold of the refinement, pixels.
const HUBER_PX: f64 = 1.5;

/// One correspondence linearised: its residual (pixels) and the two Jacobian rows.
type Linearized = ([f64; 2], [[f64; 6]; 2]);

/// Residuals (2 per correspondence) and their Jacobian rows with respect to a small rotation
/// (left-multiplied, camera frame) and a shift of the camera centre, for the listed
/// correspondences; `None` when a point falls behind the camera.
fn linearize(
    camera: &Camera,
    corr: &[Correspondence],
    idx: &[usize],
    pose: &WorldToCamera,
) -> Option<Vec<Linearized>> {
    let r = pose.r;
    idx.iter()
        .map(|&i| {
            let c = &corr[i];
            let p = r * c.world + pose.t;
            if p.z <= 1e-6 {
                return None;
            }
            let (iz, iz2) = (1.0 / p.z, 1.0 / (p.z * p.z));
            let du = Vector3::new(camera.fx * iz, 0.0, -camera.fx * p.x * iz2);
            let dv = Vector3::new(0.0, camera.fy * iz, -camera.fy * p.y * iz2);
            let w = 1.0 / c.sigma_px;
            let res = [
                w * (camera.fx * p.x * iz + camera.cx - c.pixel.x),
                w * (camera.fy * p.y * iz + camera.cy - c.pixel.y),
            ];
            // dp/dθ = −[p]×, dp/dC = −R.
            let skew = p.cross_matrix();
            let row = |g: Vector3<f64>| {
                let a = -(g.transpose() * skew) * w;
                let b = -(g.transpose() * r) * w;
                [a[0], a[1], a[2], b[0], b[1], b[2]]
            };
            Some((res, [row(du), row(dv)]))
        })
        .collect()
}

/// The pose after a step: rotation `exp(θ) R`, camera centre `C + δc`.
fn step(pose: &WorldToCamera, delta: &Vector6<f64>) -> WorldToCamera {
    let rot = Rotation3::new(Vector3::new(delta[0], delta[1], delta[2]));
    let c = -(pose.r.transpose() * pose.t) + Vector3::new(delta[3], delta[4], delta[5]);
    let r = rot.matrix() * pose.r;
    WorldToCamera { r, t: -(r * c) }
}

fn huber_cost(lin: &[Linearized]) -> f64 {
    lin.iter()
        .map(|(res, _)| {
            let e = (res[0] * res[0] + res[1] * res[1]).sqrt();
            if e <= HUBER_PX {
                0.5 * e * e
            } else {
                HUBER_PX * (e - 0.5 * HUBER_PX)
            }
        })
        .sum()
}

/// Levenberg-Marquardt on the Huber-weighted reprojection error of the listed correspondences.
fn refine(
    camera: &Camera,
    corr: &[Correspondence],
    idx: &[usize],
    start: WorldToCamera,
) -> WorldToCamera {
    let mut pose = start;
    let Some(mut lin) = linearize(camera, corr, idx, &pose) else {
        return pose;
    };
    let mut cost = huber_cost(&lin);
    let mut lambda = 1e-3;
    for _ in 0..15 {
        let mut jtj = Matrix6::<f64>::zeros();
        let mut jtr = Vector6::<f64>::zeros();
        for (res, rows) in &lin {
            let e = (res[0] * res[0] + res[1] * res[1]).sqrt();
            let w = if e <= HUBER_PX { 1.0 } else { HUBER_PX / e };
            for (k, row) in rows.iter().enumerate() {
                let j = Vector6::from_row_slice(row);
                jtj += w * j * j.transpose();
                jtr += w * j * res[k];
            }
        }
        let mut improved = false;
        for _ in 0..5 {
            let mut a = jtj;
            for d in 0..6 {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-9);
            }
            let Some(delta) = a.cholesky().map(|c| c.solve(&(-jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let trial = step(&pose, &delta);
            if let Some(tl) = linearize(camera, corr, idx, &trial) {
                let tc = huber_cost(&tl);
                if tc < cost {
                    let done = (cost - tc) < 1e-10 * cost.max(1e-12) || delta.norm() < 1e-10;
                    pose = trial;
                    lin = tl;
                    cost = tc;
                    lambda = (lambda * 0.3).max(1e-9);
                    improved = !done;
                    break;
                }
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    pose
}

/// Covariance of the rotation (rad²) and of the camera centre (m²) at a refined pose:
/// `σ² (JᵀJ)⁻¹`, σ² the residuals' variance per coordinate (2n − 6 degrees of freedom); and the
/// RMS reprojection error.
fn covariance(
    camera: &Camera,
    corr: &[Correspondence],
    idx: &[usize],
    pose: &WorldToCamera,
) -> Option<(Matrix3<f64>, Matrix3<f64>, f64)> {
    let lin = linearize(camera, corr, idx, pose)?;
    let mut jtj = Matrix6::<f64>::zeros();
    let mut sum2 = 0.0;
    for (res, rows) in &lin {
        sum2 += res[0] * res[0] + res[1] * res[1];
        for row in rows {
            let j = Vector6::from_row_slice(row);
            jtj += j * j.transpose();
        }
    }
    let dof = (2 * idx.len()).saturating_sub(6).max(1) as f64;
    let sigma2 = sum2 / dof;
    let inv = jtj.try_inverse()? * sigma2;
    let rms = (sum2 / idx.len() as f64).sqrt();
    Some((
        inv.fixed_view::<3, 3>(0, 0).into_owned(),
        inv.fixed_view::<3, 3>(3, 3).into_owned(),
        rms,
    ))
}

#[cfg(test)]
mod tests;
