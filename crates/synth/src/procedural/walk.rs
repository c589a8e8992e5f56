//! Labels and the walk graph, both from the plan alone (so no variant can change them).
//!
//! Regions: one per zone rectangle, labelled with the zone's place; door openings carry the
//! label of the room, stairwell or bridge they lead into, and a stairwell's regions reach up to
//! the next storey's floor (the shaft is open between storeys).
//!
//! Walk graph: a lattice of nodes in every corridor, lobby and bridge rectangle (one line along
//! the middle of a corridor, nodes every 1.5 m; a lattice of at least 4 m in halls, with furniture between), a node on the shared
//! edge where two such rectangles meet, and for every open doorway a node in the opening with an
//! approach node on each side, joined to the nearest lattice node. Open rooms get a line of
//! nodes straight in from the door, and stairwells their climb (see [`super::stairs`]). Every
//! edge stays inside one convex rectangle or crosses a doorway square on, so no edge goes through
//! a wall; furniture is later kept off all edges.

use super::plan::{CELL, DoorState, IRect, Level, Opening, Plan, ZoneKind};
use super::stairs;
use crate::world::{Region, WalkGraph, WalkNode};
use nalgebra::{Point2, Point3};
use std::collections::HashMap;

/// Longest edge of the graph, metres: longer straight stretches get intermediate nodes, so
/// trajectories can turn or pause anywhere along them.
pub(crate) const MAX_EDGE: f32 = 2.0;

/// Margin and spacing of the lattice of walk nodes in halls, metres.
const LOBBY: (f32, f32) = (1.3, 4.0);

/// Positions of a hall's lattice of walk nodes across `[lo, hi]` (before long edges are
/// split), so furniture can be put between them.
pub(crate) fn lobby_lattice(lo: f32, hi: f32) -> Vec<f32> {
    positions(lo, hi, LOBBY.0, LOBBY.1, true)
}

/// Regions of every level, in level, zone, rectangle order.
pub(crate) fn regions(plan: &Plan) -> Vec<Region> {
    let mut out = Vec::new();
    for level in &plan.levels {
        for zone in &level.zones {
            let ceiling_z = if zone.kind == ZoneKind::Stair && !level.top {
                level.next_z
            } else {
                level.floor_z + zone.top
            };
            for r in &zone.rects {
                out.push(Region {
                    min: r.min_m(),
                    max: r.max_m(),
                    floor_z: level.floor_z,
                    ceiling_z,
                    place: zone.place.clone(),
                });
            }
        }
    }
    out
}

/// Builds the walk graph; node regions index into `regions`.
pub(crate) fn graph(plan: &Plan, regions: &[Region]) -> WalkGraph {
    let mut g = Builder::default();
    // The stairs first: their landing nodes are where stairwell doors lead.
    let mut landings: HashMap<(usize, usize), usize> = HashMap::new();
    for (li, level) in plan.levels.iter().enumerate() {
        for shaft in &level.shafts {
            let l = g.node(stairs::landing_node(level, shaft));
            landings.insert((li, shaft.zone), l);
        }
    }
    for (li, level) in plan.levels.iter().enumerate() {
        for shaft in &level.shafts {
            let climb = stairs::climb(level, shaft);
            if climb.is_empty() {
                continue;
            }
            let next = plan.levels.get(li + 1).and_then(|up| {
                up.shafts
                    .iter()
                    .find(|s| s.building == shaft.building)
                    .and_then(|s| landings.get(&(li + 1, s.zone)))
            });
            let Some(&next) = next else { continue };
            let mut prev = landings.get(&(li, shaft.zone)).copied();
            for p in climb {
                let n = g.node(p);
                if let Some(a) = prev {
                    g.edge(a, n);
                }
                prev = Some(n);
            }
            if let Some(a) = prev {
                g.edge(a, next);
            }
        }
        lattices(&mut g, level, li, &landings);
    }
    g.split_long_edges(MAX_EDGE);
    let nodes = g
        .nodes
        .iter()
        .map(|&p| WalkNode {
            p,
            region: regions.iter().position(|r| r.contains(&p)).unwrap_or(0),
        })
        .collect();
    WalkGraph {
        nodes,
        edges: g.edges,
    }
}

/// Nodes and edges of one level's corridors, halls, bridge, doorways and rooms.
fn lattices(g: &mut Builder, level: &Level, li: usize, landings: &HashMap<(usize, usize), usize>) {
    let z = level.floor_z;
    // Lattices of the walkable rectangles.
    let mut lattice: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    let mut walkable: Vec<(usize, usize, IRect)> = Vec::new();
    for (zi, zone) in level.zones.iter().enumerate() {
        let (along, across, spacing, sparse) = match zone.kind {
            ZoneKind::Corridor | ZoneKind::Bridge => (0.9, 1.2, 1.5, false),
            ZoneKind::Lobby => (LOBBY.0, LOBBY.0, LOBBY.1, true),
            _ => continue,
        };
        for (ri, r) in zone.rects.iter().enumerate() {
            let (mx, my) = if r.w() >= r.h() {
                (along, across)
            } else {
                (across, along)
            };
            let (lo, hi) = (r.min_m(), r.max_m());
            let xs = positions(lo[0], hi[0], mx, spacing, sparse);
            let ys = positions(lo[1], hi[1], my, spacing, sparse);
            let mut ids = Vec::with_capacity(xs.len() * ys.len());
            for &y in &ys {
                for &x in &xs {
                    ids.push(g.node(Point3::new(x, y, z)));
                }
            }
            let nx = xs.len();
            for j in 0..ys.len() {
                for i in 0..nx {
                    let k = j * nx + i;
                    if i + 1 < nx {
                        g.edge(ids[k], ids[k + 1]);
                    }
                    if j + 1 < ys.len() {
                        g.edge(ids[k], ids[k + nx]);
                    }
                }
            }
            lattice.insert((zi, ri), ids);
            walkable.push((zi, ri, *r));
        }
    }
    // Where two walkable rectangles meet: a node on the shared edge.
    for (i, &(za, ra, a)) in walkable.iter().enumerate() {
        for &(zb, rb, b) in &walkable[i + 1..] {
            let Some(mid) = shared_edge_mid(&a, &b) else {
                continue;
            };
            let pt = Point3::new(mid[0], mid[1], z);
            let j = g.node(pt);
            for key in [(za, ra), (zb, rb)] {
                if let Some(n) = nearest(g, lattice.get(&key), &pt) {
                    g.edge(j, n);
                }
            }
        }
    }
    // Doorways.
    for op in &level.openings {
        if !matches!(op.state, DoorState::Open | DoorState::Leafless) {
            continue;
        }
        let Some(door) = level.zones.get(op.zone).and_then(|z| z.rects.first()) else {
            continue;
        };
        let c = door.center_m();
        let centre = g.node(Point3::new(c[0], c[1], z));
        for (zone, sign) in [(op.outer, -op.into), (op.inner, op.into)] {
            side(
                g,
                level,
                li,
                op,
                door,
                centre,
                zone,
                sign as f32,
                &lattice,
                landings,
            );
        }
    }
}

/// Joins the doorway node `centre` to the zone on one side of the opening (`sign`: the way
/// from the door into that zone along the opening's axis).
#[allow(clippy::too_many_arguments)]
fn side(
    g: &mut Builder,
    level: &Level,
    li: usize,
    op: &Opening,
    door: &IRect,
    centre: usize,
    zone: usize,
    sign: f32,
    lattice: &HashMap<(usize, usize), Vec<usize>>,
    landings: &HashMap<(usize, usize), usize>,
) {
    let Some(z) = level.zones.get(zone) else {
        return;
    };
    let c = door.center_m();
    let (lo, hi) = (door.min_m(), door.max_m());
    // The door's face on this side, and a point just beyond it.
    let axis = if op.along_y { 1 } else { 0 };
    let face = if sign > 0.0 { hi[axis] } else { lo[axis] };
    let mut probe = c;
    probe[axis] = face + sign * 0.05;
    let Some((ri, rect)) = z.rects.iter().enumerate().find(|(_, r)| {
        let (a, b) = (r.min_m(), r.max_m());
        probe[0] >= a[0] && probe[0] <= b[0] && probe[1] >= a[1] && probe[1] <= b[1]
    }) else {
        return;
    };
    let depth = rect.max_m()[axis] - rect.min_m()[axis];
    let at = |d: f32| {
        let mut p = c;
        p[axis] = face + sign * d;
        Point3::new(p[0], p[1], level.floor_z)
    };
    match z.kind {
        ZoneKind::Corridor | ZoneKind::Lobby | ZoneKind::Bridge => {
            // The approach point, unless a lattice node is practically there already.
            let pt = at((depth / 2.0).min(1.2));
            match nearest(g, lattice.get(&(zone, ri)), &pt) {
                Some(n) if g.nodes.get(n).is_some_and(|q| (q - pt).norm() < 0.3) => {
                    g.edge(centre, n)
                }
                Some(n) => {
                    let p = g.node(pt);
                    g.edge(centre, p);
                    g.edge(p, n);
                }
                None => {
                    let p = g.node(pt);
                    g.edge(centre, p);
                }
            }
        }
        ZoneKind::Room(_) => {
            let p = g.node(at(0.8));
            g.edge(centre, p);
            let far = depth - 1.3;
            if far - 0.8 >= 0.8 {
                let f = g.node(at(far));
                g.edge(p, f);
            }
        }
        ZoneKind::Stair => {
            if let Some(&l) = landings.get(&(li, zone)) {
                g.edge(centre, l);
            }
        }
        ZoneKind::Door => {}
    }
}

/// Positions along [lo, hi]: the middle when the span is within `2 · margin`, else evenly from
/// `lo + margin` to `hi − margin`, at most `spacing` apart (at least, if `sparse`).
fn positions(lo: f32, hi: f32, margin: f32, spacing: f32, sparse: bool) -> Vec<f32> {
    let span = hi - lo - 2.0 * margin;
    if span <= 0.01 {
        return vec![(lo + hi) / 2.0];
    }
    let n = if sparse {
        (span / spacing).floor()
    } else {
        (span / spacing).ceil()
    }
    .max(1.0) as usize;
    (0..=n)
        .map(|i| lo + margin + span * i as f32 / n as f32)
        .collect()
}

/// The middle of the edge two rectangles share, if they touch along at least 1 m.
fn shared_edge_mid(a: &IRect, b: &IRect) -> Option<[f32; 2]> {
    let min_overlap = 10;
    let y_overlap = (a.y0.max(b.y0), a.y1.min(b.y1));
    let x_overlap = (a.x0.max(b.x0), a.x1.min(b.x1));
    if (a.x1 == b.x0 || b.x1 == a.x0) && y_overlap.1 - y_overlap.0 >= min_overlap {
        let x = if a.x1 == b.x0 { a.x1 } else { a.x0 };
        return Some([
            x as f32 * CELL,
            (y_overlap.0 + y_overlap.1) as f32 * CELL / 2.0,
        ]);
    }
    if (a.y1 == b.y0 || b.y1 == a.y0) && x_overlap.1 - x_overlap.0 >= min_overlap {
        let y = if a.y1 == b.y0 { a.y1 } else { a.y0 };
        return Some([
            (x_overlap.0 + x_overlap.1) as f32 * CELL / 2.0,
            y as f32 * CELL,
        ]);
    }
    None
}

/// The node of `candidates` nearest to `to`.
fn nearest(g: &Builder, candidates: Option<&Vec<usize>>, to: &Point3<f32>) -> Option<usize> {
    let d = |i: usize| g.nodes.get(i).map_or(f32::INFINITY, |p| (p - to).norm());
    candidates?
        .iter()
        .copied()
        .min_by(|&a, &b| d(a).total_cmp(&d(b)))
}

/// Nodes (deduplicated by position) and edges (deduplicated).
#[derive(Default)]
struct Builder {
    nodes: Vec<Point3<f32>>,
    index: HashMap<[i32; 3], usize>,
    edges: Vec<[usize; 2]>,
    edge_set: std::collections::HashSet<[usize; 2]>,
}

impl Builder {
    fn node(&mut self, p: Point3<f32>) -> usize {
        let key = [
            (p.x * 1000.0).round() as i32,
            (p.y * 1000.0).round() as i32,
            (p.z * 1000.0).round() as i32,
        ];
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        self.nodes.push(p);
        self.index.insert(key, self.nodes.len() - 1);
        self.nodes.len() - 1
    }

    /// Replaces every edge longer than `max` by a chain of equal pieces.
    fn split_long_edges(&mut self, max: f32) {
        let edges = std::mem::take(&mut self.edges);
        self.edge_set.clear();
        for [a, b] in edges {
            let (Some(&p), Some(&q)) = (self.nodes.get(a), self.nodes.get(b)) else {
                continue;
            };
            let pieces = ((q - p).norm() / max).ceil().max(1.0) as usize;
            let mut prev = a;
            for k in 1..pieces {
                let m = self.node(p + (q - p) * (k as f32 / pieces as f32));
                self.edge(prev, m);
                prev = m;
            }
            self.edge(prev, b);
        }
    }

    fn edge(&mut self, a: usize, b: usize) {
        if a == b {
            return;
        }
        let e = if a < b { [a, b] } else { [b, a] };
        if self.edge_set.insert(e) {
            self.edges.push(e);
        }
    }
}

/// The graph's edges on the floor of `level` as 2-D segments (stair edges excluded), for
/// keeping furniture and debris off them.
pub(crate) fn floor_segments(walk: &WalkGraph, level: &Level) -> Vec<[Point2<f32>; 2]> {
    let on = |i: usize| {
        walk.nodes
            .get(i)
            .filter(|n| (n.p.z - level.floor_z).abs() < 1e-3)
            .map(|n| n.p.xy())
    };
    walk.edges
        .iter()
        .filter_map(|&[a, b]| Some([on(a)?, on(b)?]))
        .collect()
}
