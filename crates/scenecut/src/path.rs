//! The pixel path a visual rhythm samples from each frame's thumbnail.
//!
//! A visual rhythm stacks the same pixel path of every frame side by side: one column per frame.
//! The classic path is the main diagonal; here the path is a choice, because what it covers
//! decides which cuts it can see. The default, [`PathKind::Grid`] (every 4th row and every 4th
//! column of a 64-pixel-wide thumbnail, about half the pixels), sees a cut where only people
//! moved between two shots of one static camera, which a single diagonal misses in its noise.

use crate::error::{CutError, Result};
use serde::{Deserialize, Serialize};

/// Which pixels of the thumbnail form the path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind", content = "step")]
pub enum PathKind {
    /// The main diagonal, top-left to bottom-right (the classic visual rhythm).
    Diagonal,
    /// The centre row and the centre column.
    Cross,
    /// Both diagonals, the centre row and the centre column.
    Star,
    /// Every `step`-th row and every `step`-th column (offset `step / 2`).
    Grid(u32),
}

impl Default for PathKind {
    fn default() -> Self {
        PathKind::Grid(4)
    }
}

impl std::fmt::Display for PathKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PathKind::Diagonal => f.write_str("diagonal"),
            PathKind::Cross => f.write_str("cross"),
            PathKind::Star => f.write_str("star"),
            PathKind::Grid(step) => write!(f, "grid{step}"),
        }
    }
}

impl std::str::FromStr for PathKind {
    type Err = CutError;

    /// `diagonal`, `cross`, `star`, `grid` (step 4) or `gridN`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "diagonal" => Ok(PathKind::Diagonal),
            "cross" => Ok(PathKind::Cross),
            "star" => Ok(PathKind::Star),
            "grid" => Ok(PathKind::Grid(4)),
            _ => s
                .strip_prefix("grid")
                .and_then(|n| n.parse::<u32>().ok())
                .filter(|&n| n >= 1)
                .map(PathKind::Grid)
                .ok_or_else(|| {
                    CutError::Config(format!(
                        "unknown path '{s}' (diagonal, cross, star, grid or gridN with N ≥ 1)"
                    ))
                }),
        }
    }
}

/// Pixel indices (row-major, `y * width + x`) of the path on a `width` x `height` thumbnail, in
/// drawing order. Errors on an empty thumbnail.
pub fn pixel_indices(kind: PathKind, width: u32, height: u32) -> Result<Vec<u32>> {
    if width == 0 || height == 0 {
        return Err(CutError::Config(format!(
            "a {width}x{height} thumbnail has no pixels"
        )));
    }
    let (w, h) = (width, height);
    let at = |x: u32, y: u32| y * w + x;
    let diagonal = |flip: bool| -> Vec<u32> {
        let n = w.max(h);
        (0..n)
            .map(|i| {
                let (x, y) = (scale(i, n, w), scale(i, n, h));
                at(if flip { w - 1 - x } else { x }, y)
            })
            .collect()
    };
    let row = |y: u32| (0..w).map(move |x| at(x, y));
    let column = |x: u32| (0..h).map(move |y| at(x, y));
    let indices = match kind {
        PathKind::Diagonal => diagonal(false),
        PathKind::Cross => row(h / 2).chain(column(w / 2)).collect(),
        PathKind::Star => {
            let mut v = diagonal(false);
            v.extend(diagonal(true));
            v.extend(row(h / 2));
            v.extend(column(w / 2));
            v
        }
        PathKind::Grid(step) => {
            if step == 0 {
                return Err(CutError::Config("grid step must be at least 1".into()));
            }
            let rows = (step / 2..h).step_by(step as usize).flat_map(row);
            let columns = (step / 2..w).step_by(step as usize).flat_map(column);
            let v: Vec<u32> = rows.chain(columns).collect();
            if v.is_empty() {
                // A thumbnail narrower than the step: fall back to the centre cross.
                row(h / 2).chain(column(w / 2)).collect()
            } else {
                v
            }
        }
    };
    Ok(indices)
}

/// Maps step `i` of `n` onto `0..len` with both ends reached.
fn scale(i: u32, n: u32, len: u32) -> u32 {
    if n <= 1 {
        0
    } else {
        ((u64::from(i) * u64::from(len - 1)) / u64::from(n - 1)) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_stay_inside_and_have_the_expected_length() -> Result<()> {
        for (w, h) in [(64, 48), (64, 27), (1, 1), (3, 100)] {
            for kind in [
                PathKind::Diagonal,
                PathKind::Cross,
                PathKind::Star,
                PathKind::Grid(4),
                PathKind::Grid(1),
            ] {
                let p = pixel_indices(kind, w, h)?;
                assert!(!p.is_empty());
                assert!(p.iter().all(|&i| i < w * h), "{kind} on {w}x{h}");
            }
        }
        let d = pixel_indices(PathKind::Diagonal, 64, 48)?;
        assert_eq!(d.len(), 64);
        assert_eq!((d[0], d[63]), (0, 47 * 64 + 63));
        // grid 4 on 64x48: 12 rows of 64 + 16 columns of 48
        assert_eq!(
            pixel_indices(PathKind::Grid(4), 64, 48)?.len(),
            12 * 64 + 16 * 48
        );
        assert!(pixel_indices(PathKind::Grid(4), 0, 4).is_err());
        Ok(())
    }

    #[test]
    fn names_round_trip() -> Result<()> {
        for kind in [
            PathKind::Diagonal,
            PathKind::Cross,
            PathKind::Star,
            PathKind::Grid(6),
        ] {
            assert_eq!(kind.to_string().parse::<PathKind>()?, kind);
        }
        assert_eq!("grid".parse::<PathKind>()?, PathKind::Grid(4));
        assert!("grid0".parse::<PathKind>().is_err());
        assert!("spiral".parse::<PathKind>().is_err());
        Ok(())
    }
}
