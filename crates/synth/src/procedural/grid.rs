//! Walls from the plan: each storey is painted into a grid of 0.1 m cells (outside, solid, or
//! the index of a zone of free space), and every boundary between a free cell and a cell that is
//! solid, or free but with a lower ceiling, becomes a wall face looking into the free cell.
//! Neighbouring boundary cells with the same zone, heights and exposure merge into one
//! [`WallRun`]. Doing it on a grid makes door openings, wall ends and corners come out right
//! without any geometric case analysis, and walls are two-sided exactly where both sides border
//! free space.

use super::plan::{CELL, IRect, Level};

/// Cell value: outside every building.
pub(crate) const OUTSIDE: u16 = u16::MAX;
/// Cell value: inside a wall.
pub(crate) const SOLID: u16 = u16::MAX - 1;

/// A direction in the plane; for a wall, the direction its face looks into.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Dir {
    /// +x.
    PX,
    /// −x.
    NX,
    /// +y.
    PY,
    /// −y.
    NY,
}

impl Dir {
    /// Unit vector (x, y).
    pub(crate) fn vec(self) -> [f32; 2] {
        match self {
            Dir::PX => [1.0, 0.0],
            Dir::NX => [-1.0, 0.0],
            Dir::PY => [0.0, 1.0],
            Dir::NY => [0.0, -1.0],
        }
    }

    /// True for ±y: the wall runs along x.
    pub(crate) fn along_x(self) -> bool {
        matches!(self, Dir::PY | Dir::NY)
    }

    /// Index 0–3, for hashing.
    pub(crate) fn index(self) -> u64 {
        match self {
            Dir::PX => 0,
            Dir::NX => 1,
            Dir::PY => 2,
            Dir::NY => 3,
        }
    }
}

/// A straight stretch of wall face on one storey, looking into one zone.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct WallRun {
    /// The zone the face looks into.
    pub zone: usize,
    /// The direction the face looks (its normal).
    pub normal: Dir,
    /// The wall line: y (walls along x) or x (walls along y), cells.
    pub line: i32,
    /// Start and end along the wall (x or y), cells, `a < b`.
    pub a: i32,
    /// End along the wall, cells.
    pub b: i32,
    /// Bottom of the face above the storey's floor, metres.
    pub lo: f32,
    /// Top of the face above the storey's floor, metres.
    pub hi: f32,
    /// The other side of the wall is the outdoors (windows go here).
    pub exterior: bool,
}

impl WallRun {
    /// Length, metres.
    pub(crate) fn len_m(&self) -> f32 {
        (self.b - self.a) as f32 * CELL
    }

    /// A stable identity (independent of the storey), for seeding decoration.
    pub(crate) fn key(&self) -> [u64; 4] {
        [
            self.normal.index(),
            self.line as u64,
            self.a as u64,
            self.b as u64,
        ]
    }
}

/// One storey painted into cells.
pub(crate) struct Grid {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    cells: Vec<u16>,
}

impl Grid {
    /// Paints `level`: outside everywhere, then its solids, then its zones.
    pub(crate) fn new(level: &Level) -> Self {
        let all = level
            .solids
            .iter()
            .chain(level.zones.iter().flat_map(|z| z.rects.iter()));
        let (mut x0, mut y0, mut x1, mut y1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
        for r in all {
            x0 = x0.min(r.x0);
            y0 = y0.min(r.y0);
            x1 = x1.max(r.x1);
            y1 = y1.max(r.y1);
        }
        if x0 > x1 {
            (x0, y0, x1, y1) = (0, 0, 0, 0);
        }
        let margin = 6;
        let (x0, y0) = (x0 - margin, y0 - margin);
        let (w, h) = (x1 + margin - x0, y1 + margin - y0);
        let mut grid = Self {
            x0,
            y0,
            w,
            h,
            cells: vec![OUTSIDE; (w * h).max(0) as usize],
        };
        for r in &level.solids {
            grid.paint(r, SOLID);
        }
        for (i, z) in level.zones.iter().enumerate() {
            for r in &z.rects {
                grid.paint(r, i as u16);
            }
        }
        grid
    }

    fn paint(&mut self, r: &IRect, v: u16) {
        for y in r.y0.max(self.y0)..r.y1.min(self.y0 + self.h) {
            for x in r.x0.max(self.x0)..r.x1.min(self.x0 + self.w) {
                let i = ((y - self.y0) * self.w + (x - self.x0)) as usize;
                if let Some(c) = self.cells.get_mut(i) {
                    *c = v;
                }
            }
        }
    }

    /// The cell at (x, y); outside the painted area is [`OUTSIDE`].
    pub(crate) fn get(&self, x: i32, y: i32) -> u16 {
        if x < self.x0 || y < self.y0 || x >= self.x0 + self.w || y >= self.y0 + self.h {
            return OUTSIDE;
        }
        self.cells
            .get(((y - self.y0) * self.w + (x - self.x0)) as usize)
            .copied()
            .unwrap_or(OUTSIDE)
    }

    /// Every wall face of the storey, merged into runs. Faces can only lie on the edges of
    /// zone rectangles, so only those are visited (not the whole grid).
    pub(crate) fn wall_runs(&self, level: &Level) -> Vec<WallRun> {
        // (normal, line, position along the line, key) of every boundary face.
        let mut faces: Vec<(Dir, i32, i32, Key)> = Vec::new();
        for z in &level.zones {
            for r in &z.rects {
                for x in r.x0..r.x1 {
                    // Bottom edge: free cell (x, y0), other (x, y0 − 1), face looks +y.
                    if let Some(k) = self.face(level, (x, r.y0), (x, r.y0 - 1), (0, -1)) {
                        faces.push((Dir::PY, r.y0, x, k));
                    }
                    if let Some(k) = self.face(level, (x, r.y1 - 1), (x, r.y1), (0, 1)) {
                        faces.push((Dir::NY, r.y1, x, k));
                    }
                }
                for y in r.y0..r.y1 {
                    if let Some(k) = self.face(level, (r.x0, y), (r.x0 - 1, y), (-1, 0)) {
                        faces.push((Dir::PX, r.x0, y, k));
                    }
                    if let Some(k) = self.face(level, (r.x1 - 1, y), (r.x1, y), (1, 0)) {
                        faces.push((Dir::NX, r.x1, y, k));
                    }
                }
            }
        }
        faces.sort_by_key(|f| (f.0.index(), f.1, f.2));
        let mut runs: Vec<WallRun> = Vec::new();
        for (normal, line, at, k) in faces {
            if let Some(last) = runs.last_mut() {
                let same = last.normal == normal
                    && last.line == line
                    && last.b == at
                    && last.zone == k.zone
                    && last.lo.to_bits() == k.lo
                    && last.hi.to_bits() == k.hi
                    && last.exterior == k.exterior;
                if same {
                    last.b = at + 1;
                    continue;
                }
            }
            runs.push(WallRun {
                zone: k.zone,
                normal,
                line,
                a: at,
                b: at + 1,
                lo: f32::from_bits(k.lo),
                hi: f32::from_bits(k.hi),
                exterior: k.exterior,
            });
        }
        runs
    }

    /// The face looking into cell `free` from cell `other` (one step `step` away), if any.
    fn face(
        &self,
        level: &Level,
        free: (i32, i32),
        other: (i32, i32),
        step: (i32, i32),
    ) -> Option<Key> {
        let a = self.get(free.0, free.1);
        if a >= SOLID {
            return None;
        }
        let b = self.get(other.0, other.1);
        if a == b {
            return None;
        }
        let za = level.zones.get(a as usize)?;
        let lo = match level.zones.get(b as usize) {
            Some(zb) if zb.top >= za.top => return None,
            Some(zb) => zb.top,
            None => 0.0,
        };
        // Outdoors if the wall ends in `OUTSIDE` within 0.5 m.
        let exterior = b >= SOLID
            && (0..5).any(|k| self.get(other.0 + step.0 * k, other.1 + step.1 * k) == OUTSIDE);
        Some(Key {
            zone: a as usize,
            lo: lo.to_bits(),
            hi: za.top.to_bits(),
            exterior,
        })
    }
}

/// What must match for neighbouring faces to merge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Key {
    zone: usize,
    lo: u32,
    hi: u32,
    exterior: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::DefaultWorldConfig;
    use crate::procedural::plan;

    #[test]
    fn a_corridor_has_walls_on_both_sides() {
        let plan = plan::build(&DefaultWorldConfig::default(), 1);
        let level = &plan.levels[1];
        let grid = Grid::new(level);
        let runs = grid.wall_runs(level);
        // Building 0's corridor on storey 1 is zone 0: walls at y = 7.8 m (facing +y) and
        // y = 10.2 m (facing −y), broken by doors.
        let south: Vec<&WallRun> = runs
            .iter()
            .filter(|r| r.zone == 0 && r.normal == Dir::PY)
            .collect();
        let north: Vec<&WallRun> = runs
            .iter()
            .filter(|r| r.zone == 0 && r.normal == Dir::NY)
            .collect();
        assert!(south.iter().any(|r| r.line == 78 && r.lo == 0.0));
        assert!(north.iter().any(|r| r.line == 102 && r.lo == 0.0));
        // Lintels over the doors.
        assert!(south.iter().any(|r| r.lo > 0.0));
        // The west end wall is an outer wall.
        assert!(
            runs.iter()
                .any(|r| r.zone == 0 && r.normal == Dir::PX && r.line == 3 && r.exterior)
        );
    }
}
