//! The named data figures are made of: a [`Series`] of per-frame values (one curve) and a
//! [`Track`] of positions (one path). Several figure kinds and the evaluation report take them,
//! so they sit below every figure module.

use serde::{Deserialize, Serialize};

/// A named list of values: per-frame errors of one method, one curve in a figure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// The values, one per frame (non-finite ones are left out of plots).
    pub values: Vec<f64>,
}

impl Series {
    /// A series from a name and values.
    pub fn new(name: impl Into<String>, values: impl Into<Vec<f64>>) -> Series {
        Series {
            name: name.into(),
            values: values.into(),
        }
    }
}

/// A named top-down path: camera centres `[x, y]` in metres.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Track {
    /// Legend text.
    pub name: String,
    /// Camera centres, metres, in frame order.
    pub points: Vec<[f64; 2]>,
}

impl Track {
    /// A track from a name and points.
    pub fn new(name: impl Into<String>, points: impl Into<Vec<[f64; 2]>>) -> Track {
        Track {
            name: name.into(),
            points: points.into(),
        }
    }
}
