//! What the studies share: how much they render and train ([`Scale`], turned into the demo
//! they start from) and the error columns of their tables.

use crate::demo::{DemoConfig, Evaluation};
use clap::Args;
use serde::Serialize;
use std::path::Path;

/// The error columns the studies' tables share, after their own leading columns: median
/// position and rotation error, mean position error, and the share of frames within each
/// accuracy threshold. Flattened into a row's JSON, so the keys are the row's own.
#[derive(Debug, Serialize)]
pub(crate) struct ErrorColumns {
    pub median_pos_m: f64,
    pub median_rot_deg: f64,
    pub mean_pos_m: f64,
    /// `(max m, max °, share)` per threshold: (0.25 m, 2°), (0.5 m, 5°) and (5 m, 10°).
    pub accuracy: Vec<(f64, f64, f64)>,
}

impl ErrorColumns {
    /// The columns of an evaluation.
    pub(crate) fn of(ev: &Evaluation) -> ErrorColumns {
        ErrorColumns {
            median_pos_m: ev.pos_median,
            median_rot_deg: ev.rot_median,
            mean_pos_m: ev.pos_mean,
            accuracy: ev.accuracy.clone(),
        }
    }

    /// `lead` then the headers of these columns (the thresholds of the first row's accuracy).
    pub(crate) fn headers<'a>(
        lead: &[&str],
        first: impl IntoIterator<Item = &'a ErrorColumns>,
    ) -> Vec<String> {
        let mut header: Vec<String> = lead.iter().map(|s| s.to_string()).collect();
        header.extend(["median (m)".into(), "median (°)".into(), "mean (m)".into()]);
        if let Some(first) = first.into_iter().next() {
            header.extend(
                first
                    .accuracy
                    .iter()
                    .map(|(m, d, _)| format!("≤ {m} m, {d}°")),
            );
        }
        header
    }

    /// `lead` then the cells of these columns.
    pub(crate) fn cells(&self, lead: Vec<String>) -> Vec<String> {
        let mut cells = lead;
        cells.extend([
            format!("{:.3}", self.median_pos_m),
            format!("{:.2}", self.median_rot_deg),
            format!("{:.3}", self.mean_pos_m),
        ]);
        cells.extend(
            self.accuracy
                .iter()
                .map(|(_, _, f)| format!("{:.1} %", 100.0 * f)),
        );
        cells
    }
}

/// How much a study renders and trains: the demo's quick or full setup, with overrides (small
/// values make a study a smoke test).
#[derive(Args, Debug, Clone, Default, PartialEq)]
pub struct Scale {
    /// The demo's quick setup (minutes) instead of the full one.
    #[arg(long)]
    pub quick: bool,
    /// Override the number of training frames.
    #[arg(long)]
    pub train_frames: Option<usize>,
    /// Override the length of the held-out test walk, frames.
    #[arg(long)]
    pub test_frames: Option<usize>,
    /// Override the number of training epochs of the network.
    #[arg(long)]
    pub epochs: Option<usize>,
}

impl Scale {
    /// The demo's quick setup, nothing overridden.
    pub fn quick() -> Scale {
        Scale {
            quick: true,
            ..Scale::default()
        }
    }
}

impl Scale {
    /// The demo a study trains with: the demo's own defaults at this scale, in `out`.
    pub fn demo(&self, out: &Path) -> DemoConfig {
        DemoConfig {
            out: out.to_path_buf(),
            quick: self.quick,
            train_frames: self.train_frames,
            test_frames: self.test_frames,
            epochs: self.epochs,
            ..DemoConfig::default()
        }
    }
}
