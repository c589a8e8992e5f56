//! What is set into or hung on walls and ceilings: windows, posters, notice boards, signs, fire
//! extinguishers, whiteboards; light panels (each with its [`Light`]), vents, sprinklers, smoke
//! detectors, cable trays; and, after a disaster, missing ceiling tiles.
//!
//! Positions come from the decoration stream, seeded per wall run or ceiling rectangle from the
//! zone's key, so zones that share a key (building 0's corridors on storeys 1 and 2) get the
//! same things in the same places and a variant never moves anything. What a poster, notice
//! board or sign shows (its material's seed and colour) comes from a separate content stream that
//! [`Variant::PostersChanged`](crate::world::Variant::PostersChanged) reseeds.

use super::grid::{Dir, WallRun};
use super::materials::{ACCENTS, Materials};
use super::mesh::{Frame, R2};
use super::plan::{CELL, Level, Opening, RoomKind, ZoneKind};
use super::rng::{self, Stream};
use crate::world::{Light, Material, MaterialId, Pattern, World};
use nalgebra::{Point3, Vector3};

/// How a wall item is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Mount {
    /// Set into the wall: the wall is cut around it and it lies in the wall's plane.
    Inset,
    /// A box standing out of the wall by `depth` metres (fire extinguishers).
    Box {
        /// How far it stands out, metres.
        depth: f32,
    },
}

/// A thing on a wall run.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct WallItem {
    /// Index into the level's runs.
    pub run: usize,
    /// Extent in the run's (u, v) coordinates, metres.
    pub rect: R2,
    /// How it is built.
    pub mount: Mount,
    /// Its material.
    pub material: MaterialId,
}

/// What a ceiling item is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum CeilingKind {
    /// A light panel (emissive, with a light).
    Panel,
    /// A vent grille.
    Vent,
    /// A missing tile: a hole showing the dark void above.
    Missing,
}

/// A thing set into a ceiling.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CeilingItem {
    /// The zone whose ceiling it is in.
    pub zone: usize,
    /// Which of the zone's rectangles.
    pub rect_index: usize,
    /// Extent in world (x, y), metres.
    pub rect: R2,
    /// What it is.
    pub kind: CeilingKind,
    /// Its material.
    pub material: MaterialId,
}

/// A small box hanging from a ceiling or standing on a floor (sprinklers, detectors, trays).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Fixture {
    /// Lower corner.
    pub min: Point3<f32>,
    /// Upper corner.
    pub max: Point3<f32>,
    /// Material.
    pub material: MaterialId,
}

/// The decoration of one level.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct LevelDecor {
    /// Wall items.
    pub wall: Vec<WallItem>,
    /// Ceiling items.
    pub ceiling: Vec<CeilingItem>,
    /// Small boxes.
    pub fixtures: Vec<Fixture>,
}

/// A run's frame and its face rectangle in (u, v).
pub(crate) fn run_frame(run: &WallRun, level: &Level) -> (Frame, R2) {
    let [nx, ny] = run.normal.vec();
    let n = Vector3::new(nx, ny, 0.0);
    let line = run.line as f32 * CELL;
    let offset = match run.normal {
        Dir::PX | Dir::PY => line,
        Dir::NX | Dir::NY => -line,
    };
    let frame = Frame::vertical(n, offset, level.floor_z);
    let (a, b) = (run.a as f32 * CELL, run.b as f32 * CELL);
    let (u0, u1) = match run.normal {
        Dir::NY | Dir::PX => (a, b),
        Dir::PY | Dir::NX => (-b, -a),
    };
    (frame, R2::new(u0, run.lo, u1, run.hi))
}

/// u of a world coordinate along a run's wall (x for walls along x, y otherwise).
pub(crate) fn u_of(run: &WallRun, s: f32) -> f32 {
    match run.normal {
        Dir::NY | Dir::PX => s,
        Dir::PY | Dir::NX => -s,
    }
}

/// Everything [`decorate`] needs.
pub(crate) struct Context<'a> {
    /// World seed.
    pub seed: u64,
    /// Posters changed (reseeds the content stream).
    pub posters_changed: bool,
    /// A disaster happened (ceiling tiles fall).
    pub disaster: bool,
    /// The level.
    pub level: &'a Level,
    /// Its wall runs.
    pub runs: &'a [WallRun],
    /// Base materials.
    pub mats: &'a Materials,
    /// Door height, metres.
    pub door_height: f32,
}

/// Places the decoration of one level, adding content and light-panel materials and lights to
/// `world`.
pub(crate) fn decorate(world: &mut World, cx: &Context) -> LevelDecor {
    let mut d = Placer {
        cx,
        frames: cx.runs.iter().map(|r| run_frame(r, cx.level)).collect(),
        out: LevelDecor::default(),
    };
    d.windows();
    for op in &cx.level.openings {
        d.door_signs(world, op);
    }
    for (i, run) in cx.runs.iter().enumerate() {
        d.run_items(world, i, run);
    }
    d.ceilings(world);
    d.out
}

struct Placer<'a> {
    cx: &'a Context<'a>,
    frames: Vec<(Frame, R2)>,
    out: LevelDecor,
}

impl Placer<'_> {
    /// True when `rect` fits on run `run` (0.1 m from its ends) clear of its items by `gap`.
    fn free(&self, run: usize, rect: R2, gap: f32) -> bool {
        let Some((_, face)) = self.frames.get(run) else {
            return false;
        };
        let inner = R2::new(face.u0 + 0.1, face.v0, face.u1 - 0.1, face.v1);
        inner.contains(&rect)
            && self
                .out
                .wall
                .iter()
                .filter(|w| w.run == run)
                .all(|w| !w.rect.grow(gap).overlaps(&rect))
    }

    fn put(&mut self, run: usize, rect: R2, mount: Mount, material: MaterialId) -> bool {
        if !self.free(run, rect, 0.15) {
            return false;
        }
        self.out.wall.push(WallItem {
            run,
            rect,
            mount,
            material,
        });
        true
    }

    /// Sets an item into run `run` at `rect` if there is room, with a material `make` creates
    /// then (so no material is made for an item that does not fit).
    fn put_new(
        &mut self,
        world: &mut World,
        run: usize,
        rect: R2,
        make: impl FnOnce(&Self, &mut World) -> MaterialId,
    ) -> bool {
        if !self.free(run, rect, 0.15) {
            return false;
        }
        let material = make(self, world);
        self.put(run, rect, Mount::Inset, material)
    }

    /// Tries up to eight random positions along run `run` for an item `w` wide spanning
    /// `v.0..v.1`; returns the new item's index.
    fn put_random(
        &mut self,
        rng: &mut Stream,
        run: usize,
        w: f32,
        v: (f32, f32),
        mount: Mount,
        material: MaterialId,
    ) -> Option<usize> {
        let face = self.frames.get(run)?.1;
        for _ in 0..8 {
            let u0 = rng::range(rng, face.u0 + 0.3, face.u1 - 0.3 - w);
            let rect = R2::new(u0, v.0, u0 + w, v.1);
            if self.free(run, rect, 0.3) {
                self.out.wall.push(WallItem {
                    run,
                    rect,
                    mount,
                    material,
                });
                return Some(self.out.wall.len() - 1);
            }
        }
        None
    }

    /// Like [`Self::put_random`], then gives the item a new content material for `key` (made
    /// only once the item is placed, so the number of materials never depends on the content
    /// stream).
    #[allow(clippy::too_many_arguments)]
    fn put_content(
        &mut self,
        world: &mut World,
        rng: &mut Stream,
        run: usize,
        w: f32,
        v: (f32, f32),
        pattern: Pattern,
        key: u64,
    ) -> Option<usize> {
        let i = self.put_random(rng, run, w, v, Mount::Inset, 0)?;
        let m = self.content(world, pattern, key, None);
        if let Some(item) = self.out.wall.get_mut(i) {
            item.material = m;
        }
        Some(i)
    }

    /// Regular windows along every outer wall of rooms, corridors, halls and the bridge.
    fn windows(&mut self) {
        let lv = self.cx.level;
        for (i, run) in self.cx.runs.iter().enumerate() {
            if !run.exterior || run.lo > 0.0 {
                continue;
            }
            let Some(zone) = lv.zones.get(run.zone) else {
                continue;
            };
            let b = usize::from(zone.place.building);
            let (w, pier, sill, head) = match zone.kind {
                ZoneKind::Room(_) | ZoneKind::Corridor => {
                    (if b == 0 { 1.4 } else { 1.2 }, 1.0, 0.9, 2.3)
                }
                ZoneKind::Lobby => (1.6, 0.8, 0.4, 2.5),
                ZoneKind::Bridge => (1.8, 0.4, 0.8, zone.top - 0.25),
                _ => continue,
            };
            let head = head.min(zone.top - 0.25);
            let material = self
                .cx
                .mats
                .window
                .get(b)
                .copied()
                .unwrap_or(self.cx.mats.frame);
            let Some(&(_, face)) = self.frames.get(i) else {
                continue;
            };
            let usable = face.w() - 0.8;
            let n = ((usable + pier) / (w + pier)).floor().max(0.0) as usize;
            if n == 0 {
                continue;
            }
            let total = n as f32 * w + (n - 1) as f32 * pier;
            let start = face.u0 + (face.w() - total) / 2.0;
            for k in 0..n {
                let u0 = start + k as f32 * (w + pier);
                self.put(i, R2::new(u0, sill, u0 + w, head), Mount::Inset, material);
            }
        }
    }

    /// The run of `level` with this normal and line, at floor level (or at `lo`), in `zone`,
    /// whose face contains the interval `u0..u1`.
    fn find_run(
        &self,
        zone: usize,
        normal: Dir,
        line: i32,
        lo: f32,
        u0: f32,
        u1: f32,
    ) -> Option<usize> {
        self.cx.runs.iter().enumerate().position(|(i, r)| {
            r.zone == zone
                && r.normal == normal
                && r.line == line
                && (r.lo - lo).abs() < 1e-4
                && self
                    .frames
                    .get(i)
                    .is_some_and(|(_, f)| f.u0 <= u0 && f.u1 >= u1)
        })
    }

    /// Room-number signs beside room doors, exit signs over stairwell doors, a lamp and a
    /// storey sign inside the stairwell, signs over the bridge's ends.
    fn door_signs(&mut self, world: &mut World, op: &Opening) {
        let lv = self.cx.level;
        let (Some(door), Some(outer), Some(inner)) = (
            lv.zones.get(op.zone).and_then(|z| z.rects.first()).copied(),
            lv.zones.get(op.outer),
            lv.zones.get(op.inner),
        ) else {
            return;
        };
        // The face of the wall on the outer side, and on the inner side.
        let (lo_line, hi_line, s0, s1) = if op.along_y {
            (
                door.y0,
                door.y1,
                door.x0 as f32 * CELL,
                door.x1 as f32 * CELL,
            )
        } else {
            (
                door.x0,
                door.x1,
                door.y0 as f32 * CELL,
                door.y1 as f32 * CELL,
            )
        };
        let (out_normal, out_line, in_normal, in_line) = match (op.along_y, op.into > 0) {
            (true, true) => (Dir::NY, lo_line, Dir::PY, hi_line),
            (true, false) => (Dir::PY, hi_line, Dir::NY, lo_line),
            (false, true) => (Dir::NX, lo_line, Dir::PX, hi_line),
            (false, false) => (Dir::PX, hi_line, Dir::NX, lo_line),
        };
        let building = u64::from(inner.place.building);
        let key = rng::hash(&[outer.key, door.x0 as u64, door.y0 as u64]);
        match inner.kind {
            ZoneKind::Room(_) => {
                // Beside the latch, at eye height; the other side if that is taken.
                let sides = if op.hinge_low {
                    [(s1 + 0.12, s1 + 0.37), (s0 - 0.37, s0 - 0.12)]
                } else {
                    [(s0 - 0.37, s0 - 0.12), (s1 + 0.12, s1 + 0.37)]
                };
                for (a, b) in sides {
                    let probe = self.run_at(op.outer, out_normal, out_line, 0.0, a, b);
                    if let Some((run, u0, u1)) = probe {
                        let rect = R2::new(u0, 1.45, u1, 1.62);
                        if self.free(run, rect, 0.05) {
                            let m = self.content(world, Pattern::Sign, key, Some(building));
                            self.out.wall.push(WallItem {
                                run,
                                rect,
                                mount: Mount::Inset,
                                material: m,
                            });
                            break;
                        }
                    }
                }
            }
            ZoneKind::Stair => {
                let top = self.cx.door_height;
                if let Some((run, u0, u1)) =
                    self.run_at(op.outer, out_normal, out_line, top, s0 + 0.3, s1 - 0.3)
                {
                    let rect = R2::new(u0, top + 0.15, u1, top + 0.33);
                    self.put_new(world, run, rect, |p, w| p.exit_sign(w, key));
                }
                // Inside: a lamp over the door and a big storey number beside it.
                if let Some((run, u0, u1)) =
                    self.run_at(op.inner, in_normal, in_line, top, s0 + 0.2, s1 - 0.2)
                {
                    let rect = R2::new(u0, top + 0.35, u1, top + 0.6);
                    self.put_new(world, run, rect, |p, w| p.lamp(w, run, rect));
                }
                let skey = rng::hash(&[rng::text("storey sign"), building, u64::from(lv.storey)]);
                if let Some((run, u0, u1)) =
                    self.run_at(op.inner, in_normal, in_line, 0.0, s0 - 0.75, s0 - 0.3)
                {
                    let rect = R2::new(u0, 1.45, u1, 1.9);
                    self.put_new(world, run, rect, |p, w| {
                        p.content(w, Pattern::Sign, skey, Some(building))
                    });
                }
            }
            ZoneKind::Bridge => {
                let top = lv.zones.get(op.zone).map_or(self.cx.door_height, |z| z.top);
                if let Some((run, u0, u1)) =
                    self.run_at(op.outer, out_normal, out_line, top, s0 + 0.4, s1 - 0.4)
                {
                    let rect = R2::new(u0, top + 0.08, u1, top + 0.38);
                    self.put_new(world, run, rect, |p, w| {
                        p.content(w, Pattern::Sign, key, Some(building))
                    });
                }
            }
            _ => {}
        }
    }

    /// The run of `zone` on (`normal`, `line`) at height `lo` covering world interval `a..b`
    /// along the wall, with that interval in u.
    fn run_at(
        &self,
        zone: usize,
        normal: Dir,
        line: i32,
        lo: f32,
        a: f32,
        b: f32,
    ) -> Option<(usize, f32, f32)> {
        let probe = WallRun {
            zone,
            normal,
            line,
            a: 0,
            b: 0,
            lo,
            hi: lo,
            exterior: false,
        };
        let (ua, ub) = (u_of(&probe, a), u_of(&probe, b));
        let (u0, u1) = (ua.min(ub), ua.max(ub));
        self.find_run(zone, normal, line, lo, u0, u1)
            .map(|r| (r, u0, u1))
    }

    /// Random items on one run: posters, notice boards, extinguishers, whiteboards.
    fn run_items(&mut self, world: &mut World, i: usize, run: &WallRun) {
        let lv = self.cx.level;
        if run.lo > 0.0 || run.exterior {
            return;
        }
        let Some(zone) = lv.zones.get(run.zone) else {
            return;
        };
        let len = run.len_m();
        if len < 1.0 {
            return;
        }
        let mut rng = rng::stream(&[
            self.cx.seed,
            rng::text("decor"),
            zone.key,
            run.key()[0],
            run.key()[1],
            run.key()[2],
            run.key()[3],
        ]);
        let key = |k: u64| rng::hash(&[zone.key, run.key()[0], run.key()[1], run.key()[2], k]);
        let density = 0.05 + 0.15 * ((zone.key >> 16) % 8) as f32 / 7.0;
        match zone.kind {
            ZoneKind::Corridor | ZoneKind::Lobby => {
                if rng::chance(&mut rng, len / 14.0) {
                    let (w, h) = if rng::chance(&mut rng, 0.5) {
                        (1.2, 0.9)
                    } else {
                        (0.9, 0.6)
                    };
                    let v0 = rng::range(&mut rng, 1.0, 1.2);
                    self.put_content(
                        world,
                        &mut rng,
                        i,
                        w,
                        (v0, v0 + h),
                        Pattern::NoticeBoard,
                        key(1),
                    );
                }
                if rng::chance(&mut rng, len / 16.0) {
                    let red = self.cx.mats.red;
                    // Room is sought for the extinguisher and its sign above it together.
                    let placed = self.put_random(
                        &mut rng,
                        i,
                        0.2,
                        (0.3, 1.95),
                        Mount::Box { depth: 0.16 },
                        red,
                    );
                    if let Some(item) = placed.and_then(|ix| self.out.wall.get_mut(ix)) {
                        let r = item.rect;
                        item.rect.v1 = 0.85;
                        let m = self.content(world, Pattern::Sign, key(2), None);
                        let sign = R2::new(r.u0, 1.7, r.u1, 1.95);
                        self.out.wall.push(WallItem {
                            run: i,
                            rect: sign,
                            mount: Mount::Inset,
                            material: m,
                        });
                    }
                }
                if rng::chance(&mut rng, 0.25) {
                    // A fire alarm call point.
                    let red = self.cx.mats.red;
                    self.put_random(&mut rng, i, 0.1, (1.35, 1.47), Mount::Inset, red);
                }
                let n = (len * density + rng::range(&mut rng, 0.0, 1.0)).floor() as usize;
                for k in 0..n {
                    let w = rng::range(&mut rng, 0.45, 0.75);
                    let h = w * if rng::chance(&mut rng, 0.7) {
                        1.41
                    } else {
                        0.71
                    };
                    let v0 = rng::range(&mut rng, 1.1, 1.35);
                    self.put_content(
                        world,
                        &mut rng,
                        i,
                        w,
                        (v0, v0 + h),
                        Pattern::Poster,
                        key(10 + k as u64),
                    );
                }
            }
            ZoneKind::Room(kind) => {
                match kind {
                    RoomKind::Meeting if len >= 2.6 && rng::chance(&mut rng, 0.6) => {
                        let wb = self.cx.mats.whiteboard;
                        self.put_random(&mut rng, i, 1.8, (0.9, 2.0), Mount::Inset, wb);
                    }
                    RoomKind::Office if rng::chance(&mut rng, 0.35) => {
                        self.put_content(
                            world,
                            &mut rng,
                            i,
                            0.9,
                            (1.1, 1.7),
                            Pattern::NoticeBoard,
                            key(1),
                        );
                    }
                    _ => {}
                }
                if kind != RoomKind::Storage && rng::chance(&mut rng, 0.3 + len / 20.0) {
                    let w = rng::range(&mut rng, 0.5, 0.9);
                    let h = w * rng::range(&mut rng, 0.7, 1.3);
                    self.put_content(
                        world,
                        &mut rng,
                        i,
                        w,
                        (1.3, 1.3 + h),
                        Pattern::Poster,
                        key(2),
                    );
                }
            }
            _ => {}
        }
    }

    /// A poster, notice board or sign material for content `key`.
    fn content(
        &self,
        world: &mut World,
        pattern: Pattern,
        key: u64,
        building: Option<u64>,
    ) -> MaterialId {
        let mut rng = rng::stream(&[
            self.cx.seed,
            rng::text("content"),
            u64::from(self.cx.posters_changed),
            key,
        ]);
        let color = match (&pattern, building) {
            (Pattern::Sign, Some(b)) if !self.cx.posters_changed => {
                if b == 0 {
                    [0.15, 0.30, 0.60]
                } else {
                    [0.45, 0.15, 0.20]
                }
            }
            (Pattern::NoticeBoard, _) => [0.70, 0.55, 0.35],
            _ => rng::pick(&mut rng, &ACCENTS)
                .copied()
                .unwrap_or([0.5, 0.5, 0.5]),
        };
        let name = match pattern {
            Pattern::Sign => "sign",
            Pattern::NoticeBoard => "notice board",
            _ => "poster",
        };
        let seed = rng::seed(&mut rng);
        world.add_material(Material {
            name: name.to_string(),
            color,
            pattern,
            seed,
            emissive: 0.0,
            unlit: false,
        })
    }

    /// A lit green exit sign.
    fn exit_sign(&self, world: &mut World, key: u64) -> MaterialId {
        let mut rng = rng::stream(&[
            self.cx.seed,
            rng::text("exit"),
            u64::from(self.cx.posters_changed),
            key,
        ]);
        let seed = rng::seed(&mut rng);
        world.add_material(Material {
            name: "exit sign".to_string(),
            color: [0.10, 0.65, 0.25],
            pattern: Pattern::Sign,
            seed,
            emissive: 0.5,
            unlit: false,
        })
    }

    /// A wall lamp's material and its light, 0.15 m in front of `rect` on run `run`.
    fn lamp(&self, world: &mut World, run: usize, rect: R2) -> MaterialId {
        let m = world.add_material(Material {
            name: "wall lamp".to_string(),
            color: [1.0, 0.97, 0.90],
            pattern: Pattern::LightPanel,
            seed: rng::hash(&[self.cx.seed, run as u64]),
            emissive: 1.0,
            unlit: false,
        });
        if let Some((f, _)) = self.frames.get(run) {
            let [cu, cv] = rect.center();
            world.lights.push(Light {
                position: f.at(cu, cv) + f.n * 0.15,
                intensity: 0.6,
                on: true,
                fixture: Some(m),
            });
        }
        m
    }

    /// Light panels, vents, sprinklers, smoke detectors and cable trays; missing tiles after a
    /// disaster.
    fn ceilings(&mut self, world: &mut World) {
        let lv = self.cx.level;
        for (zi, zone) in lv.zones.iter().enumerate() {
            let style_rng = &mut rng::stream(&[self.cx.seed, rng::text("ceiling style"), zone.key]);
            let style = Style::draw(style_rng, zone.kind);
            for (ri, r) in zone.rects.iter().enumerate() {
                let rect = R2::new(r.min_m()[0], r.min_m()[1], r.max_m()[0], r.max_m()[1]);
                let z = lv.floor_z + zone.top;
                let mut rng =
                    rng::stream(&[self.cx.seed, rng::text("ceiling"), zone.key, ri as u64]);
                match zone.kind {
                    ZoneKind::Corridor | ZoneKind::Bridge => {
                        self.corridor_ceiling(world, &mut rng, &style, zi, ri, rect, z)
                    }
                    ZoneKind::Room(_) | ZoneKind::Lobby => {
                        self.room_ceiling(world, &mut rng, &style, zi, ri, rect, z)
                    }
                    ZoneKind::Stair if lv.top && ri == 0 => {
                        let [cx, cy] = rect.center();
                        self.panel(world, zi, ri, R2::centered(cx, cy, 0.6, 0.6), z, &style);
                    }
                    _ => {}
                }
                if self.cx.disaster
                    && matches!(
                        zone.kind,
                        ZoneKind::Corridor | ZoneKind::Room(_) | ZoneKind::Lobby
                    )
                {
                    let mut d = rng::stream(&[
                        self.cx.seed,
                        rng::text("missing tiles"),
                        zone.key,
                        u64::from(lv.storey),
                        ri as u64,
                    ]);
                    self.missing_tiles(&mut d, zi, ri, rect);
                }
            }
        }
    }

    /// True when `item` fits in `rect` (0.1 m in) clear of this zone rectangle's items.
    fn ceiling_free(&self, zi: usize, ri: usize, rect: &R2, item: &R2) -> bool {
        rect.grow(-0.1).contains(item)
            && self
                .out
                .ceiling
                .iter()
                .filter(|c| c.zone == zi && c.rect_index == ri)
                .all(|c| !c.rect.grow(0.05).overlaps(item))
    }

    fn panel(&mut self, world: &mut World, zi: usize, ri: usize, item: R2, z: f32, style: &Style) {
        let m = world.add_material(Material {
            name: "light panel".to_string(),
            color: style.light,
            pattern: Pattern::LightPanel,
            // From the zone's key, so corridors meant to look alike have alike panels.
            seed: rng::hash(&[
                self.cx.seed,
                self.cx.level.zones.get(zi).map_or(0, |z| z.key),
                ri as u64,
                self.out.ceiling.iter().filter(|c| c.zone == zi).count() as u64,
            ]),
            emissive: 1.0,
            unlit: false,
        });
        let [cx, cy] = item.center();
        let intensity = (item.w() * item.h() / 0.72).clamp(0.4, 1.5);
        world.lights.push(Light {
            position: Point3::new(cx, cy, z - 0.05),
            intensity,
            on: true,
            fixture: Some(m),
        });
        self.out.ceiling.push(CeilingItem {
            zone: zi,
            rect_index: ri,
            rect: item,
            kind: CeilingKind::Panel,
            material: m,
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn corridor_ceiling(
        &mut self,
        world: &mut World,
        rng: &mut Stream,
        style: &Style,
        zi: usize,
        ri: usize,
        rect: R2,
        z: f32,
    ) {
        // Work in (along, across) coordinates, mapping back to (x, y).
        let along_x = rect.w() >= rect.h();
        let to_xy = |a0: f32, c0: f32, a1: f32, c1: f32| {
            if along_x {
                R2::new(a0, c0, a1, c1)
            } else {
                R2::new(c0, a0, c1, a1)
            }
        };
        let (a_lo, a_hi, c_lo, c_hi) = if along_x {
            (rect.u0, rect.u1, rect.v0, rect.v1)
        } else {
            (rect.v0, rect.v1, rect.u0, rect.u1)
        };
        let centre = (c_lo + c_hi) / 2.0;
        let snap = |x: f32| (x / 0.6).round() * 0.6;
        let (pl, pw) = if style.across {
            (style.panel.1, style.panel.0)
        } else {
            style.panel
        };
        let mut a = snap(a_lo + style.spacing / 2.0);
        let mut k = 0;
        while a + pl < a_hi {
            let side = if style.zigzag {
                if k % 2 == 0 { -0.6 } else { 0.6 }
            } else {
                0.0
            };
            let c0 = snap(centre + side - pw / 2.0);
            let item = to_xy(a, c0, a + pl, c0 + pw);
            if self.ceiling_free(zi, ri, &rect, &item) {
                self.panel(world, zi, ri, item, z, style);
            }
            // A vent between some panels, off to one side.
            if style.vent_every > 0 && k % style.vent_every == style.vent_every / 2 {
                let va = snap(a + style.spacing / 2.0);
                let vc = if rng::chance(rng, 0.5) {
                    snap(c_lo + 0.3)
                } else {
                    snap(c_hi - 0.9)
                };
                let vent = to_xy(va, vc, va + 0.6, vc + 0.6);
                if self.ceiling_free(zi, ri, &rect, &vent) {
                    self.out.ceiling.push(CeilingItem {
                        zone: zi,
                        rect_index: ri,
                        rect: vent,
                        kind: CeilingKind::Vent,
                        material: self.cx.mats.vent,
                    });
                }
            }
            a += style.spacing;
            k += 1;
        }
        // Sprinklers on a line off the centre, detectors now and then, perhaps a cable tray.
        let mut s = a_lo + rng::range(rng, 0.8, 2.0);
        while s < a_hi - 0.5 {
            let c = centre + rng::range(rng, -0.7, 0.7);
            let (x, y) = if along_x { (s, c) } else { (c, s) };
            self.hanging(rect, zi, ri, x, y, z, 0.06, 0.06, self.cx.mats.metal);
            if rng::chance(rng, 0.2) {
                let c2 = centre + rng::range(rng, -0.5, 0.5);
                let (x, y) = if along_x {
                    (s + 1.0, c2)
                } else {
                    (c2, s + 1.0)
                };
                self.hanging(rect, zi, ri, x, y, z, 0.14, 0.05, self.cx.mats.white);
            }
            s += rng::range(rng, 2.4, 3.6);
        }
        if style.tray {
            let c0 = c_lo + 0.35;
            let r = to_xy(a_lo + 0.05, c0, a_hi - 0.05, c0 + 0.3);
            self.out.fixtures.push(Fixture {
                min: Point3::new(r.u0, r.v0, z - 0.33),
                max: Point3::new(r.u1, r.v1, z - 0.25),
                material: self.cx.mats.metal,
            });
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn room_ceiling(
        &mut self,
        world: &mut World,
        rng: &mut Stream,
        style: &Style,
        zi: usize,
        ri: usize,
        rect: R2,
        z: f32,
    ) {
        let snap = |x: f32| (x / 0.6).round() * 0.6;
        let nx = (rect.w() / style.grid).round().max(1.0) as usize;
        let ny = (rect.h() / style.grid).round().max(1.0) as usize;
        let (pw, ph) = if rect.w() >= rect.h() {
            style.panel
        } else {
            (style.panel.1, style.panel.0)
        };
        for j in 0..ny {
            for i in 0..nx {
                let cx = rect.u0 + (i as f32 + 0.5) * rect.w() / nx as f32;
                let cy = rect.v0 + (j as f32 + 0.5) * rect.h() / ny as f32;
                let (x0, y0) = (snap(cx - pw / 2.0), snap(cy - ph / 2.0));
                let item = R2::new(x0, y0, x0 + pw, y0 + ph);
                if self.ceiling_free(zi, ri, &rect, &item) {
                    self.panel(world, zi, ri, item, z, style);
                }
            }
        }
        let vents = 1 + (rect.w() * rect.h() / 40.0) as usize;
        for _ in 0..vents {
            for _ in 0..6 {
                let x0 = snap(rng::range(rng, rect.u0 + 0.3, rect.u1 - 0.9));
                let y0 = snap(rng::range(rng, rect.v0 + 0.3, rect.v1 - 0.9));
                let (w, h) = if rng::chance(rng, 0.5) {
                    (0.6, 0.6)
                } else {
                    (1.2, 0.3)
                };
                let vent = R2::new(x0, y0, x0 + w, y0 + h);
                if self.ceiling_free(zi, ri, &rect, &vent) {
                    self.out.ceiling.push(CeilingItem {
                        zone: zi,
                        rect_index: ri,
                        rect: vent,
                        kind: CeilingKind::Vent,
                        material: self.cx.mats.vent,
                    });
                    break;
                }
            }
        }
        let step = 3.0;
        let (sx, sy) = (
            ((rect.w() / step).round().max(1.0)) as usize,
            ((rect.h() / step).round().max(1.0)) as usize,
        );
        for j in 0..sy {
            for i in 0..sx {
                let x = rect.u0
                    + (i as f32 + 0.5) * rect.w() / sx as f32
                    + rng::range(rng, -0.2, 0.2)
                    + 0.3;
                let y = rect.v0
                    + (j as f32 + 0.5) * rect.h() / sy as f32
                    + rng::range(rng, -0.2, 0.2)
                    + 0.3;
                self.hanging(rect, zi, ri, x, y, z, 0.06, 0.06, self.cx.mats.metal);
            }
        }
        if rng::chance(rng, 0.7) {
            let x = rng::range(rng, rect.u0 + 0.5, rect.u1 - 0.5);
            let y = rng::range(rng, rect.v0 + 0.5, rect.v1 - 0.5);
            self.hanging(rect, zi, ri, x, y, z, 0.14, 0.05, self.cx.mats.white);
        }
    }

    /// A small box of side `w` hanging `h` below the ceiling at (x, y), unless it would touch a
    /// ceiling item or leave the rectangle.
    #[allow(clippy::too_many_arguments)]
    fn hanging(
        &mut self,
        rect: R2,
        zi: usize,
        ri: usize,
        x: f32,
        y: f32,
        z: f32,
        w: f32,
        h: f32,
        material: MaterialId,
    ) {
        let foot = R2::centered(x, y, w, w);
        if !self.ceiling_free(zi, ri, &rect, &foot.grow(0.05)) {
            return;
        }
        self.out.fixtures.push(Fixture {
            min: Point3::new(foot.u0, foot.v0, z - h),
            max: Point3::new(foot.u1, foot.v1, z),
            material,
        });
    }

    /// About one tile in twelve gone, where nothing is mounted.
    fn missing_tiles(&mut self, rng: &mut Stream, zi: usize, ri: usize, rect: R2) {
        let (i0, i1) = (
            (rect.u0 / 0.6).ceil() as i32,
            (rect.u1 / 0.6).floor() as i32,
        );
        let (j0, j1) = (
            (rect.v0 / 0.6).ceil() as i32,
            (rect.v1 / 0.6).floor() as i32,
        );
        for j in j0..j1 {
            for i in i0..i1 {
                if !rng::chance(rng, 0.08) {
                    continue;
                }
                let tile = R2::new(
                    i as f32 * 0.6,
                    j as f32 * 0.6,
                    (i + 1) as f32 * 0.6,
                    (j + 1) as f32 * 0.6,
                );
                let clear = self
                    .out
                    .ceiling
                    .iter()
                    .filter(|c| c.zone == zi && c.rect_index == ri)
                    .all(|c| !c.rect.overlaps(&tile))
                    && self
                        .out
                        .fixtures
                        .iter()
                        .all(|f| !R2::new(f.min.x, f.min.y, f.max.x, f.max.y).overlaps(&tile));
                if clear && rect.contains(&tile) {
                    self.out.ceiling.push(CeilingItem {
                        zone: zi,
                        rect_index: ri,
                        rect: tile,
                        kind: CeilingKind::Missing,
                        material: self.cx.mats.plenum,
                    });
                }
            }
        }
    }
}

/// How a zone's ceiling is fitted out; differs per zone key, so storeys look different.
struct Style {
    /// Panel size (along, across) for corridors, (x, y) for rooms, metres.
    panel: (f32, f32),
    /// Panels turned across the corridor.
    across: bool,
    /// Distance between corridor panels, metres.
    spacing: f32,
    /// Alternate corridor panels left and right of the centre.
    zigzag: bool,
    /// A vent after every this many panels (0: none).
    vent_every: usize,
    /// A cable tray along the corridor.
    tray: bool,
    /// Room panel grid pitch, metres.
    grid: f32,
    /// Light colour.
    light: [f32; 3],
}

impl Style {
    fn draw(rng: &mut Stream, kind: ZoneKind) -> Self {
        let panels = [(1.2, 0.6), (0.6, 0.6), (1.2, 0.3), (1.8, 0.3)];
        let panel = rng::pick(rng, &panels).copied().unwrap_or((1.2, 0.6));
        let spacing = *rng::pick(rng, &[2.4, 3.0, 3.6, 4.2]).unwrap_or(&3.0);
        let warm = rng::range(rng, 0.0, 1.0);
        Self {
            panel,
            across: rng::chance(rng, 0.3),
            spacing,
            zigzag: rng::chance(rng, 0.25),
            vent_every: rng::range_i(rng, 0, 3) as usize,
            tray: kind == ZoneKind::Corridor && rng::chance(rng, 0.35),
            grid: rng::range(rng, 2.2, 3.0),
            light: [1.0, 0.95 + 0.05 * (1.0 - warm), 0.85 + 0.15 * (1.0 - warm)],
        }
    }
}
