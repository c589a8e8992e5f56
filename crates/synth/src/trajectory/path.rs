//! The geometric path through a route's nodes, parametrised by arc length: straight runs,
//! corners rounded by quadratic Bézier arcs, dead ends kept sharp, and the speed limits of
//! corners, stairs and dead ends.

use nalgebra::Vector3;

/// Turns sharper than this (radians, 150°) are dead ends: the walker stops and turns round.
const UTURN: f64 = 150.0 * std::f64::consts::PI / 180.0;
/// Longest corner cut along each edge, metres: the arc then stays within 0.2 m of the edges.
const CORNER_CUT: f64 = 0.8;
/// Samples of a Bézier arc's length table.
const ARC_SAMPLES: usize = 16;
/// Slope (rise over run) from which an edge counts as stairs.
const STAIR_SLOPE: f64 = 0.15;
/// Top speed on stairs, m/s.
const STAIR_SPEED: f64 = 0.6;

#[derive(Clone, Debug)]
enum Shape {
    Line {
        a: Vector3<f64>,
        b: Vector3<f64>,
    },
    Bezier {
        p0: Vector3<f64>,
        c: Vector3<f64>,
        p2: Vector3<f64>,
        /// Arc length at `t = i / ARC_SAMPLES`.
        table: [f64; ARC_SAMPLES + 1],
    },
}

#[derive(Clone, Debug)]
struct Segment {
    shape: Shape,
    /// Arc length at the segment's start.
    s0: f64,
    len: f64,
    /// Regions of the route nodes before and after (for place labels off the regions).
    regions: [usize; 2],
}

/// A stretch of path with a top speed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limit {
    pub s_start: f64,
    pub s_end: f64,
    pub v: f64,
}

/// A path parametrised by arc length `s` (metres, 3-D).
#[derive(Clone, Debug)]
pub(crate) struct Path {
    segs: Vec<Segment>,
    /// Total length.
    pub total: f64,
    /// Arc positions of dead ends (sorted).
    pub uturns: Vec<f64>,
    /// Arc positions of real turns (more than 20°), dead ends and both ends (sorted): the
    /// lateral drift fades out near them.
    pub turns: Vec<f64>,
    /// Speed limits, sorted and disjoint.
    pub limits: Vec<Limit>,
    /// Region of each dead end's route node, in the order of `uturns`.
    pub uturn_regions: Vec<usize>,
}

/// A point of the path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathPoint {
    pub p: Vector3<f64>,
    /// Unit tangent (3-D).
    pub tangent: Vector3<f64>,
    /// Region of the nearer route node.
    pub region: usize,
}

impl Path {
    /// The path through `points` (position, region), with `max_speed` for the corner limits,
    /// largest yaw rate `omega` (rad/s) and lateral acceleration `a_lat` (m/s²).
    pub fn new(points: &[(Vector3<f64>, usize)], omega: f64, a_lat: f64) -> Path {
        // Drop repeated points: they have no direction.
        let mut pts: Vec<(Vector3<f64>, usize)> = Vec::with_capacity(points.len());
        for &(p, reg) in points {
            if pts.last().is_none_or(|(q, _)| (p - q).norm() > 1e-3) {
                pts.push((p, reg));
            }
        }
        let mut path = Path {
            segs: Vec::new(),
            total: 0.0,
            uturns: Vec::new(),
            turns: vec![0.0],
            limits: Vec::new(),
            uturn_regions: Vec::new(),
        };
        if pts.len() < 2 {
            let (p, reg) = pts.first().copied().unwrap_or((Vector3::zeros(), 0));
            path.segs.push(Segment {
                shape: Shape::Line { a: p, b: p },
                s0: 0.0,
                len: 0.0,
                regions: [reg, reg],
            });
            return path;
        }
        let mut start = pts[0].0;
        let mut start_region = pts[0].1;
        for i in 1..pts.len() {
            let (p, reg) = pts[i];
            let Some(&(next, _)) = pts.get(i + 1) else {
                path.push_line(start, p, [start_region, reg]);
                break;
            };
            let (u_in, len_in) = unit(p - pts[i - 1].0);
            let (u_out, len_out) = unit(next - p);
            let angle = turn_angle(u_in, u_out);
            if angle > UTURN {
                path.push_line(start, p, [start_region, reg]);
                path.uturns.push(path.total);
                path.uturn_regions.push(reg);
                path.turns.push(path.total);
                path.limits.push(Limit {
                    s_start: path.total,
                    s_end: path.total,
                    v: 0.0,
                });
                start = p;
                start_region = reg;
                continue;
            }
            let d = CORNER_CUT.min(0.4 * len_in).min(0.4 * len_out);
            if angle < 1e-3 || d < 1e-3 {
                path.push_line(start, p, [start_region, reg]);
                start = p;
                start_region = reg;
                continue;
            }
            let p0 = p - u_in * d;
            let p2 = p + u_out * d;
            path.push_line(start, p0, [start_region, reg]);
            let s_start = path.total;
            let kappa = path.push_bezier(p0, p, p2, reg);
            if angle > 20f64.to_radians() {
                path.turns.push(s_start + (path.total - s_start) / 2.0);
            }
            if kappa > 1e-9 {
                let v = (0.8 * omega / kappa).min((a_lat / kappa).sqrt());
                path.limits.push(Limit {
                    s_start,
                    s_end: path.total,
                    v,
                });
            }
            start = p2;
            start_region = reg;
        }
        path.turns.push(path.total);
        path.turns.sort_by(f64::total_cmp);
        path.limits.sort_by(|a, b| a.s_start.total_cmp(&b.s_start));
        path
    }

    fn push_line(&mut self, a: Vector3<f64>, b: Vector3<f64>, regions: [usize; 2]) {
        let len = (b - a).norm();
        if len < 1e-9 {
            return;
        }
        let rise = (b.z - a.z).abs();
        let run = (b - a).xy().norm();
        if rise > STAIR_SLOPE * run {
            self.limits.push(Limit {
                s_start: self.total,
                s_end: self.total + len,
                v: STAIR_SPEED,
            });
        }
        self.segs.push(Segment {
            shape: Shape::Line { a, b },
            s0: self.total,
            len,
            regions,
        });
        self.total += len;
    }

    /// Adds a Bézier arc and returns its largest curvature (1/m, in 3-D).
    fn push_bezier(
        &mut self,
        p0: Vector3<f64>,
        c: Vector3<f64>,
        p2: Vector3<f64>,
        region: usize,
    ) -> f64 {
        let mut table = [0.0; ARC_SAMPLES + 1];
        let mut prev = p0;
        let mut kappa: f64 = 0.0;
        let dd = 2.0 * (p2 - 2.0 * c + p0);
        for (i, slot) in table.iter_mut().enumerate().skip(1) {
            let t = i as f64 / ARC_SAMPLES as f64;
            let q = bezier(p0, c, p2, t);
            *slot = (q - prev).norm();
            prev = q;
        }
        for i in 1..=ARC_SAMPLES {
            table[i] += table[i - 1];
        }
        for i in 0..=ARC_SAMPLES {
            let t = i as f64 / ARC_SAMPLES as f64;
            let d = bezier_d(p0, c, p2, t);
            let n = d.norm();
            if n > 1e-9 {
                kappa = kappa.max(d.cross(&dd).norm() / n.powi(3));
            }
        }
        let len = table[ARC_SAMPLES];
        if len > 1e-9 {
            self.segs.push(Segment {
                shape: Shape::Bezier { p0, c, p2, table },
                s0: self.total,
                len,
                regions: [region, region],
            });
            self.total += len;
        }
        kappa
    }

    /// The point at arc length `s` (clamped to the path). At a segment boundary the later
    /// segment is used, so the tangent at a dead end already points back.
    pub fn at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.total);
        let i = self
            .segs
            .partition_point(|seg| seg.s0 <= s)
            .saturating_sub(1)
            .min(self.segs.len().saturating_sub(1));
        let Some(seg) = self.segs.get(i) else {
            return PathPoint {
                p: Vector3::zeros(),
                tangent: Vector3::x(),
                region: 0,
            };
        };
        let local = (s - seg.s0).clamp(0.0, seg.len);
        let frac = if seg.len > 0.0 { local / seg.len } else { 0.0 };
        let region = seg.regions[usize::from(frac > 0.5)];
        match &seg.shape {
            Shape::Line { a, b } => PathPoint {
                p: a + (b - a) * frac,
                tangent: unit(b - a).0,
                region,
            },
            Shape::Bezier { p0, c, p2, table } => {
                let k = table.partition_point(|&x| x <= local).clamp(1, ARC_SAMPLES);
                let (l0, l1) = (table[k - 1], table[k]);
                let f = if l1 > l0 {
                    (local - l0) / (l1 - l0)
                } else {
                    0.0
                };
                let t = ((k - 1) as f64 + f) / ARC_SAMPLES as f64;
                PathPoint {
                    p: bezier(*p0, *c, *p2, t),
                    tangent: unit(bezier_d(*p0, *c, *p2, t)).0,
                    region,
                }
            }
        }
    }

    /// Distance (arc length) from `s` to the nearest real turn, dead end or path end.
    pub fn distance_to_turn(&self, s: f64) -> f64 {
        let i = self.turns.partition_point(|&x| x < s);
        let after = self.turns.get(i).map_or(f64::INFINITY, |x| x - s);
        let before = i
            .checked_sub(1)
            .and_then(|j| self.turns.get(j))
            .map_or(f64::INFINITY, |x| s - x);
        after.min(before)
    }

    /// The first dead end strictly after `s`, if any.
    pub fn next_uturn(&self, s: f64) -> Option<(f64, usize)> {
        let i = self.uturns.partition_point(|&x| x <= s + 1e-9);
        Some((*self.uturns.get(i)?, *self.uturn_regions.get(i)?))
    }

    /// Top speed at `s` for a walker that brakes at `a_dec` (m/s²): the limits ahead, each
    /// relaxed by the distance left to brake.
    pub fn speed_limit(&self, s: f64, a_dec: f64, horizon: f64) -> f64 {
        let first = self.limits.partition_point(|l| l.s_end < s);
        let mut v = f64::INFINITY;
        for l in &self.limits[first..] {
            if l.s_start > s + horizon {
                break;
            }
            // A stop (dead end) no longer binds once reached: the walker turns there and goes on.
            if l.s_end < s || (l.v == 0.0 && l.s_start <= s + 1e-9) {
                continue;
            }
            let gap = (l.s_start - s).max(0.0);
            v = v.min((l.v * l.v + 2.0 * a_dec * gap).sqrt());
        }
        v
    }
}

/// Unit vector and length; `x` for a zero vector.
pub(crate) fn unit(v: Vector3<f64>) -> (Vector3<f64>, f64) {
    let n = v.norm();
    if n > 1e-12 {
        (v / n, n)
    } else {
        (Vector3::x(), 0.0)
    }
}

/// Turn angle between two directions in the floor plane (0 where either has no horizontal
/// extent, as on a vertical ladder).
fn turn_angle(u: Vector3<f64>, v: Vector3<f64>) -> f64 {
    let (a, b) = (u.xy(), v.xy());
    let (na, nb) = (a.norm(), b.norm());
    if na < 1e-6 || nb < 1e-6 {
        return 0.0;
    }
    (a.perp(&b) / (na * nb)).atan2(a.dot(&b) / (na * nb)).abs()
}

fn bezier(p0: Vector3<f64>, c: Vector3<f64>, p2: Vector3<f64>, t: f64) -> Vector3<f64> {
    let u = 1.0 - t;
    p0 * (u * u) + c * (2.0 * u * t) + p2 * (t * t)
}

fn bezier_d(p0: Vector3<f64>, c: Vector3<f64>, p2: Vector3<f64>, t: f64) -> Vector3<f64> {
    (c - p0) * (2.0 * (1.0 - t)) + (p2 - c) * (2.0 * t)
}
