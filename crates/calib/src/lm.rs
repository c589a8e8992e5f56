//! Levenberg-Marquardt refinement of intrinsics, distortion and board poses, minimising the
//! reprojection error. Analytic Jacobian; rotations are updated multiplicatively
//! (`R ← exp(δ) R`) and stored as Rodrigues vectors. The normal equations are dense
//! (`9 + 6 · views` unknowns, small for calibration) and solved by Cholesky.

use nalgebra::{
    DMatrix, DVector, Matrix2, Matrix2x3, Matrix3, Point2, Rotation3, Vector2, Vector3,
};

/// Number of intrinsic parameters: fx, fy, cx, cy, k1, k2, p1, p2, k3.
pub(crate) const N_INTR: usize = 9;

/// Which intrinsic parameters the solver may change.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Free {
    pub intrinsics: [bool; N_INTR],
}

/// The parameters being refined.
#[derive(Clone, Debug)]
pub(crate) struct Params {
    /// fx, fy, cx, cy, k1, k2, p1, p2, k3.
    pub intr: [f64; N_INTR],
    /// Per view: Rodrigues rotation and translation (board to camera).
    pub poses: Vec<(Vector3<f64>, Vector3<f64>)>,
}

/// One view's data: board points and observed image points.
pub(crate) struct View<'a> {
    pub obj: &'a [Vector3<f64>],
    pub img: &'a [Point2<f64>],
}

struct Projection {
    uv: Vector2<f64>,
    /// d(u, v) / d(intrinsics)
    d_intr: [[f64; N_INTR]; 2],
    /// d(u, v) / d(camera point)
    d_pc: Matrix2x3<f64>,
}

/// Projects camera-frame point `pc` with intrinsics `a`; `None` behind the camera.
fn project(a: &[f64; N_INTR], pc: &Vector3<f64>) -> Option<Projection> {
    let [fx, fy, cx, cy, k1, k2, p1, p2, k3] = *a;
    if pc.z <= 1e-12 {
        return None;
    }
    let iz = 1.0 / pc.z;
    let x = pc.x * iz;
    let y = pc.y * iz;
    let r2 = x * x + y * y;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let radial = 1.0 + k1 * r2 + k2 * r4 + k3 * r6;
    let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    let uv = Vector2::new(fx * xd + cx, fy * yd + cy);
    let d_intr = [
        [
            xd,
            0.0,
            1.0,
            0.0,
            fx * x * r2,
            fx * x * r4,
            fx * 2.0 * x * y,
            fx * (r2 + 2.0 * x * x),
            fx * x * r6,
        ],
        [
            0.0,
            yd,
            0.0,
            1.0,
            fy * y * r2,
            fy * y * r4,
            fy * (r2 + 2.0 * y * y),
            fy * 2.0 * x * y,
            fy * y * r6,
        ],
    ];
    // distortion Jacobian d(xd, yd)/d(x, y)
    let d_radial = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r4; // d radial / d r2
    let dxx = radial + x * d_radial * 2.0 * x + 2.0 * p1 * y + 6.0 * p2 * x;
    let dxy = x * d_radial * 2.0 * y + 2.0 * p1 * x + 2.0 * p2 * y;
    let dyx = y * d_radial * 2.0 * x + 2.0 * p1 * x + 2.0 * p2 * y;
    let dyy = radial + y * d_radial * 2.0 * y + 6.0 * p1 * y + 2.0 * p2 * x;
    let dd = Matrix2::new(fx * dxx, fx * dxy, fy * dyx, fy * dyy);
    let dn = Matrix2x3::new(iz, 0.0, -x * iz, 0.0, iz, -y * iz);
    Some(Projection {
        uv,
        d_intr,
        d_pc: dd * dn,
    })
}

/// Reprojected image points of a view.
pub(crate) fn reproject(
    a: &[f64; N_INTR],
    pose: &(Vector3<f64>, Vector3<f64>),
    obj: &[Vector3<f64>],
) -> Vec<Option<Vector2<f64>>> {
    let r = Rotation3::from_scaled_axis(pose.0);
    obj.iter()
        .map(|x| project(a, &(r * x + pose.1)).map(|p| p.uv))
        .collect()
}

/// Sum of squared reprojection errors of one view (infinite when a point is behind the camera).
pub(crate) fn view_sse(a: &[f64; N_INTR], pose: &(Vector3<f64>, Vector3<f64>), v: &View) -> f64 {
    reproject(a, pose, v.obj)
        .iter()
        .zip(v.img)
        .map(|(p, q)| match p {
            Some(p) => (p - q.coords).norm_squared(),
            None => f64::INFINITY,
        })
        .sum()
}

fn total_sse(p: &Params, views: &[View]) -> f64 {
    views
        .iter()
        .zip(&p.poses)
        .map(|(v, pose)| view_sse(&p.intr, pose, v))
        .sum()
}

/// Refines `p` in place and returns the final sum of squared errors; `None` when a point falls behind a camera or the start is invalid.
pub(crate) fn refine(p: &mut Params, views: &[View], free: &Free, max_iters: usize) -> Option<f64> {
    let nv = views.len();
    let n = N_INTR + 6 * nv;
    let mut cost = total_sse(p, views);
    if !cost.is_finite() {
        return None;
    }
    let mut lambda = 1e-3;
    for _ in 0..max_iters {
        // normal equations
        let mut jtj = DMatrix::<f64>::zeros(n, n);
        let mut jtr = DVector::<f64>::zeros(n);
        for (vi, (view, pose)) in views.iter().zip(&p.poses).enumerate() {
            let rot = Rotation3::from_scaled_axis(pose.0);
            let base = N_INTR + 6 * vi;
            let mut jv = [[0.0f64; N_INTR + 6]; 2];
            for (x, q) in view.obj.iter().zip(view.img) {
                let rx = rot * x;
                let pc = rx + pose.1;
                let pr = project(&p.intr, &pc)?;
                let res = pr.uv - q.coords;
                // d pc / d delta (left perturbation) = -[rx]_x ; d pc / d t = I
                let skew = Matrix3::new(0.0, -rx.z, rx.y, rx.z, 0.0, -rx.x, -rx.y, rx.x, 0.0);
                let d_rot = pr.d_pc * (-skew);
                for r in 0..2 {
                    jv[r][..N_INTR].copy_from_slice(&pr.d_intr[r]);
                    for c in 0..3 {
                        jv[r][N_INTR + c] = d_rot[(r, c)];
                        jv[r][N_INTR + 3 + c] = pr.d_pc[(r, c)];
                    }
                }
                let idx = |c: usize| if c < N_INTR { c } else { base + c - N_INTR };
                for r in 0..2 {
                    for c1 in 0..N_INTR + 6 {
                        let j1 = jv[r][c1];
                        if j1 == 0.0 {
                            continue;
                        }
                        jtr[idx(c1)] += j1 * res[r];
                        for c2 in c1..N_INTR + 6 {
                            jtj[(idx(c1), idx(c2))] += j1 * jv[r][c2];
                        }
                    }
                }
            }
        }
        // symmetrise (only the upper part of each block was filled in index order)
        for i in 0..n {
            for j in 0..i {
                let s = jtj[(i, j)] + jtj[(j, i)];
                jtj[(i, j)] = s;
                jtj[(j, i)] = s;
            }
        }
        // fixed parameters
        for (i, &f) in free.intrinsics.iter().enumerate() {
            if !f {
                for j in 0..n {
                    jtj[(i, j)] = 0.0;
                    jtj[(j, i)] = 0.0;
                }
                jtj[(i, i)] = 1.0;
                jtr[i] = 0.0;
            }
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(chol) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let delta = chol.solve(&(-&jtr));
            let mut trial = p.clone();
            for i in 0..N_INTR {
                trial.intr[i] += delta[i];
            }
            for (vi, pose) in trial.poses.iter_mut().enumerate() {
                let b = N_INTR + 6 * vi;
                let dr = Vector3::new(delta[b], delta[b + 1], delta[b + 2]);
                let r = Rotation3::from_scaled_axis(dr) * Rotation3::from_scaled_axis(pose.0);
                pose.0 = r.scaled_axis();
                pose.1 += Vector3::new(delta[b + 3], delta[b + 4], delta[b + 5]);
            }
            let trial_cost = total_sse(&trial, views);
            if trial_cost.is_finite() && trial_cost < cost {
                let rel = (cost - trial_cost) / cost.max(1e-300);
                *p = trial;
                cost = trial_cost;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                if rel < 1e-12 || delta.norm() < 1e-12 {
                    return Some(cost);
                }
                break;
            }
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
        }
        if !improved {
            break;
        }
    }
    Some(cost)
}
