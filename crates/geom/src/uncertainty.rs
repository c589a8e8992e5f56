//! What a position covariance means as a probability, and how to make it mean what it says.
//!
//! A pose's position covariance `Σ` (m², world axes) claims that the error `e` falls in the
//! ellipsoid `eᵀ Σ⁻¹ e ≤ χ²_d(p)` with probability `p` (`d` the position's dimensions: 3, or 2
//! for a floor position x, y). [`Standardised`] holds one frame's squared Mahalanobis distance
//! `r² = eᵀ Σ⁻¹ e` and `ln det Σ`; [`UncertaintyFigures`] scores a set of them: coverage of the
//! 50 / 90 / 95 / 99 % regions, mean negative log-likelihood, expected calibration error (the
//! mean gap between nominal and observed coverage over levels 5 … 95 %) and sharpness.
//!
//! [`Calibration`] is fitted on validation frames (never on the frames a figure is reported
//! on) and corrects both the covariance and its regions:
//! - `scale`: the covariance's factor, the likelihood's best (`mean r² / d`): what a Kalman
//!   filter or a ROS consumer that treats the covariance as a Gaussian's wants;
//! - `radii`: the validation frames' own `r²` quantiles at [`KNOT_LEVELS`] (the isotonic map
//!   of `r²` onto probability, piecewise linear in the level), so that the `p` region is right
//!   when the errors are not Gaussian-shaped (network errors are heavier-tailed: a single
//!   scale cannot make the 50 % and the 95 % regions right at once).
//!
//! Written by hand: χ² with 1–3 degrees of freedom has a closed form through `erf` (from
//! `libm`), and a statistics crate would bring distributions we never use.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// The regions every report gives: 50, 90, 95 and 99 %.
pub const COVERAGE_LEVELS: [f64; 4] = [0.5, 0.9, 0.95, 0.99];

/// Levels of the calibration's quantile knots: 5 % … 95 % in steps of 5, then 99 %.
pub const KNOT_LEVELS: [f64; 20] = [
    0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, 0.50, 0.55, 0.60, 0.65, 0.70, 0.75, 0.80,
    0.85, 0.90, 0.95, 0.99,
];

/// Levels of the expected calibration error: 5 % … 95 % in steps of 5.
fn ece_levels() -> impl Iterator<Item = f64> {
    (1..=19).map(|k| f64::from(k) * 0.05)
}

/// `P(X ≤ x)` for `X ~ χ²` with `dof` degrees of freedom (1, 2 or 3; others panic-free: 0).
pub fn chi2_cdf(x: f64, dof: usize) -> f64 {
    if x <= 0.0 || x.is_nan() {
        return 0.0;
    }
    if x.is_infinite() {
        return 1.0;
    }
    let s = (x / 2.0).sqrt();
    match dof {
        1 => libm::erf(s),
        2 => 1.0 - (-x / 2.0).exp(),
        3 => libm::erf(s) - (2.0 * x / std::f64::consts::PI).sqrt() * (-x / 2.0).exp(),
        _ => 0.0,
    }
}

/// The `p` quantile of `χ²_dof` (`dof` 1–3), by bisection to 1e-12 relative.
pub fn chi2_quantile(p: f64, dof: usize) -> f64 {
    if p <= 0.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while chi2_cdf(hi, dof) < p && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_cdf(mid, dof) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// One frame's error against its covariance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Standardised {
    /// Squared Mahalanobis distance `eᵀ Σ⁻¹ e`.
    pub r2: f64,
    /// `ln det Σ` (of the `dims` block), ln m^(2·dims).
    pub log_det: f64,
    /// Dimensions of the error: 3, or 2 for a floor position (x, y), 1 for a heading.
    pub dims: usize,
}

impl Standardised {
    /// `err` (estimate − truth, world metres) under `cov` on the first `dims` axes (2: x, y;
    /// 3: all); `None` when that block is not positive definite.
    pub fn of(err: &Vector3<f64>, cov: &Matrix3<f64>, dims: usize) -> Option<Standardised> {
        let (r2, log_det) = match dims {
            2 => {
                let c = cov.fixed_view::<2, 2>(0, 0).into_owned();
                let chol = c.cholesky()?;
                let e = err.fixed_rows::<2>(0).into_owned();
                let y = chol.l().solve_lower_triangular(&e)?;
                let ld = 2.0 * chol.l().diagonal().map(f64::ln).sum();
                (y.norm_squared(), ld)
            }
            3 => {
                let chol = cov.cholesky()?;
                let y = chol.l().solve_lower_triangular(err)?;
                let ld = 2.0 * chol.l().diagonal().map(f64::ln).sum();
                (y.norm_squared(), ld)
            }
            _ => return None,
        };
        (r2.is_finite() && log_det.is_finite()).then_some(Standardised { r2, log_det, dims })
    }

    /// An error of squared length `dist2` under an isotropic covariance of trace `total_var`
    /// in `dims` dimensions (a rotation angle against its RMS spread); `None` for a zero or
    /// non-finite variance.
    pub fn isotropic(dist2: f64, total_var: f64, dims: usize) -> Option<Standardised> {
        let per_axis = total_var / dims.max(1) as f64;
        (per_axis > 0.0 && per_axis.is_finite() && dist2.is_finite()).then(|| Standardised {
            r2: dist2 / per_axis,
            log_det: dims as f64 * per_axis.ln(),
            dims,
        })
    }

    /// The same error under the covariance times `k` (> 0).
    pub fn scaled(&self, k: f64) -> Standardised {
        Standardised {
            r2: self.r2 / k,
            log_det: self.log_det + self.dims as f64 * k.ln(),
            dims: self.dims,
        }
    }

    /// Negative log-likelihood of the error under the Gaussian, nats.
    pub fn nll(&self) -> f64 {
        0.5 * (self.dims as f64 * (2.0 * std::f64::consts::PI).ln() + self.log_det + self.r2)
    }
}

/// A fitted correction of covariances (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Dimensions of the errors it was fitted on (1–3).
    pub dims: usize,
    /// Factor of the covariance: the validation frames' `mean r² / dims`.
    pub scale: f64,
    /// The validation frames' `r²` (under the raw covariance) at each of [`KNOT_LEVELS`].
    pub radii: Vec<f64>,
    /// Frames it was fitted on.
    pub frames: usize,
}

/// Fewer frames than this fit no calibration: too few to place a 95 % quantile.
pub const MIN_CALIBRATION_FRAMES: usize = 20;

impl Calibration {
    /// Fitted on validation frames' raw standardised errors; `None` for fewer than
    /// [`MIN_CALIBRATION_FRAMES`] or mixed dimensions.
    pub fn fit(frames: &[Standardised]) -> Option<Calibration> {
        let dims = frames.first()?.dims;
        if frames.len() < MIN_CALIBRATION_FRAMES || frames.iter().any(|f| f.dims != dims) {
            return None;
        }
        let mut r2: Vec<f64> = frames.iter().map(|f| f.r2).collect();
        r2.sort_by(f64::total_cmp);
        let scale = r2.iter().sum::<f64>() / (r2.len() * dims) as f64;
        let radii = KNOT_LEVELS
            .iter()
            .map(|&p| crate::metrics::percentile_sorted(&r2, 100.0 * p))
            .collect();
        (scale.is_finite() && scale > 0.0).then_some(Calibration {
            dims,
            scale,
            radii,
            frames: frames.len(),
        })
    }

    /// Checks a calibration read from a file.
    pub fn check(&self) -> Result<(), String> {
        let ordered = self.radii.windows(2).all(|w| w[0] <= w[1]);
        let valid = (1..=3).contains(&self.dims)
            && self.scale.is_finite()
            && self.scale > 0.0
            && self.radii.len() == KNOT_LEVELS.len()
            && ordered
            && self.radii.iter().all(|r| r.is_finite() && *r >= 0.0);
        if !valid {
            return Err(format!(
                "uncertainty calibration must have dims 1 to 3, a positive scale and {} \
                 ascending radii: {self:?}",
                KNOT_LEVELS.len()
            ));
        }
        Ok(())
    }

    /// The `r²` bound (under the raw covariance) of the calibrated `p` region: the knots'
    /// radii, linear in `p` between them, held flat past the first and the last.
    pub fn raw_radius2(&self, p: f64) -> f64 {
        let (first, last) = (KNOT_LEVELS[0], KNOT_LEVELS[KNOT_LEVELS.len() - 1]);
        if p <= first {
            return self.radii[0];
        }
        if p >= last {
            return self.radii[self.radii.len() - 1];
        }
        let k = KNOT_LEVELS.iter().position(|&l| l >= p).unwrap_or(1).max(1);
        let (l0, l1) = (KNOT_LEVELS[k - 1], KNOT_LEVELS[k]);
        let f = (p - l0) / (l1 - l0);
        self.radii[k - 1] + f * (self.radii[k] - self.radii[k - 1])
    }

    /// How much the calibrated covariance (`scale · Σ`) must be grown for its χ² region at
    /// level `p` to be the calibrated `p` region: `raw_radius2(p) / (scale · χ²_d(p))`.
    pub fn region_factor(&self, p: f64) -> f64 {
        self.raw_radius2(p) / (self.scale * chi2_quantile(p, self.dims))
    }
}

/// How a set of covariances reads their errors, optionally through a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UncertaintyFigures {
    /// Frames scored.
    pub frames: usize,
    /// Share of errors inside the 50, 90, 95 and 99 % regions ([`COVERAGE_LEVELS`]).
    pub coverage: [f64; 4],
    /// Mean negative log-likelihood of the errors, nats (under the covariance, scaled when
    /// calibrated).
    pub nll: f64,
    /// Mean |observed − nominal| coverage over the levels 5 … 95 %.
    pub ece: f64,
    /// Median `sqrt(trace Σ)` (the calibrated covariance's when calibrated), metres.
    pub median_sigma_m: f64,
}

impl UncertaintyFigures {
    /// Scores `frames` (`sigma_m`: each one's `sqrt(trace Σ)` of the raw covariance), reading
    /// the regions as Gaussian χ² regions without `cal`, through `cal`'s radii with it; `None`
    /// without frames.
    pub fn of(
        frames: &[Standardised],
        sigma_m: &[f64],
        cal: Option<&Calibration>,
    ) -> Option<UncertaintyFigures> {
        if frames.is_empty() {
            return None;
        }
        let bound = |p: f64, f: &Standardised| match cal {
            Some(c) => c.raw_radius2(p),
            None => chi2_quantile(p, f.dims),
        };
        let coverage_at = |p: f64| {
            frames.iter().filter(|f| f.r2 <= bound(p, f)).count() as f64 / frames.len() as f64
        };
        let coverage = COVERAGE_LEVELS.map(coverage_at);
        let ece = ece_levels()
            .map(|p| (coverage_at(p) - p).abs())
            .sum::<f64>()
            / ece_levels().count() as f64;
        let k = cal.map_or(1.0, |c| c.scale);
        let nll = frames.iter().map(|f| f.scaled(k).nll()).sum::<f64>() / frames.len() as f64;
        let mut sigma: Vec<f64> = sigma_m.iter().map(|s| s * k.sqrt()).collect();
        sigma.sort_by(f64::total_cmp);
        let median_sigma_m = if sigma.is_empty() {
            f64::NAN
        } else {
            crate::metrics::percentile_sorted(&sigma, 50.0)
        };
        Some(UncertaintyFigures {
            frames: frames.len(),
            coverage,
            nll,
            ece,
            median_sigma_m,
        })
    }

    /// Observed coverage at each level of `levels`, for a reliability diagram.
    pub fn reliability(
        frames: &[Standardised],
        cal: Option<&Calibration>,
        levels: &[f64],
    ) -> Vec<f64> {
        levels
            .iter()
            .map(|&p| {
                frames
                    .iter()
                    .filter(|f| {
                        f.r2 <= cal.map_or_else(|| chi2_quantile(p, f.dims), |c| c.raw_radius2(p))
                    })
                    .count() as f64
                    / frames.len().max(1) as f64
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A standard normal draw (Box–Muller; the workspace has no rand_distr).
    fn gaussian(rng: &mut impl Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    #[test]
    fn chi2_matches_tables() {
        // Quantiles from standard tables (scipy.stats.chi2.ppf).
        for (p, d, q) in [
            (0.95, 1, 3.841_458_820_694_124),
            (0.5, 2, 1.386_294_361_119_890_6),
            (0.95, 2, 5.991_464_547_107_979),
            (0.5, 3, 2.365_973_884_375_338),
            (0.95, 3, 7.814_727_903_251_178),
            (0.99, 3, 11.344_866_730_144_373),
        ] {
            assert!((chi2_quantile(p, d) - q).abs() < 1e-9, "{p} {d}");
            assert!((chi2_cdf(q, d) - p).abs() < 1e-12);
        }
    }

    /// Errors drawn from known anisotropic Gaussians with their true covariances.
    fn known_gaussian(n: usize, seed: u64, claimed: f64) -> (Vec<Standardised>, Vec<f64>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut out = (Vec::new(), Vec::new());
        for i in 0..n {
            let s = 0.1 + 0.05 * (i % 9) as f64;
            let cov = Matrix3::from_diagonal(&Vector3::new(s * s, 4.0 * s * s, 0.25 * s * s));
            let e = Vector3::new(
                s * gaussian(&mut rng),
                2.0 * s * gaussian(&mut rng),
                0.5 * s * gaussian(&mut rng),
            );
            let c = cov * claimed;
            out.0.push(Standardised::of(&e, &c, 3).unwrap());
            out.1.push(c.trace().sqrt());
        }
        out
    }

    #[test]
    fn true_covariances_cover_what_they_claim() {
        let (frames, sigma) = known_gaussian(4000, 1, 1.0);
        let f = UncertaintyFigures::of(&frames, &sigma, None).unwrap();
        for (c, p) in f.coverage.iter().zip(COVERAGE_LEVELS) {
            assert!((c - p).abs() < 0.02, "{f:?}");
        }
        assert!(f.ece < 0.015, "{f:?}");
    }

    #[test]
    fn a_miscalibrated_scale_is_detected_and_fitted_away() {
        // Claimed covariances a quarter of the truth: the 95 % region holds far fewer.
        let (val, _) = known_gaussian(2000, 2, 0.25);
        let (test, sigma) = known_gaussian(2000, 3, 0.25);
        let raw = UncertaintyFigures::of(&test, &sigma, None).unwrap();
        assert!(raw.coverage[2] < 0.7 && raw.ece > 0.15, "{raw:?}");
        let cal = Calibration::fit(&val).unwrap();
        assert!((cal.scale - 4.0).abs() < 0.3, "{cal:?}");
        let fixed = UncertaintyFigures::of(&test, &sigma, Some(&cal)).unwrap();
        assert!((fixed.coverage[0] - 0.5).abs() < 0.03, "{fixed:?}");
        assert!((fixed.coverage[2] - 0.95).abs() < 0.02, "{fixed:?}");
        assert!(fixed.nll < raw.nll, "{fixed:?} {raw:?}");
        assert!((fixed.median_sigma_m / raw.median_sigma_m - 2.0).abs() < 0.15);
        // Gaussian errors: the regions need no more than the scale.
        assert!((cal.region_factor(0.95) - 1.0).abs() < 0.1, "{cal:?}");
        assert!(cal.check().is_ok());
    }

    #[test]
    fn heavy_tails_need_the_radii_not_only_the_scale() {
        // Errors whose true scale varies 10x unseen by the covariance: a single scale cannot
        // place both regions; the radii can.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut draw = |n: usize| -> Vec<Standardised> {
            (0..n)
                .map(|i| {
                    let s = if i % 5 == 0 { 1.0 } else { 0.1 };
                    let e = Vector3::new(
                        s * gaussian(&mut rng),
                        s * gaussian(&mut rng),
                        s * gaussian(&mut rng),
                    );
                    Standardised::of(&e, &(Matrix3::identity() * 0.04), 3).unwrap()
                })
                .collect()
        };
        let (val, test) = (draw(3000), draw(3000));
        let cal = Calibration::fit(&val).unwrap();
        let sigma = vec![0.2; test.len()];
        let fixed = UncertaintyFigures::of(&test, &sigma, Some(&cal)).unwrap();
        assert!((fixed.coverage[0] - 0.5).abs() < 0.03, "{fixed:?}");
        assert!((fixed.coverage[2] - 0.95).abs() < 0.02, "{fixed:?}");
        // The scale alone read as a Gaussian: the 50 % region far too large.
        let scaled: Vec<Standardised> = test.iter().map(|f| f.scaled(cal.scale)).collect();
        let gauss = UncertaintyFigures::of(&scaled, &sigma, None).unwrap();
        assert!(gauss.coverage[0] > 0.7, "{gauss:?}");
    }

    #[test]
    fn floor_positions_use_the_xy_block() {
        let cov = Matrix3::from_diagonal(&Vector3::new(0.04, 0.01, 0.0));
        let s = Standardised::of(&Vector3::new(0.2, 0.1, 5.0), &cov, 2).unwrap();
        assert!((s.r2 - 2.0).abs() < 1e-12);
        assert!(Standardised::of(&Vector3::new(0.2, 0.1, 5.0), &cov, 3).is_none());
    }

    #[test]
    fn a_bad_calibration_is_refused() {
        let mut cal = Calibration {
            dims: 3,
            scale: 1.0,
            radii: KNOT_LEVELS.iter().map(|&p| chi2_quantile(p, 3)).collect(),
            frames: 100,
        };
        assert!(cal.check().is_ok());
        cal.radii.swap(0, 5);
        assert!(cal.check().is_err());
        cal.radii.swap(0, 5);
        cal.scale = f64::NAN;
        assert!(cal.check().is_err());
    }
}
