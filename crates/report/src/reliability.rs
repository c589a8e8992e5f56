//! Reliability diagrams: for uncertainty that claims probabilities, the share of errors that
//! fell inside each claimed region against the region's nominal probability. A calibrated
//! source lies on the diagonal; below it, the regions are too small (overconfident).

use crate::error::{ReportError, Result};
use crate::figure::Figure;
use serde::{Deserialize, Serialize};

/// One curve: nominal levels against observed coverage, both in [0, 1].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReliabilityCurve {
    /// Legend text.
    pub name: String,
    /// `[nominal, observed]` pairs, nominal ascending.
    pub points: Vec<[f64; 2]>,
}

/// Observed against nominal coverage, one curve per source, with the diagonal.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Reliability {
    /// Figure title.
    pub title: String,
    /// The curves.
    pub curves: Vec<ReliabilityCurve>,
}

/// A reliability diagram of `curves`.
pub fn reliability(title: &str, curves: Vec<ReliabilityCurve>) -> Figure {
    Figure::Reliability(Reliability {
        title: title.into(),
        curves,
    })
}

/// The checked curves, ready to draw.
pub(crate) struct ReliabilityPlot {
    pub(crate) title: String,
    pub(crate) curves: Vec<(String, Vec<(f64, f64)>)>,
}

pub(crate) fn prepare_reliability(f: &Reliability) -> Result<ReliabilityPlot> {
    let ok = |p: &[f64; 2]| p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
    if f.curves.is_empty() || f.curves.iter().any(|c| c.points.is_empty()) {
        return Err(ReportError::BadInput(format!(
            "reliability diagram '{}': no curve, or a curve without points",
            f.title
        )));
    }
    if let Some(c) = f.curves.iter().find(|c| !c.points.iter().all(ok)) {
        return Err(ReportError::BadInput(format!(
            "reliability diagram '{}': curve '{}' has a value outside [0, 1]",
            f.title, c.name
        )));
    }
    Ok(ReliabilityPlot {
        title: f.title.clone(),
        curves: f
            .curves
            .iter()
            .map(|c| {
                (
                    c.name.clone(),
                    c.points.iter().map(|p| (p[0], p[1])).collect(),
                )
            })
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(name: &str, f: impl Fn(f64) -> f64) -> ReliabilityCurve {
        ReliabilityCurve {
            name: name.into(),
            points: (1..20)
                .map(|k| f64::from(k) * 0.05)
                .map(|p| [p, f(p)])
                .collect(),
        }
    }

    #[test]
    fn draws_every_curve_and_the_diagonal() -> Result<()> {
        let fig = reliability(
            "Coverage",
            vec![curve("raw", |p| p * p), curve("calibrated", |p| p)],
        );
        let svg = fig.to_svg()?;
        assert!(svg.contains("Coverage") && svg.contains("raw") && svg.contains("calibrated"));
        assert!(svg.contains("ideal"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_curves_are_refused() {
        for fig in [
            reliability("t", vec![]),
            reliability("t", vec![curve("x", |_| f64::NAN)]),
            reliability("t", vec![curve("x", |p| p + 1.0)]),
        ] {
            crate::figure::assert_rejected(&fig);
        }
    }
}
