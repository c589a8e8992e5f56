//! Free space of an imported model: walkable floor points on a grid, joined into a walk graph,
//! and storeys found from the heights people can stand at (the limits are in the module
//! documentation of `import`).
//!
//! Ray casts go through a uniform 2-D grid of triangle footprints: a vertical ray visits one
//! cell, a short horizontal segment a few, so sampling is about linear in the number of grid
//! points plus the triangles' footprint cells.

use crate::world::{Light, Place, PlaceKind, Region, Triangle, WalkGraph, WalkNode, World};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Grid spacing of floor samples, metres.
const SPACING: f32 = 0.5;
/// At most this many grid columns (so a campus model stays tractable).
const MAX_COLUMNS: f32 = 2.0e6;
/// A floor's normal is within ~32° of up.
const FLOOR_COS: f32 = 0.85;
/// Free height above a walkable point, metres.
const HEADROOM: f32 = 2.0;
/// Free distance around a walkable point, metres.
const CLEARANCE: f32 = 0.2;
/// Heights above the floor, metres, where clearance and edges are checked: shins and chest.
const CHECK_HEIGHTS: [f32; 2] = [0.4, 1.0];
/// Largest height difference, metres, between joined neighbours (two stair risers).
const MAX_STEP: f32 = 0.4;
/// Surfaces closer than this, metres, are one.
const SAME_Z: f32 = 0.02;
/// Connected pieces of the walk graph with fewer nodes are dropped (2 m²: a bed, a table).
const MIN_ISLAND: usize = 8;
/// Walkable heights at least this far apart, metres, are different storeys.
const STOREY_GAP: f32 = 2.0;
/// Lights placed under ceilings are this far apart, metres.
const LIGHT_SPACING: f32 = 3.0;

/// What sampling the free space found, for warnings and fallback lights.
#[derive(Clone, Debug, Default)]
pub(super) struct FreeSpace {
    /// Number of walk nodes.
    pub nodes: usize,
    /// True when the nodes have ceilings above them.
    pub covered: bool,
    /// Per walk node: grid column and the height of the surface above it, if any.
    pub ceilings: Vec<([i64; 2], Option<f32>)>,
}

/// Triangle footprints binned on a uniform grid over the model's x–y bounds.
struct Grid<'a> {
    /// The triangles.
    tris: &'a [Triangle],
    /// Lower corner of the grid.
    lo: [f32; 2],
    /// Cell edge, metres.
    cell: f32,
    /// Cells along x and y.
    n: [usize; 2],
    /// Per cell, where its triangle list starts in `items` (one extra entry at the end).
    start: Vec<usize>,
    /// Triangle indices, cell by cell.
    items: Vec<u32>,
    /// Per triangle: bounding box (min x, y, z, max x, y, z), to skip most ray tests cheaply.
    boxes: Vec<[f32; 6]>,
}

impl<'a> Grid<'a> {
    /// Bins `tris` over the rectangle `lo`–`hi`.
    fn new(tris: &'a [Triangle], lo: [f32; 2], hi: [f32; 2]) -> Self {
        let ex = (hi[0] - lo[0]).max(1e-3);
        let ey = (hi[1] - lo[1]).max(1e-3);
        let target = (tris.len() as f32).clamp(1.0, 1.0e6);
        let mut cell = (ex * ey / target).sqrt().clamp(0.25, 10.0);
        while (ex / cell).ceil() * (ey / cell).ceil() > 4.0e6 {
            cell *= 1.5;
        }
        let n = [
            ((ex / cell).ceil() as usize).max(1),
            ((ey / cell).ceil() as usize).max(1),
        ];
        let mut grid = Self {
            tris,
            lo,
            cell,
            n,
            start: vec![0; n[0] * n[1] + 1],
            items: Vec::new(),
            boxes: tris
                .iter()
                .map(|t| {
                    let (lo, hi) = (
                        t.v[0].inf(&t.v[1]).inf(&t.v[2]),
                        t.v[0].sup(&t.v[1]).sup(&t.v[2]),
                    );
                    [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]
                })
                .collect(),
        };
        for t in tris {
            let (x0, x1, y0, y1) = grid.footprint(t);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    grid.start[iy * n[0] + ix + 1] += 1;
                }
            }
        }
        for i in 1..grid.start.len() {
            grid.start[i] += grid.start[i - 1];
        }
        let mut fill = grid.start.clone();
        grid.items = vec![0; grid.start[n[0] * n[1]]];
        for (k, t) in tris.iter().enumerate() {
            let (x0, x1, y0, y1) = grid.footprint(t);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let c = iy * n[0] + ix;
                    grid.items[fill[c]] = k as u32;
                    fill[c] += 1;
                }
            }
        }
        grid
    }

    /// The cell column (x) or row (y) of a coordinate, clamped to the grid.
    fn index(&self, v: f32, axis: usize) -> usize {
        let i = ((v - self.lo[axis]) / self.cell).floor();
        if i.is_nan() || i < 0.0 {
            0
        } else {
            (i as usize).min(self.n[axis] - 1)
        }
    }

    /// The range of cells (x0, x1, y0, y1, inclusive) a triangle's footprint touches.
    fn footprint(&self, t: &Triangle) -> (usize, usize, usize, usize) {
        let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for p in &t.v {
            x0 = x0.min(p.x);
            x1 = x1.max(p.x);
            y0 = y0.min(p.y);
            y1 = y1.max(p.y);
        }
        (
            self.index(x0, 0),
            self.index(x1, 0),
            self.index(y0, 1),
            self.index(y1, 1),
        )
    }

    /// The triangles binned in cell (ix, iy).
    fn cell_items(&self, ix: usize, iy: usize) -> &[u32] {
        let c = iy * self.n[0] + ix;
        match (self.start.get(c), self.start.get(c + 1)) {
            (Some(&a), Some(&b)) => self.items.get(a..b).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Every surface a vertical line through (x, y) crosses: (height, normal z), sorted by
    /// height.
    fn column(&self, x: f32, y: f32, out: &mut Vec<(f32, f32)>) {
        out.clear();
        for &k in self.cell_items(self.index(x, 0), self.index(y, 1)) {
            let (Some(t), Some(b)) = (self.tris.get(k as usize), self.boxes.get(k as usize)) else {
                continue;
            };
            if x < b[0] || x > b[3] || y < b[1] || y > b[4] {
                continue;
            }
            let [a, b, c] = t.v;
            let d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
            if d.abs() < 1e-9 {
                continue; // seen edge-on from above: a wall
            }
            let l1 = ((b.x - x) * (c.y - y) - (c.x - x) * (b.y - y)) / d;
            let l2 = ((c.x - x) * (a.y - y) - (a.x - x) * (c.y - y)) / d;
            let l3 = 1.0 - l1 - l2;
            let eps = -1e-6;
            if l1 >= eps && l2 >= eps && l3 >= eps {
                out.push((l1 * a.z + l2 * b.z + l3 * c.z, t.normal().z));
            }
        }
        out.sort_by(|p, q| p.0.total_cmp(&q.0));
    }

    /// True when the open segment `a`–`b` crosses a triangle.
    fn blocked(&self, a: Point3<f32>, b: Point3<f32>) -> bool {
        let d = b - a;
        let (lo, hi) = (a.inf(&b), a.sup(&b));
        let (x0, x1) = (self.index(lo.x, 0), self.index(hi.x, 0));
        let (y0, y1) = (self.index(lo.y, 1), self.index(hi.y, 1));
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                for &k in self.cell_items(ix, iy) {
                    let (Some(t), Some(bx)) =
                        (self.tris.get(k as usize), self.boxes.get(k as usize))
                    else {
                        continue;
                    };
                    let apart = hi.x < bx[0]
                        || lo.x > bx[3]
                        || hi.y < bx[1]
                        || lo.y > bx[4]
                        || hi.z < bx[2]
                        || lo.z > bx[5];
                    if !apart && segment_hits(t, &a, &d) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

/// Möller–Trumbore: does `o + s·d`, 0 < s < 1, cross the triangle?
fn segment_hits(t: &Triangle, o: &Point3<f32>, d: &Vector3<f32>) -> bool {
    let e1 = t.v[1] - t.v[0];
    let e2 = t.v[2] - t.v[0];
    let p = d.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-12 {
        return false; // parallel
    }
    let inv = 1.0 / det;
    let s = o - t.v[0];
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(&e1);
    let v = d.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let along = e2.dot(&q) * inv;
    along > 1e-4 && along < 1.0 - 1e-4
}

/// A walkable point before the graph is pruned.
struct Candidate {
    /// Grid column.
    cell: [i64; 2],
    /// Floor point.
    p: Point3<f32>,
    /// Height of the surface above, if any.
    ceiling: Option<f32>,
}

/// Samples the free space of `world`: fills `world.walk` and `world.regions` (one per storey).
pub(super) fn build(world: &mut World) -> FreeSpace {
    let Some((lo, hi)) = world.bounds() else {
        return FreeSpace::default();
    };
    let grid = Grid::new(&world.triangles, [lo.x, lo.y], [hi.x, hi.y]);
    let (ex, ey) = (hi.x - lo.x, hi.y - lo.y);
    let spacing = SPACING.max((ex * ey / MAX_COLUMNS).sqrt());
    let nx = ((ex / spacing).ceil() as i64).max(1);
    let ny = ((ey / spacing).ceil() as i64).max(1);
    let at = |c: i64, lo: f32| lo + (c as f32 + 0.5) * spacing;

    // Rows in parallel; collected in order, so the graph does not depend on the thread count.
    let rows: Vec<Vec<Candidate>> = (0..ny)
        .into_par_iter()
        .map(|iy| {
            let mut found = Vec::new();
            let mut hits = Vec::new();
            for ix in 0..nx {
                let (x, y) = (at(ix, lo.x), at(iy, lo.y));
                grid.column(x, y, &mut hits);
                let mut last_floor = f32::NEG_INFINITY;
                for (i, &(z, nz)) in hits.iter().enumerate() {
                    if nz < FLOOR_COS || z - last_floor < SAME_Z {
                        continue;
                    }
                    last_floor = z;
                    let ceiling = hits[i + 1..].iter().find(|h| h.0 > z + SAME_Z).map(|h| h.0);
                    if ceiling.is_some_and(|c| c - z < HEADROOM) {
                        continue;
                    }
                    let p = Point3::new(x, y, z);
                    let crowded = CHECK_HEIGHTS.iter().any(|&h| {
                        let a = p + Vector3::new(0.0, 0.0, h);
                        [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
                            .iter()
                            .any(|&(dx, dy)| {
                                grid.blocked(a, a + Vector3::new(dx, dy, 0.0) * CLEARANCE)
                            })
                    });
                    if !crowded {
                        found.push(Candidate {
                            cell: [ix, iy],
                            p,
                            ceiling,
                        });
                    }
                }
            }
            found
        })
        .collect();
    let mut found: Vec<Candidate> = rows.into_iter().flatten().collect();
    // Indoors means under a roof; only a model without any ceiling walks on what it has.
    let covered = found.iter().any(|c| c.ceiling.is_some());
    if covered {
        found.retain(|c| c.ceiling.is_some());
    }

    let mut by_cell: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    for (i, c) in found.iter().enumerate() {
        by_cell.entry(c.cell).or_default().push(i);
    }
    let edges: Vec<[usize; 2]> = found
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, c)| {
            let mut edges = Vec::new();
            for (dx, dy) in [(1, 0), (0, 1), (1, 1), (-1, 1)] {
                let Some(others) = by_cell.get(&[c.cell[0] + dx, c.cell[1] + dy]) else {
                    continue;
                };
                let best = others
                    .iter()
                    .copied()
                    .filter(|&j| (found[j].p.z - c.p.z).abs() <= MAX_STEP)
                    .min_by(|&a, &b| {
                        (found[a].p.z - c.p.z)
                            .abs()
                            .total_cmp(&(found[b].p.z - c.p.z).abs())
                    });
                let Some(j) = best else { continue };
                let clear = CHECK_HEIGHTS.iter().all(|&h| {
                    let up = Vector3::new(0.0, 0.0, h);
                    !grid.blocked(c.p + up, found[j].p + up)
                });
                if clear {
                    edges.push([i, j]);
                }
            }
            edges
        })
        .collect();

    let keep = drop_islands(found.len(), &edges);
    let mut new_index = vec![usize::MAX; found.len()];
    let mut kept = Vec::new();
    for (i, c) in found.into_iter().enumerate() {
        if keep[i] {
            new_index[i] = kept.len();
            kept.push(c);
        }
    }
    let edges: Vec<[usize; 2]> = edges
        .into_iter()
        .filter(|&[a, b]| keep[a] && keep[b])
        .map(|[a, b]| [new_index[a], new_index[b]])
        .collect();

    let levels = storey_levels(&kept);
    world.regions = regions(&levels, lo, hi);
    let storey_of = |z: f32| {
        levels
            .iter()
            .filter(|&&l| l <= z + 0.3)
            .count()
            .saturating_sub(1)
    };
    world.walk = WalkGraph {
        nodes: kept
            .iter()
            .map(|c| WalkNode {
                p: c.p,
                region: storey_of(c.p.z).min(world.regions.len().saturating_sub(1)),
            })
            .collect(),
        edges,
    };
    FreeSpace {
        nodes: kept.len(),
        covered,
        ceilings: kept.iter().map(|c| (c.cell, c.ceiling)).collect(),
    }
}

/// Which nodes lie in connected pieces of at least [`MIN_ISLAND`] nodes (all of them, if none
/// does).
fn drop_islands(n: usize, edges: &[[usize; 2]]) -> Vec<bool> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for &[a, b] in edges {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let roots: Vec<usize> = (0..n).map(|i| root(&mut parent, i)).collect();
    let mut size = vec![0usize; n];
    for &r in &roots {
        size[r] += 1;
    }
    if size.iter().all(|&s| s < MIN_ISLAND) {
        return vec![true; n];
    }
    roots.iter().map(|&r| size[r] >= MIN_ISLAND).collect()
}

/// Floor heights of the storeys, lowest first: heights where many walk nodes stand (a stair's few
/// nodes per height do not count), at least [`STOREY_GAP`] apart.
fn storey_levels(nodes: &[Candidate]) -> Vec<f32> {
    let mut zs: Vec<f32> = nodes.iter().map(|c| c.p.z).collect();
    zs.sort_by(f32::total_cmp);
    let Some(&lowest) = zs.first() else {
        return Vec::new();
    };
    let min_count = MIN_ISLAND.max(zs.len() / 20);
    let mut groups: Vec<(f32, usize)> = Vec::new(); // (median height, count)
    let mut i = 0;
    while i < zs.len() {
        let mut j = i;
        while j < zs.len() && zs[j] - zs[i] <= 0.15 {
            j += 1;
        }
        if j - i >= min_count {
            groups.push((zs[(i + j) / 2], j - i));
        }
        i = j;
    }
    let mut levels: Vec<(f32, usize)> = Vec::new();
    for g in groups {
        match levels.last_mut() {
            Some(last) if g.0 - last.0 < STOREY_GAP => {
                if g.1 > last.1 {
                    *last = g;
                }
            }
            _ => levels.push(g),
        }
    }
    if levels.is_empty() {
        return vec![lowest];
    }
    levels.into_iter().map(|l| l.0).collect()
}

/// One region per storey over the model's footprint; one over the whole model without storeys.
fn regions(levels: &[f32], lo: Point3<f32>, hi: Point3<f32>) -> Vec<Region> {
    let region = |storey: usize, floor_z: f32, ceiling_z: f32| Region {
        min: [lo.x, lo.y],
        max: [hi.x, hi.y],
        floor_z,
        ceiling_z,
        place: Place {
            building: 0,
            storey: u8::try_from(storey).unwrap_or(u8::MAX),
            corridor: None,
            kind: PlaceKind::Room,
            axis: None,
        },
    };
    if levels.is_empty() {
        return vec![region(0, lo.z, hi.z.max(lo.z + HEADROOM))];
    }
    levels
        .iter()
        .enumerate()
        .map(|(k, &z)| {
            let top = levels.get(k + 1).copied().unwrap_or(hi.z);
            region(k, z, top.max(z + HEADROOM))
        })
        .collect()
}

/// Lights 0.2 m under the ceiling above every [`LIGHT_SPACING`]-th grid point (2.5 m above the
/// floor where there is no ceiling), for models with no light sources at all.
pub(super) fn ceiling_lights(world: &World, free: &FreeSpace) -> Vec<Light> {
    let Some((lo, hi)) = world.bounds() else {
        return Vec::new();
    };
    let spacing = SPACING.max(((hi.x - lo.x) * (hi.y - lo.y) / MAX_COLUMNS).sqrt());
    let step = ((LIGHT_SPACING / spacing).round() as i64).max(1);
    world
        .walk
        .nodes
        .iter()
        .zip(&free.ceilings)
        .filter(|(_, (cell, _))| cell[0] % step == step / 2 && cell[1] % step == step / 2)
        .map(|(node, (_, ceiling))| Light {
            position: Point3::new(
                node.p.x,
                node.p.y,
                ceiling.map_or(node.p.z + 2.5, |c| c - 0.2),
            ),
            intensity: 1.0,
            on: true,
            fixture: None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of two triangles facing +z (or −z when `down`).
    fn square(x0: f32, y0: f32, size: f32, z: f32, down: bool) -> Vec<Triangle> {
        let p = |x: f32, y: f32| Point3::new(x0 + x * size, y0 + y * size, z);
        let mut quads = [
            [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
            [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
        ];
        if down {
            for q in &mut quads {
                q.swap(1, 2);
            }
        }
        quads
            .into_iter()
            .map(|v| Triangle {
                v,
                uv: [[0.0; 2]; 3],
                material: 0,
                plane: 0,
            })
            .collect()
    }

    #[test]
    fn import_walk_two_storeys_and_low_ceiling() -> Result<(), String> {
        let mut world = World::default();
        // Storey 0: a 4 m floor with a ceiling at 3 m; storey 1: the slab's top at 3.2 m with a
        // roof at 6 m; a 1 m crawl space beside it that nobody can stand in.
        world.triangles.extend(square(0.0, 0.0, 4.0, 0.0, false));
        world.triangles.extend(square(0.0, 0.0, 4.0, 3.0, true));
        world.triangles.extend(square(0.0, 0.0, 4.0, 3.2, false));
        world.triangles.extend(square(0.0, 0.0, 4.0, 6.0, true));
        world.triangles.extend(square(5.0, 0.0, 2.0, 0.0, false));
        world.triangles.extend(square(5.0, 0.0, 2.0, 1.0, true));
        let free = build(&mut world);
        let (lower, upper): (Vec<_>, Vec<_>) = world.walk.nodes.iter().partition(|n| n.p.z < 1.0);
        if lower.len() != 64 || upper.len() != 64 || !free.covered {
            return Err(format!("{} + {} nodes", lower.len(), upper.len()));
        }
        if lower.iter().any(|n| n.p.x > 4.0 || n.region != 0) || upper.iter().any(|n| n.region != 1)
        {
            return Err("nodes in the crawl space or in the wrong storey".into());
        }
        let storeys: Vec<(u8, f32)> = world
            .regions
            .iter()
            .map(|r| (r.place.storey, r.floor_z))
            .collect();
        if storeys != vec![(0, 0.0), (1, 3.2)] {
            return Err(format!("regions {storeys:?}"));
        }
        // 8 x 8 grid per storey, 8-connected: 2 * 7 * 8 straight + 2 * 7 * 7 diagonal edges.
        if world.walk.edges.len() != 2 * (2 * 7 * 8 + 2 * 7 * 7) {
            return Err(format!("{} edges", world.walk.edges.len()));
        }
        Ok(())
    }
}
