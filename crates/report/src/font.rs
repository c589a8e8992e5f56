//! The embedded plot font: DejaVu Sans from the `dejavu` crate, registered with plotters once,
//! so figures look the same on every machine and never depend on system fonts.

use crate::error::{ReportError, Result};
use plotters::style::{FontStyle, register_font};
use std::path::Path;
use std::sync::OnceLock;

/// The family name every figure uses (also written into SVG `font-family`).
pub(crate) const FONT: &str = "DejaVu Sans";

/// What SVG files name as their font: DejaVu first (its metrics laid the text out), then
/// look-alikes for viewers that do not have it.
pub(crate) const SVG_FONT_STACK: &str = "DejaVu Sans, Verdana, Bitstream Vera Sans, sans-serif";

static REGISTERED: OnceLock<bool> = OnceLock::new();

/// Registers the regular and bold faces on first use; an error if the font bytes do not parse.
pub(crate) fn ensure_font(path: &Path) -> Result<()> {
    let ok = *REGISTERED.get_or_init(|| {
        register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && register_font(FONT, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(ReportError::Plot {
            path: path.to_path_buf(),
            msg: format!("the embedded {FONT} font could not be loaded"),
        })
    }
}
