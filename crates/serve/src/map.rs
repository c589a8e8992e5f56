//! The floor map the dashboard draws under the live pose.

use serde::{Deserialize, Serialize};

/// A top-down map of the storey the camera moves on (world x, y in metres).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FloorMap {
    /// What the map shows, for the page's title.
    pub title: String,
    /// Rooms and corridors as axis-aligned rectangles `[x0, y0, x1, y1]`.
    pub rects: Vec<[f64; 4]>,
    /// A reference path to draw (the walk's ground truth), `[x, y]` points.
    pub path: Vec<[f64; 2]>,
}

impl FloorMap {
    /// The map's extent `[x0, y0, x1, y1]`, grown by `margin` metres; `None` when empty.
    pub fn bounds(&self, margin: f64) -> Option<[f64; 4]> {
        let xs = self
            .rects
            .iter()
            .flat_map(|r| [[r[0], r[1]], [r[2], r[3]]])
            .chain(self.path.iter().copied());
        let mut b: Option<[f64; 4]> = None;
        for [x, y] in xs.filter(|p| p[0].is_finite() && p[1].is_finite()) {
            let e = b.get_or_insert([x, y, x, y]);
            *e = [e[0].min(x), e[1].min(y), e[2].max(x), e[3].max(y)];
        }
        b.map(|e| [e[0] - margin, e[1] - margin, e[2] + margin, e[3] + margin])
    }
}
