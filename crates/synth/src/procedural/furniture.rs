//! Furniture and, after a disaster, debris.
//!
//! Each piece is a few boxes in its own frame (footprint centred on the origin, its back towards
//! −y, standing on z = 0). Pieces go against walls (desks, cabinets, shelves, benches, plants)
//! or stand free (meeting tables with their chairs, sofa groups), placed by rejection sampling:
//! inside the zone, clear of other pieces, of the space in front of doors, of wall items they
//! would cover, and at least [`CLEARANCE`] from every walk-graph edge, so trajectories never walk
//! through a table. The furniture stream is seeded per zone and reseeded by
//! [`Variant::FurnitureMoved`](crate::world::Variant::FurnitureMoved); rooms of the same kind on
//! different storeys therefore get different arrangements.

use super::decor::{LevelDecor, Mount, run_frame};
use super::grid::WallRun;
use super::materials::Materials;
use super::mesh::{Mesh, R2};
use super::plan::{Level, RoomKind, ZoneKind};
use super::rng::{self, Stream};
use super::walk::lobby_lattice;
use crate::world::MaterialId;
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use std::f32::consts::{FRAC_PI_2, PI};

/// Distance kept between furniture and the walk graph's edges, metres.
pub(crate) const CLEARANCE: f32 = 0.45;

/// One box of a piece, in the piece's frame.
#[derive(Clone, Debug, PartialEq)]
struct Part {
    min: Vector3<f32>,
    max: Vector3<f32>,
    material: MaterialId,
}

/// A piece of furniture in its own frame.
#[derive(Clone, Debug, PartialEq)]
struct Piece {
    parts: Vec<Part>,
    /// Footprint width (x), depth (y) and height, metres.
    size: Vector3<f32>,
}

impl Piece {
    fn new(size: Vector3<f32>) -> Self {
        Self {
            parts: Vec::new(),
            size,
        }
    }

    /// Adds a box from `(x0, y0, z0)` to `(x1, y1, z1)`.
    #[allow(clippy::too_many_arguments)]
    fn part(
        mut self,
        x0: f32,
        y0: f32,
        z0: f32,
        x1: f32,
        y1: f32,
        z1: f32,
        material: MaterialId,
    ) -> Self {
        self.parts.push(Part {
            min: Vector3::new(x0, y0, z0),
            max: Vector3::new(x1, y1, z1),
            material,
        });
        self
    }
}

/// A piece placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Placed {
    piece_parts: Vec<Part>,
    size: Vector3<f32>,
    /// Centre of the footprint, metres.
    pub at: Point3<f32>,
    /// Rotation about z taking the piece's frame to the world, radians.
    pub yaw: f32,
    /// Fallen over (lying on its front).
    pub fallen: bool,
    /// World footprint (x, y), metres.
    pub foot: R2,
}

/// The world footprint of a `size` piece at `at` turned by `yaw`, lying on its front if `fallen`.
fn footprint(size: Vector3<f32>, at: Point3<f32>, yaw: f32, fallen: bool) -> R2 {
    let (w, d0, d1) = if fallen {
        (size.x, size.y / 2.0, size.y / 2.0 + size.z)
    } else {
        (size.x, -size.y / 2.0, size.y / 2.0)
    };
    let (s, c) = yaw.sin_cos();
    let corners = [(-w / 2.0, d0), (w / 2.0, d0), (w / 2.0, d1), (-w / 2.0, d1)];
    let mut r = R2::new(f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for (x, y) in corners {
        let (wx, wy) = (at.x + c * x - s * y, at.y + s * x + c * y);
        r = R2::new(r.u0.min(wx), r.v0.min(wy), r.u1.max(wx), r.v1.max(wy));
    }
    r
}

/// The catalogue.
struct Catalog<'a> {
    m: &'a Materials,
}

impl Catalog<'_> {
    fn wood(&self, rng: &mut Stream) -> MaterialId {
        rng::pick(rng, &self.m.woods)
            .copied()
            .unwrap_or(self.m.cabinet)
    }

    fn fabric(&self, rng: &mut Stream) -> MaterialId {
        rng::pick(rng, &self.m.fabrics)
            .copied()
            .unwrap_or(self.m.cabinet)
    }

    fn desk(&self, rng: &mut Stream) -> Piece {
        let w = rng::range(rng, 1.2, 1.6);
        let (d, h) = (0.7, rng::range(rng, 0.72, 0.76));
        let top = self.wood(rng);
        let leg = if rng::chance(rng, 0.5) {
            self.m.metal
        } else {
            top
        };
        Piece::new(Vector3::new(w, d, h))
            .part(-w / 2.0, -d / 2.0, h - 0.03, w / 2.0, d / 2.0, h, top)
            .part(
                -w / 2.0,
                -d / 2.0 + 0.03,
                0.0,
                -w / 2.0 + 0.03,
                d / 2.0 - 0.03,
                h - 0.03,
                leg,
            )
            .part(
                w / 2.0 - 0.03,
                -d / 2.0 + 0.03,
                0.0,
                w / 2.0,
                d / 2.0 - 0.03,
                h - 0.03,
                leg,
            )
    }

    /// A chair facing +y (backrest at −y).
    fn chair(&self, rng: &mut Stream) -> Piece {
        let f = self.fabric(rng);
        Piece::new(Vector3::new(0.5, 0.5, 0.9))
            .part(-0.03, -0.03, 0.0, 0.03, 0.03, 0.42, self.m.metal)
            .part(-0.24, -0.22, 0.42, 0.24, 0.24, 0.48, f)
            .part(-0.23, -0.25, 0.5, 0.23, -0.2, 0.9, f)
    }

    fn cabinet(&self, rng: &mut Stream, tall: bool) -> Piece {
        let w = rng::range(rng, 0.6, 1.0);
        let h = if tall {
            rng::range(rng, 1.6, 2.0)
        } else {
            rng::range(rng, 0.7, 0.8)
        };
        let m = if rng::chance(rng, 0.6) {
            self.m.cabinet
        } else {
            self.wood(rng)
        };
        Piece::new(Vector3::new(w, 0.45, h)).part(-w / 2.0, -0.225, 0.0, w / 2.0, 0.225, h, m)
    }

    fn shelf(&self, rng: &mut Stream) -> Piece {
        let w = rng::range(rng, 0.8, 1.2);
        let h = rng::range(rng, 1.8, 2.1);
        let m = self.wood(rng);
        // A frame with a dark recess so shelves read as shelves.
        Piece::new(Vector3::new(w, 0.38, h))
            .part(-w / 2.0, -0.19, 0.0, w / 2.0, -0.15, h, m)
            .part(-w / 2.0, -0.15, 0.0, -w / 2.0 + 0.03, 0.19, h, m)
            .part(w / 2.0 - 0.03, -0.15, 0.0, w / 2.0, 0.19, h, m)
            .part(
                -w / 2.0 + 0.03,
                -0.15,
                h / 2.0 - 0.02,
                w / 2.0 - 0.03,
                0.19,
                h / 2.0,
                m,
            )
            .part(-w / 2.0 + 0.03, -0.15, h - 0.03, w / 2.0 - 0.03, 0.19, h, m)
    }

    fn plant(&self, rng: &mut Stream) -> Piece {
        let s = rng::range(rng, 0.3, 0.45);
        let h = rng::range(rng, 0.9, 1.6);
        let leaf = s + rng::range(rng, 0.15, 0.35);
        Piece::new(Vector3::new(leaf, leaf, h))
            .part(-s / 2.0, -s / 2.0, 0.0, s / 2.0, s / 2.0, 0.4, self.m.pot)
            .part(
                -leaf / 2.0,
                -leaf / 2.0,
                0.4,
                leaf / 2.0,
                leaf / 2.0,
                h,
                self.m.leaves,
            )
    }

    fn bench(&self, rng: &mut Stream) -> Piece {
        let w = rng::range(rng, 1.2, 1.8);
        let m = self.wood(rng);
        Piece::new(Vector3::new(w, 0.42, 0.45))
            .part(-w / 2.0, -0.21, 0.4, w / 2.0, 0.21, 0.45, m)
            .part(
                -w / 2.0 + 0.1,
                -0.18,
                0.0,
                -w / 2.0 + 0.15,
                0.18,
                0.4,
                self.m.metal,
            )
            .part(
                w / 2.0 - 0.15,
                -0.18,
                0.0,
                w / 2.0 - 0.1,
                0.18,
                0.4,
                self.m.metal,
            )
    }

    fn table(&self, rng: &mut Stream, w: f32, d: f32) -> Piece {
        let m = self.wood(rng);
        Piece::new(Vector3::new(w, d, 0.74))
            .part(-w / 2.0, -d / 2.0, 0.71, w / 2.0, d / 2.0, 0.74, m)
            .part(
                -w / 2.0 + 0.2,
                -0.05,
                0.0,
                -w / 2.0 + 0.26,
                0.05,
                0.71,
                self.m.metal,
            )
            .part(
                w / 2.0 - 0.26,
                -0.05,
                0.0,
                w / 2.0 - 0.2,
                0.05,
                0.71,
                self.m.metal,
            )
    }

    fn sofa(&self, rng: &mut Stream, w: f32) -> Piece {
        let f = self.fabric(rng);
        Piece::new(Vector3::new(w, 0.8, 0.8))
            .part(-w / 2.0, -0.4, 0.0, w / 2.0, 0.4, 0.42, f)
            .part(-w / 2.0, -0.4, 0.42, w / 2.0, -0.2, 0.8, f)
    }

    /// Plain boxes: printers, fridges, counters, reception desks, bins, water coolers.
    fn block(&self, w: f32, d: f32, h: f32, m: MaterialId) -> Piece {
        Piece::new(Vector3::new(w, d, h)).part(-w / 2.0, -d / 2.0, 0.0, w / 2.0, d / 2.0, h, m)
    }
}

/// A wall item seen as something furniture must not stand in front of.
struct Shadow {
    foot: R2,
    /// Furniture lower than this may stand in front.
    below: f32,
}

/// Where furniture may go on one level.
pub(crate) struct Site<'a> {
    /// The level.
    pub level: &'a Level,
    /// Its wall runs.
    pub runs: &'a [WallRun],
    /// Its decoration (wall items are kept uncovered).
    pub decor: &'a LevelDecor,
    /// Walk-graph edges on its floor.
    pub segments: &'a [[Point2<f32>; 2]],
    /// Walk-graph nodes on its floor.
    pub nodes: &'a [Point2<f32>],
}

/// Places furniture on one level with the furniture stream `seed` (already reflecting the
/// variant); `disaster` topples some of it.
pub(crate) fn furnish(site: &Site, mats: &Materials, seed: u64, disaster: bool) -> Vec<Placed> {
    let mut f = Furnisher {
        site,
        cat: Catalog { m: mats },
        placed: Vec::new(),
        blocked: Vec::new(),
        shadows: Vec::new(),
    };
    f.prepare();
    for (zi, zone) in site.level.zones.iter().enumerate() {
        // Zone keys differ between storeys except for corridors meant to look alike.
        let mut rng = rng::stream(&[seed, zone.key]);
        match zone.kind {
            ZoneKind::Room(kind) => f.room(&mut rng, zi, kind),
            ZoneKind::Corridor => f.corridor(&mut rng, zi),
            ZoneKind::Lobby => f.lobby(&mut rng, zi),
            ZoneKind::Bridge => {
                let n = rng::range_i(&mut rng, 1, 2);
                for _ in 0..n {
                    let p = f.cat.plant(&mut rng);
                    f.along_wall(&mut rng, zi, p, 6);
                }
            }
            _ => {}
        }
    }
    if disaster {
        let mut rng = rng::stream(&[seed, rng::text("topple"), u64::from(site.level.storey)]);
        f.topple(&mut rng);
    }
    f.placed
}

struct Furnisher<'a> {
    site: &'a Site<'a>,
    cat: Catalog<'a>,
    placed: Vec<Placed>,
    /// Floor areas kept free (in front of doors).
    blocked: Vec<R2>,
    shadows: Vec<Shadow>,
}

impl Furnisher<'_> {
    /// Keeps doorways clear and records the wall items furniture must not cover.
    fn prepare(&mut self) {
        let lv = self.site.level;
        for op in &lv.openings {
            let Some(door) = lv.zones.get(op.zone).and_then(|z| z.rects.first()) else {
                continue;
            };
            let (a, b) = (door.min_m(), door.max_m());
            let r = R2::new(a[0], a[1], b[0], b[1]);
            let keep = if op.along_y {
                R2::new(r.u0 - 0.15, r.v0 - 1.1, r.u1 + 0.15, r.v1 + 1.1)
            } else {
                R2::new(r.u0 - 1.1, r.v0 - 0.15, r.u1 + 1.1, r.v1 + 0.15)
            };
            self.blocked.push(keep);
        }
        for item in &self.site.decor.wall {
            let Some(run) = self.site.runs.get(item.run) else {
                continue;
            };
            let (frame, _) = run_frame(run, lv);
            let depth = match item.mount {
                Mount::Inset => 0.3,
                Mount::Box { depth } => depth + 0.3,
            };
            let (p, q) = (
                frame.at(item.rect.u0, 0.0),
                frame.at(item.rect.u1, 0.0) + frame.n * depth,
            );
            let foot = R2::new(p.x.min(q.x), p.y.min(q.y), p.x.max(q.x), p.y.max(q.y));
            let below = match item.mount {
                Mount::Inset => item.rect.v0 - 0.05,
                Mount::Box { .. } => 0.0,
            };
            self.shadows.push(Shadow { foot, below });
        }
    }

    /// True when a piece of height `h` with footprint `foot` may stand in zone `zi`.
    fn fits(&self, zi: usize, foot: &R2, h: f32, ignore: Option<usize>) -> bool {
        let Some(zone) = self.site.level.zones.get(zi) else {
            return false;
        };
        let inside = zone.rects.iter().any(|r| {
            let (a, b) = (r.min_m(), r.max_m());
            R2::new(a[0] + 0.02, a[1] + 0.02, b[0] - 0.02, b[1] - 0.02).contains(foot)
        });
        inside
            && self.blocked.iter().all(|b| !b.overlaps(foot))
            && self
                .shadows
                .iter()
                .all(|s| h < s.below || !s.foot.overlaps(foot))
            && self
                .placed
                .iter()
                .enumerate()
                .all(|(i, p)| Some(i) == ignore || !p.foot.grow(0.05).overlaps(foot))
            && self
                .site
                .segments
                .iter()
                .all(|s| !segment_hits(s, &foot.grow(CLEARANCE)))
    }

    fn add(&mut self, piece: Piece, at: Point3<f32>, yaw: f32) {
        let foot = footprint(piece.size, at, yaw, false);
        self.placed.push(Placed {
            piece_parts: piece.parts,
            size: piece.size,
            at,
            yaw,
            fallen: false,
            foot,
        });
    }

    /// A random spot against a wall of zone `zi` for `piece` (back to the wall), tried `tries`
    /// times. Returns the piece's centre and yaw when it was placed.
    fn along_wall(
        &mut self,
        rng: &mut Stream,
        zi: usize,
        piece: Piece,
        tries: usize,
    ) -> Option<(Point3<f32>, f32)> {
        // In corridors only the long side walls: the ends differ between otherwise identical
        // corridors (a window here, the bridge there), and must not change what stands where.
        let long_x = self
            .site
            .level
            .zones
            .get(zi)
            .filter(|z| z.kind == ZoneKind::Corridor)
            .and_then(|z| z.rects.first())
            .map(|r| r.w() >= r.h());
        let runs: Vec<&WallRun> = self
            .site
            .runs
            .iter()
            .filter(|r| r.zone == zi && r.lo == 0.0 && r.len_m() >= piece.size.x + 0.2)
            .filter(|r| long_x.is_none_or(|x| r.normal.along_x() == x))
            .collect();
        for _ in 0..tries {
            let run = rng::pick(rng, &runs)?;
            let (frame, face) = run_frame(run, self.site.level);
            let u = rng::range(
                rng,
                face.u0 + piece.size.x / 2.0 + 0.05,
                face.u1 - piece.size.x / 2.0 - 0.05,
            );
            let at = frame.at(u, 0.0) + frame.n * (piece.size.y / 2.0 + 0.03);
            let yaw = (-frame.n.x).atan2(frame.n.y);
            let foot = footprint(piece.size, at, yaw, false);
            if self.fits(zi, &foot, piece.size.z, None) {
                self.add(piece, at, yaw);
                return Some((at, yaw));
            }
        }
        None
    }

    /// A desk against a wall with its chair in front, facing the desk.
    fn desk_with_chair(&mut self, rng: &mut Stream, zi: usize) {
        let desk = self.cat.desk(rng);
        let chair = self.cat.chair(rng);
        // Find room for both at once: a desk as deep as desk and chair together.
        let probe = Piece::new(Vector3::new(desk.size.x, desk.size.y + 0.7, desk.size.z));
        let Some((at, yaw)) = self.along_wall(rng, zi, probe, 8) else {
            return;
        };
        self.placed.pop();
        let (s, c) = yaw.sin_cos();
        let forward = Vector3::new(-s, c, 0.0);
        let desk_at = at - forward * 0.35;
        // (The probe stood 0.03 m off the wall; so does the desk.)
        self.add(desk, desk_at, yaw);
        let chair_at = desk_at + forward * (0.35 + 0.35);
        self.add(chair, chair_at, yaw + PI + rng::range(rng, -0.4, 0.4));
    }

    fn room(&mut self, rng: &mut Stream, zi: usize, kind: RoomKind) {
        let Some(r) = self
            .site
            .level
            .zones
            .get(zi)
            .and_then(|z| z.rects.first())
            .copied()
        else {
            return;
        };
        let area = r.w() as f32 * r.h() as f32 * 0.01;
        match kind {
            RoomKind::Office => {
                let desks = (area / 7.0).round().clamp(1.0, 4.0) as usize;
                for _ in 0..desks {
                    self.desk_with_chair(rng, zi);
                }
                for _ in 0..rng::range_i(rng, 1, 2) {
                    let tall = rng::chance(rng, 0.5);
                    let p = self.cat.cabinet(rng, tall);
                    self.along_wall(rng, zi, p, 6);
                }
                if rng::chance(rng, 0.5) {
                    let p = self.cat.shelf(rng);
                    self.along_wall(rng, zi, p, 6);
                }
                if rng::chance(rng, 0.6) {
                    let p = self.cat.plant(rng);
                    self.along_wall(rng, zi, p, 6);
                }
            }
            RoomKind::Meeting => {
                if !self.meeting_table(rng, zi) {
                    self.desk_with_chair(rng, zi);
                }
                let p = self.cat.cabinet(rng, false);
                self.along_wall(rng, zi, p, 6);
                let p = self.cat.plant(rng);
                self.along_wall(rng, zi, p, 6);
            }
            RoomKind::Storage => {
                for _ in 0..8 {
                    let p = self.cat.shelf(rng);
                    self.along_wall(rng, zi, p, 4);
                }
            }
            RoomKind::Kitchen => {
                let counter =
                    self.cat
                        .block(rng::range(rng, 1.8, 2.6), 0.6, 0.9, self.cat.m.counter);
                self.along_wall(rng, zi, counter, 8);
                let fridge = self.cat.block(0.7, 0.7, 1.8, self.cat.m.whiteboard);
                self.along_wall(rng, zi, fridge, 8);
                let table = self.cat.table(rng, 0.9, 0.9);
                let chairs = rng::range_i(rng, 2, 4) as usize;
                self.free_group(rng, zi, table, chairs);
            }
        }
    }

    /// A table with chairs round it somewhere in the room; false if none fits.
    fn meeting_table(&mut self, rng: &mut Stream, zi: usize) -> bool {
        let Some(r) = self
            .site
            .level
            .zones
            .get(zi)
            .and_then(|z| z.rects.first())
            .copied()
        else {
            return false;
        };
        let long = (r.w().max(r.h()) as f32 * 0.1 - 2.6).min(3.2);
        for len in [long, long - 0.8, 1.4] {
            if len < 1.2 {
                continue;
            }
            let chairs = ((len / 0.7).floor() as usize).max(1) * 2;
            let table = self.cat.table(rng, len, 1.1);
            if self.free_group(rng, zi, table.clone(), chairs) {
                return true;
            }
        }
        false
    }

    /// A free-standing table with `chairs` chairs along its long sides; false if it found no
    /// room.
    fn free_group(&mut self, rng: &mut Stream, zi: usize, table: Piece, chairs: usize) -> bool {
        let Some(r) = self
            .site
            .level
            .zones
            .get(zi)
            .and_then(|z| z.rects.first())
            .copied()
        else {
            return false;
        };
        let (a, b) = (r.min_m(), r.max_m());
        let (w, d) = (table.size.x, table.size.y);
        for _ in 0..12 {
            let yaw = if (b[0] - a[0]) >= (b[1] - a[1]) {
                0.0
            } else {
                FRAC_PI_2
            };
            let x = rng::range(rng, a[0] + 1.0, b[0] - 1.0);
            let y = rng::range(rng, a[1] + 1.0, b[1] - 1.0);
            let at = Point3::new(x, y, self.site.level.floor_z);
            let group = footprint(Vector3::new(w + 0.2, d + 1.3, 1.0), at, yaw, false);
            if !self.fits(zi, &group, 1.0, None) {
                continue;
            }
            let (s, c) = yaw.sin_cos();
            let (along, across) = (Vector3::new(c, s, 0.0), Vector3::new(-s, c, 0.0));
            self.add(table, at, yaw);
            let per_side = chairs.div_ceil(2);
            for k in 0..chairs {
                let side = if k % 2 == 0 { 1.0 } else { -1.0 };
                let i = k / 2;
                let t = (i as f32 + 0.5) / per_side as f32 - 0.5;
                let p = at + along * (t * w) + across * (side * (d / 2.0 + 0.3));
                let chair = self.cat.chair(rng);
                // Facing the table.
                let yaw_c = yaw + if side > 0.0 { PI } else { 0.0 } + rng::range(rng, -0.3, 0.3);
                self.add(chair, p, yaw_c);
            }
            return true;
        }
        false
    }

    fn corridor(&mut self, rng: &mut Stream, zi: usize) {
        let Some(r) = self
            .site
            .level
            .zones
            .get(zi)
            .and_then(|z| z.rects.first())
            .copied()
        else {
            return;
        };
        let len = r.w().max(r.h()) as f32 * 0.1;
        let n = (len / rng::range(rng, 4.0, 8.0)).round() as usize;
        let base = rng::seed(rng);
        for k in 0..n {
            // One stream per piece: a piece that finds no room does not shift the others.
            let rng = &mut rng::stream(&[base, k as u64]);
            let roll = rng::range(rng, 0.0, 1.0);
            let piece = if roll < 0.3 {
                self.cat.bench(rng)
            } else if roll < 0.55 {
                self.cat.plant(rng)
            } else if roll < 0.7 {
                let m = self.cat.m.cabinet;
                self.cat.block(
                    rng::range(rng, 0.8, 1.6),
                    0.45,
                    rng::range(rng, 1.0, 1.9),
                    m,
                )
            } else if roll < 0.8 {
                self.cat.block(0.6, 0.5, 1.0, self.cat.m.white)
            } else if roll < 0.9 {
                self.cat.block(0.35, 0.35, 1.1, self.cat.m.white)
            } else {
                let f = self.cat.fabric(rng);
                self.cat.block(0.4, 0.4, 0.7, f)
            };
            self.along_wall(rng, zi, piece, 6);
        }
    }

    fn lobby(&mut self, rng: &mut Stream, zi: usize) {
        let reception = self.cat.block(2.4, 0.8, 1.1, self.cat.m.counter);
        self.along_wall(rng, zi, reception, 10);
        for _ in 0..rng::range_i(rng, 2, 4) {
            let table = self.cat.block(0.8, 0.5, 0.4, self.cat.m.cabinet);
            self.sofa_group(rng, zi, table);
        }
        for _ in 0..rng::range_i(rng, 3, 6) {
            let p = self.cat.plant(rng);
            self.along_wall(rng, zi, p, 6);
        }
        for _ in 0..rng::range_i(rng, 1, 3) {
            let p = self.cat.bench(rng);
            self.along_wall(rng, zi, p, 6);
        }
    }

    /// A coffee table between two sofas, standing free in the hall. Halls have a lattice of
    /// walk nodes, so the group is tried at the middles of the lattice's cells.
    fn sofa_group(&mut self, rng: &mut Stream, zi: usize, table: Piece) {
        let zone_rects = self
            .site
            .level
            .zones
            .get(zi)
            .map(|z| z.rects.clone())
            .unwrap_or_default();
        let mut spots = Vec::new();
        for r in &zone_rects {
            let (a, b) = (r.min_m(), r.max_m());
            let (xs, ys) = (lobby_lattice(a[0], b[0]), lobby_lattice(a[1], b[1]));
            for y in ys.windows(2) {
                for x in xs.windows(2) {
                    spots.push(((x[0] + x[1]) / 2.0, (y[0] + y[1]) / 2.0));
                }
            }
        }
        for _ in 0..spots.len().min(12) {
            let Some(&(x, y)) = rng::pick(rng, &spots) else {
                return;
            };
            let at = Point3::new(
                x + rng::range(rng, -0.1, 0.1),
                y + rng::range(rng, -0.1, 0.1),
                self.site.level.floor_z,
            );
            for yaw in [0.0, FRAC_PI_2] {
                let group = footprint(Vector3::new(1.8, 2.55, 1.0), at, yaw, false);
                if !self.fits(zi, &group, 1.0, None) {
                    continue;
                }
                let (s, c) = yaw.sin_cos();
                let across = Vector3::new(-s, c, 0.0);
                self.add(table, at, yaw);
                for side in [-1.0f32, 1.0] {
                    let sofa = self.cat.sofa(rng, 1.6);
                    let yaw_s = yaw + if side > 0.0 { PI } else { 0.0 };
                    self.add(sofa, at + across * (side * 0.85), yaw_s);
                }
                return;
            }
        }
    }

    /// Some pieces fall on their fronts, where they land clear of walk nodes and other pieces.
    fn topple(&mut self, rng: &mut Stream) {
        for i in 0..self.placed.len() {
            if !rng::chance(rng, 0.35) {
                continue;
            }
            let Some(p) = self.placed.get(i) else {
                continue;
            };
            let yaw = p.yaw + rng::range(rng, -0.5, 0.5);
            let foot = footprint(p.size, p.at, yaw, true);
            let zone = self.site.level.zones.iter().position(|z| {
                z.rects.iter().any(|r| {
                    let (a, b) = (r.min_m(), r.max_m());
                    p.at.x >= a[0] && p.at.x <= b[0] && p.at.y >= a[1] && p.at.y <= b[1]
                })
            });
            let Some(zi) = zone else { continue };
            let inside = self.site.level.zones.get(zi).is_some_and(|z| {
                z.rects.iter().any(|r| {
                    let (a, b) = (r.min_m(), r.max_m());
                    R2::new(a[0] + 0.02, a[1] + 0.02, b[0] - 0.02, b[1] - 0.02).contains(&foot)
                })
            });
            let clear_nodes = self
                .site
                .nodes
                .iter()
                .all(|n| !foot.grow(0.35).contains(&R2::new(n.x, n.y, n.x, n.y)));
            let clear = self
                .placed
                .iter()
                .enumerate()
                .all(|(j, q)| j == i || !q.foot.overlaps(&foot));
            if !(inside && clear_nodes && clear) {
                continue;
            }
            if let Some(p) = self.placed.get_mut(i) {
                p.fallen = true;
                p.yaw = yaw;
                p.foot = foot;
            }
        }
    }
}

/// True when segment `s` meets rectangle `r` (Liang–Barsky clipping).
pub(crate) fn segment_hits(s: &[Point2<f32>; 2], r: &R2) -> bool {
    let (p, q) = (s[0], s[1]);
    let d = q - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (den, num_lo, num_hi) in [(d.x, r.u0 - p.x, r.u1 - p.x), (d.y, r.v0 - p.y, r.v1 - p.y)] {
        if den.abs() < 1e-9 {
            if num_lo > 0.0 || num_hi < 0.0 {
                return false;
            }
            continue;
        }
        let (a, b) = (num_lo / den, num_hi / den);
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        t0 = t0.max(a);
        t1 = t1.min(b);
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// The pose of a placed piece's frame.
fn pose(p: &Placed) -> Isometry3<f32> {
    let base = Isometry3::from_parts(
        Translation3::new(p.at.x, p.at.y, p.at.z),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.yaw),
    );
    if p.fallen {
        // Rotate −90° about the front bottom edge: the piece lies on its front.
        let pivot = Vector3::new(0.0, p.size.y / 2.0, 0.0);
        let fall =
            Isometry3::from_parts(
                Translation3::from(pivot),
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -FRAC_PI_2),
            ) * Isometry3::from_parts(Translation3::from(-pivot), UnitQuaternion::identity());
        base * fall
    } else {
        base
    }
}

/// Emits placed pieces.
pub(crate) fn emit(mesh: &mut Mesh, placed: &[Placed]) {
    for p in placed {
        let frame = pose(p);
        for part in &p.piece_parts {
            let c = (part.min + part.max) / 2.0;
            let half = (part.max - part.min) / 2.0;
            let iso = frame * Isometry3::translation(c.x, c.y, c.z);
            mesh.cuboid(&iso, half, part.material, p.fallen || part.min.z > 1e-3);
        }
    }
}

/// Debris after a disaster: broken concrete and plaster on the floors of corridors, rooms and
/// halls, and the fallen tiles under the holes in the ceiling. Kept 0.4 m from walk nodes (edges
/// may be partly covered: people step over rubble).
pub(crate) fn debris(mesh: &mut Mesh, site: &Site, mats: &Materials, seed: u64) {
    let lv = site.level;
    let mut rng = rng::stream(&[seed, rng::text("debris"), u64::from(lv.storey)]);
    let rects: Vec<R2> = lv
        .zones
        .iter()
        .filter(|z| {
            matches!(
                z.kind,
                ZoneKind::Corridor | ZoneKind::Room(_) | ZoneKind::Lobby | ZoneKind::Bridge
            )
        })
        .flat_map(|z| z.rects.iter())
        .map(|r| {
            let (a, b) = (r.min_m(), r.max_m());
            R2::new(a[0] + 0.3, a[1] + 0.3, b[0] - 0.3, b[1] - 0.3)
        })
        .filter(|r| r.w() > 0.0 && r.h() > 0.0)
        .collect();
    let total: f32 = rects.iter().map(|r| r.w() * r.h()).sum();
    let count = (total / 8.0) as usize;
    let clear = |x: f32, y: f32, m: f32| {
        site.nodes
            .iter()
            .all(|n| (n.x - x).hypot(n.y - y) > 0.4 + m)
    };
    for _ in 0..count {
        // A rectangle chosen by area, then a point in it.
        let mut pick = rng::range(&mut rng, 0.0, total);
        let Some(r) = rects.iter().find(|r| {
            pick -= r.w() * r.h();
            pick <= 0.0
        }) else {
            continue;
        };
        let (x, y) = (
            rng::range(&mut rng, r.u0, r.u1),
            rng::range(&mut rng, r.v0, r.v1),
        );
        let size = Vector3::new(
            rng::range(&mut rng, 0.08, 0.5),
            rng::range(&mut rng, 0.08, 0.4),
            rng::range(&mut rng, 0.03, 0.25),
        );
        if !clear(x, y, size.x.max(size.y) / 2.0) {
            continue;
        }
        let material = if rng::chance(&mut rng, 0.5) {
            mats.rubble[0]
        } else {
            mats.rubble[1]
        };
        tumbled(mesh, &mut rng, x, y, lv.floor_z, size, 0.5, material);
    }
    for item in site
        .decor
        .ceiling
        .iter()
        .filter(|c| c.kind == super::decor::CeilingKind::Missing)
    {
        let [cx, cy] = item.rect.center();
        let (x, y) = (
            cx + rng::range(&mut rng, -0.5, 0.5),
            cy + rng::range(&mut rng, -0.5, 0.5),
        );
        if !clear(x, y, 0.45) || lv.zones.get(item.zone).is_none() {
            continue;
        }
        let tile = lv
            .zones
            .get(item.zone)
            .and_then(|z| mats.storey(z.place.building, lv.storey))
            .map_or(mats.rubble[1], |p| p.ceiling);
        tumbled(
            mesh,
            &mut rng,
            x,
            y,
            lv.floor_z,
            Vector3::new(0.6, 0.6, 0.015),
            0.15,
            tile,
        );
    }
}

/// A box of `size` at (x, y) on the floor at `z`, turned at random and tilted up to `tilt`
/// radians, resting with its lowest corner just at the floor.
#[allow(clippy::too_many_arguments)]
fn tumbled(
    mesh: &mut Mesh,
    rng: &mut Stream,
    x: f32,
    y: f32,
    z: f32,
    size: Vector3<f32>,
    tilt: f32,
    material: MaterialId,
) {
    let yaw = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng::range(rng, -PI, PI));
    let a = rng::range(rng, -PI, PI);
    let axis = nalgebra::Unit::new_normalize(Vector3::new(a.cos(), a.sin(), 0.0));
    let rot = UnitQuaternion::from_axis_angle(&axis, rng::range(rng, 0.0, tilt)) * yaw;
    let half = size / 2.0;
    let low = [-1.0f32, 1.0]
        .iter()
        .flat_map(|&sx| {
            [-1.0f32, 1.0].into_iter().flat_map(move |sy| {
                [-1.0f32, 1.0]
                    .into_iter()
                    .map(move |sz| Vector3::new(sx, sy, sz))
            })
        })
        .map(|s| (rot * half.component_mul(&s)).z)
        .fold(f32::MAX, f32::min);
    let centre_z = z - low - 0.01;
    let iso = Isometry3::from_parts(Translation3::new(x, y, centre_z), rot);
    mesh.cuboid(&iso, half, material, true);
}
