//! Zhang's closed-form initialisation: a homography per view (normalised DLT), intrinsics from
//! the constraints on `B = K⁻ᵀ K⁻¹` with zero skew, and each view's pose from its homography.

use nalgebra::{DMatrix, Matrix3, Point2, Rotation3, Vector2, Vector3};

/// Pinhole intrinsics without distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Intrinsics {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

impl Intrinsics {
    pub fn k(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    fn valid(&self, width: f64, height: f64) -> bool {
        [self.fx, self.fy, self.cx, self.cy]
            .iter()
            .all(|v| v.is_finite())
            && self.fx > 0.0
            && self.fy > 0.0
            && self.cx > 0.0
            && self.cx < width
            && self.cy > 0.0
            && self.cy < height
            && (self.fx / self.fy) > 0.2
            && (self.fx / self.fy) < 5.0
    }
}

/// Similarity that moves points to zero mean and mean distance √2.
fn normaliser(pts: impl Iterator<Item = Vector2<f64>> + Clone) -> Option<Matrix3<f64>> {
    let n = pts.clone().count() as f64;
    let mean = pts.clone().fold(Vector2::zeros(), |a, p| a + p) / n;
    let dist = pts.map(|p| (p - mean).norm()).sum::<f64>() / n;
    if !(dist.is_finite() && dist > 1e-12) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / dist;
    Some(Matrix3::new(
        s,
        0.0,
        -s * mean.x,
        0.0,
        s,
        -s * mean.y,
        0.0,
        0.0,
        1.0,
    ))
}

/// Homography mapping board points `(X, Y)` to image points, by the normalised DLT.
/// `None` when the points are degenerate (collinear, repeated, non-finite).
pub(crate) fn homography(obj: &[Vector2<f64>], img: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let n = obj.len();
    if n < 4 || img.len() != n {
        return None;
    }
    let t_obj = normaliser(obj.iter().copied())?;
    let t_img = normaliser(img.iter().map(|p| p.coords))?;
    let mut a = DMatrix::<f64>::zeros(2 * n, 9);
    for k in 0..n {
        let o = t_obj * Vector3::new(obj[k].x, obj[k].y, 1.0);
        let i = t_img * Vector3::new(img[k].x, img[k].y, 1.0);
        let (x, y) = (o.x / o.z, o.y / o.z);
        let (u, v) = (i.x / i.z, i.y / i.z);
        let r0 = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u];
        let r1 = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v];
        for c in 0..9 {
            a[(2 * k, c)] = r0[c];
            a[(2 * k + 1, c)] = r1[c];
        }
    }
    let h = smallest_right_singular(&a)?;
    // the second smallest singular value must be clearly non-zero (else degenerate)
    let hn = Matrix3::from_row_slice(h.as_slice());
    let t_img_inv = t_img.try_inverse()?;
    let mut hm = t_img_inv * hn * t_obj;
    let scale = hm[(2, 2)];
    if scale.abs() > 1e-12 {
        hm /= scale;
    }
    if !hm.iter().all(|v| v.is_finite()) {
        return None;
    }
    // collinear points: rank of the 3x3 map drops
    let svd = hm.svd(false, false);
    let sv = svd.singular_values;
    if sv.min() < 1e-9 * sv.max() {
        return None;
    }
    Some(hm)
}

/// The right singular vector of the smallest singular value (via the eigenvectors of AᵀA).
/// `None` when the null space is more than one-dimensional.
fn smallest_right_singular(a: &DMatrix<f64>) -> Option<nalgebra::DVector<f64>> {
    let ata = a.transpose() * a;
    let eig = nalgebra::SymmetricEigen::new(ata);
    let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let (smallest, second) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    let largest = eig.eigenvalues[order[order.len() - 1]];
    if largest.is_nan() || largest <= 0.0 || second <= 1e-14 * largest || !smallest.is_finite() {
        return None;
    }
    Some(eig.eigenvectors.column(order[0]).into_owned())
}

/// Zhang's closed form with zero skew; the principal point at the image centre with focal
/// lengths by least squares (OpenCV's initialisation) when the closed form is not plausible.
pub(crate) fn intrinsics(hs: &[Matrix3<f64>], width: f64, height: f64) -> Option<Intrinsics> {
    // condition: work on image coordinates centred and scaled to ~1
    let s = 1.0 / width.max(height);
    let t = Matrix3::new(
        s,
        0.0,
        -s * width * 0.5,
        0.0,
        s,
        -s * height * 0.5,
        0.0,
        0.0,
        1.0,
    );
    let hs: Vec<Matrix3<f64>> = hs.iter().map(|h| t * h).collect();
    let from_normalised = |k: Intrinsics| Intrinsics {
        fx: k.fx / s,
        fy: k.fy / s,
        cx: k.cx / s + width * 0.5,
        cy: k.cy / s + height * 0.5,
    };
    if let Some(k) = zhang_closed_form(&hs).map(from_normalised)
        && k.valid(width, height)
    {
        return Some(k);
    }
    centred_focal(&hs)
        .map(from_normalised)
        .filter(|k| k.valid(width, height))
}

/// `v_ij` of Zhang's paper restricted to zero skew: coefficients of `[B11, B22, B13, B23, B33]`.
fn v_ij(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 5] {
    let hi = h.column(i);
    let hj = h.column(j);
    [
        hi[0] * hj[0],
        hi[1] * hj[1],
        hi[2] * hj[0] + hi[0] * hj[2],
        hi[2] * hj[1] + hi[1] * hj[2],
        hi[2] * hj[2],
    ]
}

fn zhang_closed_form(hs: &[Matrix3<f64>]) -> Option<Intrinsics> {
    if hs.len() < 2 {
        return None;
    }
    let mut v = DMatrix::<f64>::zeros(2 * hs.len(), 5);
    for (k, h) in hs.iter().enumerate() {
        let h = h / h.column(0).norm().max(h.column(1).norm());
        let v12 = v_ij(&h, 0, 1);
        let v11 = v_ij(&h, 0, 0);
        let v22 = v_ij(&h, 1, 1);
        for c in 0..5 {
            v[(2 * k, c)] = v12[c];
            v[(2 * k + 1, c)] = v11[c] - v22[c];
        }
    }
    let b = smallest_right_singular(&v)?;
    let (mut b11, mut b22, mut b13, mut b23, mut b33) = (b[0], b[1], b[2], b[3], b[4]);
    if b11 < 0.0 {
        (b11, b22, b13, b23, b33) = (-b11, -b22, -b13, -b23, -b33);
    }
    if b11 <= 0.0 || b22 <= 0.0 {
        return None;
    }
    let cy = -b23 / b22;
    let lambda = b33 - (b13 * b13 + cy * (-b11 * b23)) / b11;
    let fx = (lambda / b11).sqrt();
    let fy = (lambda / b22).sqrt();
    let cx = -b13 * fx * fx / lambda;
    Some(Intrinsics { fx, fy, cx, cy })
}

/// OpenCV's `initIntrinsicParams2D`: principal point at the centre (here the origin),
/// `1/fx²`, `1/fy²` by linear least squares from the two constraints per view.
fn centred_focal(hs: &[Matrix3<f64>]) -> Option<Intrinsics> {
    let mut ata = nalgebra::Matrix2::<f64>::zeros();
    let mut atb = Vector2::<f64>::zeros();
    for h in hs {
        let h = h / h.column(0).norm().max(h.column(1).norm());
        let rows = [
            (
                Vector2::new(h[(0, 0)] * h[(0, 1)], h[(1, 0)] * h[(1, 1)]),
                -h[(2, 0)] * h[(2, 1)],
            ),
            (
                Vector2::new(
                    h[(0, 0)].powi(2) - h[(0, 1)].powi(2),
                    h[(1, 0)].powi(2) - h[(1, 1)].powi(2),
                ),
                -(h[(2, 0)].powi(2) - h[(2, 1)].powi(2)),
            ),
        ];
        for (a, b) in rows {
            ata += a * a.transpose();
            atb += a * b;
        }
    }
    let x = ata.try_inverse()? * atb;
    if x[0] <= 0.0 || x[1] <= 0.0 {
        return None;
    }
    Some(Intrinsics {
        fx: (1.0 / x[0]).sqrt(),
        fy: (1.0 / x[1]).sqrt(),
        cx: 0.0,
        cy: 0.0,
    })
}

/// Board-to-camera pose (rvec, tvec) from a homography and `K`.
pub(crate) fn pose_from_homography(
    h: &Matrix3<f64>,
    k: &Matrix3<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let m = k.try_inverse()? * h;
    let n1 = m.column(0).norm();
    let n2 = m.column(1).norm();
    if !(n1 > 0.0 && n2 > 0.0) {
        return None;
    }
    let mut lambda = 2.0 / (n1 + n2);
    if m[(2, 2)] * lambda < 0.0 {
        lambda = -lambda;
    }
    let r1 = m.column(0) * lambda;
    let r2 = m.column(1) * lambda;
    let t = m.column(2) * lambda;
    let r3 = r1.cross(&r2);
    let r = Matrix3::from_columns(&[r1, r2, r3]);
    let svd = r.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut rot = u * vt;
    if rot.determinant() < 0.0 {
        let mut u2 = u;
        u2.column_mut(2).neg_mut();
        rot = u2 * vt;
    }
    let rvec = Rotation3::from_matrix_unchecked(rot).scaled_axis();
    let t = Vector3::new(t[0], t[1], t[2]);
    (rvec.iter().chain(t.iter()).all(|v| v.is_finite())).then_some((rvec, t))
}
