//! Tables, plots and self-contained HTML reports for indoorloc.
//!
//! Everything a person reads about a run ends up here: `indoorloc eval --report DIR`, the demo
//! and the studies. Plots are drawn with plotters in an embedded font (DejaVu Sans, from the
//! `dejavu` crate), so they look the same on every machine and need no system fonts; the same
//! drawing code writes PNG and SVG. Reports are single HTML files with every figure inline.
//!
//! # Entry points
//! - [`pose_eval_report`]: the whole `eval` report (HTML + figures) for a [`PoseEvaluation`];
//!   [`pose_summary_table`]: its summary table, also for the terminal.
//! - [`Figure`]: [`error_cdf`], [`error_over_time`], [`trajectory_top_down`], [`error_map`]
//!   (position errors coloured along a walk), [`scatter`] (e.g. predicted uncertainty against
//!   error, with Pearson r), [`reliability`] (coverage of uncertainty regions against their
//!   nominal probability) or the structs [`ErrorCdf`], [`ErrorOverTime`], [`TopDown`],
//!   [`ErrorMap`], [`Scatter`], rendered with [`Figure::to_png`],
//!   [`Figure::to_svg`], [`Figure::save_png`], [`Figure::save_svg`], [`Figure::save_both`].
//! - [`Table`]: aligned text for terminals, HTML, JSON rows.
//! - [`HtmlReport`]: a builder of one-file reports (sections, paragraphs, highlight cards,
//!   tables, inline SVG and base64 PNG figures).
//! - [`contact_sheet`]: a grid of labelled pictures in one PNG.
//! - [`rhythm_png`]: the scene-cut picture (visual rhythm, difference series, cuts).
//! - [`saliency_overlay`]: a Grad-CAM map blended over its frame.
//! - [`write_atomic`]: every file is written to a temporary name in the same folder, then renamed.
//!
//! # Conventions
//! - Position errors in metres, rotation errors in degrees (the units people read); frames are
//!   indices into the matched lists.
//! - Non-finite values are left out of plots (legends say how many); a series with no finite
//!   value, or a figure with no series, is a [`ReportError::BadInput`], never a panic.
//! - Long inputs are decimated before drawing (quantiles, min/max per pixel column, uniform
//!   strides), so 100 000 frames render in well under a second; statistics always use every value.
//!
//! ```
//! use report::{HtmlReport, Series, Table, error_cdf};
//! let fig = error_cdf(
//!     "Errors",
//!     &[Series::new("net", vec![0.12, 0.30, 0.25])],
//!     &[Series::new("net", vec![1.5, 3.0, 2.2])],
//! );
//! let svg = fig.to_svg()?;
//! assert!(svg.contains("net"));
//! let mut t = Table::new("Results", ["method", "median (m)"]);
//! t.push_row(["net", "0.25"]);
//! let mut r = HtmlReport::new("Demo");
//! r.section("Results").table(&t).svg(svg, "Cumulative errors");
//! assert!(r.to_html().contains("<svg"));
//! # Ok::<(), report::ReportError>(())
//! ```
#![deny(missing_docs)]

// Layers, top to bottom; each module imports only from modules listed below it, so no two
// modules import each other, directly or round a circle:
// - `eval` (the evaluation report), then `html` (the report builder);
// - `figure`: the `Figure` enum over every kind, the functions that make one, and rendering;
// - one module per figure kind, each with its description, preparation and drawing: `cdf`,
//   `over_time`, `top_down`, `errmap`, `scatter`, `reliability`; and the pictures `confusion`,
//   `rhythm`, `sheet`, `saliency`;
// - `chart` (the plot style and the drawing helpers the kinds share), `series`, `decimate`,
//   `table`, `font`, `io`, `error`.
mod cdf;
mod chart;
mod confusion;
mod decimate;
mod errmap;
mod error;
mod eval;
mod figure;
mod font;
mod html;
mod io;
mod over_time;
mod reliability;
mod rhythm;
mod saliency;
mod scatter;
mod series;
mod sheet;
mod table;
mod top_down;

pub use cdf::ErrorCdf;
pub use confusion::confusion_png;
pub use errmap::ErrorMap;
pub use error::{ReportError, Result};
pub use eval::{pose_eval_report, pose_summary_table};
pub use figure::{
    Figure, error_cdf, error_map, error_over_time, reliability, scatter, trajectory_top_down,
};
pub use html::HtmlReport;
pub use io::write_atomic;
pub use over_time::ErrorOverTime;
pub use reliability::{Reliability, ReliabilityCurve};
pub use rhythm::{RhythmPlot, rhythm_png};
pub use saliency::saliency_overlay;
pub use scatter::Scatter;
pub use series::{Series, Track};
pub use sheet::{Tile, contact_sheet};
pub use table::Table;
pub use top_down::TopDown;

#[doc(no_inline)]
pub use geom::metrics::PoseEvaluation;
