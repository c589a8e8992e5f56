//! The 2-D plan of the default building: which rectangles of each storey are corridors, rooms,
//! lobbies, stairwells, door openings and the bridge.
//!
//! Everything here is in integer decimetres (one grid cell = 0.1 m), so walls, door openings and
//! rooms meet exactly and the wall extraction in [`super::grid`] needs no tolerances. Free space
//! is the union of the zones' rectangles, which never overlap; whatever is not painted as free
//! space is solid (walls are the 0.2 m gaps left between zones, outer walls 0.3 m).
//!
//! The two buildings are hand-drawn templates (so the corridor shapes the issue asks for exist by
//! construction: straight corridors in building 0, an L on the ground floor and C shapes above it
//! in building 1, a bridge between them on storey 1) filled by the layout stream: room widths,
//! room kinds, door positions, hinges and whether doors stand open. Storeys 1 and 2 of building 0
//! draw from the same layout stream and share their corridors' decoration key, so their corridors
//! look alike on purpose (the ambiguity real buildings have).

use super::DefaultWorldConfig;
use super::rng::{self, Stream};
use crate::world::{Place, PlaceKind};
use std::f32::consts::{FRAC_PI_2, PI};

/// Metres per grid cell.
pub(crate) const CELL: f32 = 0.1;
/// Width of a door opening, cells.
pub(crate) const DOOR_W: i32 = 10;
/// Interior size of a stair shaft (x, y), cells.
pub(crate) const SHAFT: (i32, i32) = (28, 60);
/// Origin (x, y) of building 1, cells: east of building 0 with a 10 m gap for the bridge.
const B1: (i32, i32) = (520, 18);

/// A rectangle of grid cells, half-open: `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct IRect {
    /// Lower x, cells.
    pub x0: i32,
    /// Lower y, cells.
    pub y0: i32,
    /// Upper x (exclusive), cells.
    pub x1: i32,
    /// Upper y (exclusive), cells.
    pub y1: i32,
}

impl IRect {
    /// A rectangle from its corners.
    pub(crate) const fn new(x0: i32, y0: i32, x1: i32, y1: i32) -> Self {
        Self { x0, y0, x1, y1 }
    }

    /// Moved by `(dx, dy)` cells.
    pub(crate) const fn at(self, o: (i32, i32)) -> Self {
        Self::new(self.x0 + o.0, self.y0 + o.1, self.x1 + o.0, self.y1 + o.1)
    }

    /// Width, cells.
    pub(crate) const fn w(&self) -> i32 {
        self.x1 - self.x0
    }

    /// Height, cells.
    pub(crate) const fn h(&self) -> i32 {
        self.y1 - self.y0
    }

    /// True when the two share at least one cell.
    #[cfg(test)]
    pub(crate) fn overlaps(&self, o: &IRect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// Lower corner, metres.
    pub(crate) fn min_m(&self) -> [f32; 2] {
        [self.x0 as f32 * CELL, self.y0 as f32 * CELL]
    }

    /// Upper corner, metres.
    pub(crate) fn max_m(&self) -> [f32; 2] {
        [self.x1 as f32 * CELL, self.y1 as f32 * CELL]
    }

    /// Centre, metres.
    pub(crate) fn center_m(&self) -> [f32; 2] {
        let (a, b) = (self.min_m(), self.max_m());
        [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
    }
}

/// What a room is used for; decides its furniture and floor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RoomKind {
    /// Desks and chairs along the walls.
    Office,
    /// A table with chairs, a whiteboard.
    Meeting,
    /// Shelves; vinyl floor.
    Storage,
    /// A counter, a fridge, a small table; vinyl floor.
    Kitchen,
}

/// What a zone of free space is, for geometry and furniture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ZoneKind {
    /// A corridor segment (one rectangle with one axis).
    Corridor,
    /// A room behind a door.
    Room(RoomKind),
    /// A hall.
    Lobby,
    /// A stair shaft (landing, the two flights' wells, the mid landing).
    Stair,
    /// A door opening through a wall (its ceiling is the lintel).
    Door,
    /// Half of the covered bridge.
    Bridge,
}

/// A labelled piece of free space on one storey.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Zone {
    /// What it is.
    pub kind: ZoneKind,
    /// Its rectangles (non-overlapping; one for everything but stairs and lobbies).
    pub rects: Vec<IRect>,
    /// Its place label.
    pub place: Place,
    /// Height of its ceiling above the storey's floor, metres.
    pub top: f32,
    /// Seeds its decoration; equal for zones that deliberately look alike.
    pub key: u64,
    /// Plane group: the building (0, 1) or 2 for the bridge.
    pub group: u8,
}

/// Whether a door stands open.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum DoorState {
    /// Open wide: people walk through.
    Open,
    /// Ajar: blocks the way.
    Ajar,
    /// Shut.
    Closed,
    /// No leaf at all (stairwell and bridge openings).
    Leafless,
}

/// A door opening joining two zones through a wall.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Opening {
    /// The door zone (the opening itself).
    pub zone: usize,
    /// The zone the door is reached from (corridor, lobby).
    pub outer: usize,
    /// The zone behind it (room, stair, bridge).
    pub inner: usize,
    /// True when the door's way through runs along y (the wall runs along x).
    pub along_y: bool,
    /// +1 or −1: the sign of the way from `outer` to `inner`.
    pub into: i32,
    /// Leaf state.
    pub state: DoorState,
    /// Hinge at the jamb of lower coordinate.
    pub hinge_low: bool,
    /// Opening angle of the leaf, radians (0 closed).
    pub angle: f32,
}

/// A stair shaft on one storey.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Shaft {
    /// Its stair zone on this storey.
    pub zone: usize,
    /// Interior lower corner, cells; the door is on the lower-y side.
    pub origin: (i32, i32),
    /// Building index.
    pub building: u8,
}

/// One storey of the site (both buildings and, on storey 1, the bridge).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Level {
    /// Storey index.
    pub storey: u8,
    /// Floor height, metres.
    pub floor_z: f32,
    /// Floor height of the storey above, metres.
    pub next_z: f32,
    /// The top storey (stair shafts end here).
    pub top: bool,
    /// Solid areas painted before the zones (building footprints, bridge walls).
    pub solids: Vec<IRect>,
    /// Free space.
    pub zones: Vec<Zone>,
    /// Door openings.
    pub openings: Vec<Opening>,
    /// Stair shafts.
    pub shafts: Vec<Shaft>,
}

/// The shape of a corridor, for tests and statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Shape {
    /// One straight segment.
    Straight,
    /// Two segments at a right angle.
    L,
    /// Three segments: a U.
    C,
    /// The bridge between the buildings.
    Bridge,
}

/// A corridor: one id, one or more segments.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Corridor {
    /// World-unique id.
    pub id: u16,
    /// Storey index.
    pub storey: u8,
    /// Its shape.
    pub shape: Shape,
}

/// The whole site.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Plan {
    /// Storeys, bottom up.
    pub levels: Vec<Level>,
    /// Corridors.
    pub corridors: Vec<Corridor>,
}

/// Number of storeys of each building.
pub(crate) const STOREYS: u8 = 3;

/// Which edge of a strip of rooms faces its corridor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    /// The strip's lower-y edge.
    South,
    /// The strip's upper-y edge.
    North,
}

/// Builds the plan from the layout stream of `seed`.
pub(crate) fn build(cfg: &DefaultWorldConfig, seed: u64) -> Plan {
    let mut corridors = Vec::new();
    let mut levels = Vec::new();
    for storey in 0..STOREYS {
        let floor_z = cfg.storey_height * f32::from(storey);
        let mut lb = LevelBuilder {
            cfg,
            level: Level {
                storey,
                floor_z,
                next_z: cfg.storey_height * f32::from(storey + 1),
                top: storey + 1 == STOREYS,
                solids: Vec::new(),
                zones: Vec::new(),
                openings: Vec::new(),
                shafts: Vec::new(),
            },
        };
        let b0_corridor = building0(&mut lb, seed, &mut corridors);
        let b1_corridor = building1(&mut lb, seed, &mut corridors);
        if storey == 1 {
            bridge(&mut lb, b0_corridor, b1_corridor, &mut corridors);
        }
        levels.push(lb.level);
    }
    Plan { levels, corridors }
}

/// Adds zones to one storey.
struct LevelBuilder<'a> {
    cfg: &'a DefaultWorldConfig,
    level: Level,
}

impl LevelBuilder<'_> {
    fn storey(&self) -> u8 {
        self.level.storey
    }

    fn zone(&mut self, zone: Zone) -> usize {
        self.level.zones.push(zone);
        self.level.zones.len() - 1
    }

    fn place(
        &self,
        building: u8,
        kind: PlaceKind,
        corridor: Option<u16>,
        axis: Option<f32>,
    ) -> Place {
        Place {
            building,
            storey: self.storey(),
            corridor,
            kind,
            axis,
        }
    }

    /// A corridor segment; `key_storey` is the storey whose decoration it repeats.
    fn corridor(
        &mut self,
        building: u8,
        r: IRect,
        axis: f32,
        id: u16,
        seg: u64,
        key_storey: u8,
    ) -> usize {
        let place = self.place(building, PlaceKind::Corridor, Some(id), Some(axis));
        let key = rng::hash(&[
            rng::text("corridor"),
            u64::from(building),
            u64::from(key_storey),
            seg,
        ]);
        let top = self.cfg.ceiling_height;
        self.zone(Zone {
            kind: ZoneKind::Corridor,
            rects: vec![r],
            place,
            top,
            key,
            group: building,
        })
    }

    fn lobby(&mut self, building: u8, rects: Vec<IRect>) -> usize {
        let place = self.place(building, PlaceKind::Lobby, None, None);
        let key = rng::hash(&[
            rng::text("lobby"),
            u64::from(building),
            u64::from(self.storey()),
        ]);
        let top = self.cfg.ceiling_height;
        self.zone(Zone {
            kind: ZoneKind::Lobby,
            rects,
            place,
            top,
            key,
            group: building,
        })
    }

    /// A door zone and its opening between `outer` and `inner`.
    #[allow(clippy::too_many_arguments)]
    fn opening(
        &mut self,
        r: IRect,
        outer: usize,
        inner: usize,
        along_y: bool,
        into: i32,
        state: DoorState,
        hinge_low: bool,
        angle: f32,
        top: f32,
    ) {
        let (place, group, key) = match self.level.zones.get(inner) {
            Some(z) => (
                z.place.clone(),
                z.group,
                rng::hash(&[z.key, rng::text("door")]),
            ),
            None => (self.place(0, PlaceKind::Lobby, None, None), 0, 0),
        };
        let zone = self.zone(Zone {
            kind: ZoneKind::Door,
            rects: vec![r],
            place,
            top,
            key,
            group,
        });
        self.level.openings.push(Opening {
            zone,
            outer,
            inner,
            along_y,
            into,
            state,
            hinge_low,
            angle,
        });
    }

    /// Splits `strip` into rooms along x, each with a door onto `corridor` on the `side` edge
    /// (the wall between the strip and the corridor is two cells thick).
    fn rooms_along(
        &mut self,
        building: u8,
        strip: IRect,
        side: Side,
        corridor: usize,
        rng: &mut Stream,
    ) {
        let corridor_id = self
            .level
            .zones
            .get(corridor)
            .and_then(|z| z.place.corridor);
        let mut x = strip.x0;
        let (min_w, max_w) = (32, 66);
        let mut index = 0u64;
        while x < strip.x1 {
            let remaining = strip.x1 - x;
            let w = if remaining <= max_w {
                remaining
            } else {
                let w = rng::range_i(rng, min_w, max_w);
                if remaining - w - 2 < min_w {
                    remaining - 2 - min_w
                } else {
                    w
                }
            };
            let r = IRect::new(x, strip.y0, x + w, strip.y1);
            x += w + 2;
            let kind = room_kind(rng, r);
            let door_x = rng::range_i(rng, r.x0 + 5, r.x1 - DOOR_W - 5);
            let roll = rng::range(rng, 0.0, 1.0);
            let open = self.cfg.open_doors.clamp(0.0, 1.0);
            let (state, angle) = if roll < open {
                (DoorState::Open, rng::range(rng, 80.0, 100.0).to_radians())
            } else if roll < open + (1.0 - open) * 0.4 {
                (DoorState::Ajar, rng::range(rng, 20.0, 40.0).to_radians())
            } else {
                (DoorState::Closed, 0.0)
            };
            let hinge_low = rng::chance(rng, 0.5);
            if r.w() < 20 {
                continue;
            }
            let place = self.place(building, PlaceKind::Room, corridor_id, None);
            let key = rng::hash(&[
                rng::text("room"),
                u64::from(building),
                u64::from(self.storey()),
                u64::from(strip.x0 as u32),
                u64::from(strip.y0 as u32),
                index,
            ]);
            index += 1;
            let top = self.cfg.ceiling_height;
            let room = self.zone(Zone {
                kind: ZoneKind::Room(kind),
                rects: vec![r],
                place,
                top,
                key,
                group: building,
            });
            let (door, into) = match side {
                Side::North => (IRect::new(door_x, r.y1, door_x + DOOR_W, r.y1 + 2), -1),
                Side::South => (IRect::new(door_x, r.y0 - 2, door_x + DOOR_W, r.y0), 1),
            };
            let door_top = self.cfg.door_height;
            self.opening(
                door, corridor, room, true, into, state, hinge_low, angle, door_top,
            );
        }
    }

    /// A stair shaft with interior lower corner `o`, its door on the lower-y side onto `outer`.
    fn stair(&mut self, building: u8, o: (i32, i32), outer: usize) {
        let (w, d) = SHAFT;
        let rects = vec![
            IRect::new(0, 0, w, 16).at(o),
            IRect::new(0, 16, 13, 46).at(o),
            IRect::new(15, 16, w, 46).at(o),
            IRect::new(0, 46, w, d).at(o),
        ];
        let place = self.place(building, PlaceKind::Stairwell, None, None);
        let key = rng::hash(&[
            rng::text("stair"),
            u64::from(building),
            u64::from(self.storey()),
        ]);
        let top = if self.level.top {
            self.cfg.ceiling_height
        } else {
            self.level.next_z - self.level.floor_z
        };
        let zone = self.zone(Zone {
            kind: ZoneKind::Stair,
            rects,
            place,
            top,
            key,
            group: building,
        });
        self.level.shafts.push(Shaft {
            zone,
            origin: o,
            building,
        });
        let door = IRect::new(9, -2, 9 + DOOR_W, 0).at(o);
        let door_top = self.cfg.door_height;
        self.opening(
            door,
            outer,
            zone,
            true,
            1,
            DoorState::Leafless,
            true,
            0.0,
            door_top,
        );
    }
}

/// A room's use, from its size.
fn room_kind(rng: &mut Stream, r: IRect) -> RoomKind {
    let roll = rng::range(rng, 0.0, 1.0);
    let area = r.w() as f32 * r.h() as f32 * CELL * CELL;
    if area > 24.0 && roll < 0.35 {
        RoomKind::Meeting
    } else if area < 20.0 && roll < 0.3 {
        RoomKind::Storage
    } else if roll > 0.9 {
        RoomKind::Kitchen
    } else {
        RoomKind::Office
    }
}

/// The layout stream of one building and storey.
fn layout_stream(seed: u64, building: u8, storey: u8) -> Stream {
    rng::stream(&[
        seed,
        rng::text("layout"),
        u64::from(building),
        u64::from(storey),
    ])
}

/// Building 0: 42 m × 18 m, a straight double-loaded corridor along x; a lobby at the west end
/// of the ground floor; storeys 1 and 2 share one layout (and corridor decoration).
/// Returns its corridor zone.
fn building0(lb: &mut LevelBuilder, seed: u64, corridors: &mut Vec<Corridor>) -> usize {
    let storey = lb.storey();
    // Storey 2 repeats storey 1.
    let twin = if storey == 2 { 1 } else { storey };
    let mut rng = layout_stream(seed, 0, twin);
    lb.level.solids.push(IRect::new(0, 0, 420, 180));
    let id = corridors.len() as u16;
    corridors.push(Corridor {
        id,
        storey,
        shape: Shape::Straight,
    });
    let x0 = if storey == 0 { 100 } else { 3 };
    let corridor = lb.corridor(0, IRect::new(x0, 78, 417, 102), 0.0, id, 0, twin);
    if storey == 0 {
        lb.lobby(0, vec![IRect::new(3, 3, 100, 177)]);
    }
    let rx = if storey == 0 { 102 } else { 3 };
    lb.rooms_along(
        0,
        IRect::new(rx, 3, 417, 76),
        Side::North,
        corridor,
        &mut rng,
    );
    lb.rooms_along(
        0,
        IRect::new(rx, 104, 198, 177),
        Side::South,
        corridor,
        &mut rng,
    );
    lb.rooms_along(
        0,
        IRect::new(230, 104, 417, 177),
        Side::South,
        corridor,
        &mut rng,
    );
    lb.stair(0, (200, 104), corridor);
    corridor
}

/// Building 1: 32 m × 27 m east of building 0. Ground floor: an L-shaped corridor (south and
/// west legs) ending in a hall around the stairwell; storeys 1 and 2: a C-shaped corridor
/// (south, west and north legs) around a core of rooms. Returns the south leg's zone.
fn building1(lb: &mut LevelBuilder, seed: u64, corridors: &mut Vec<Corridor>) -> usize {
    let storey = lb.storey();
    let mut rng = layout_stream(seed, 1, storey);
    let o = B1;
    lb.level.solids.push(IRect::new(0, 0, 320, 270).at(o));
    let id = corridors.len() as u16;
    let shape = if storey == 0 { Shape::L } else { Shape::C };
    corridors.push(Corridor { id, storey, shape });
    // Walking the corridor from its east end: west along the south leg, north up the west
    // leg, east along the north leg.
    let south = lb.corridor(1, IRect::new(3, 60, 317, 84).at(o), PI, id, 0, storey);
    lb.rooms_along(
        1,
        IRect::new(3, 3, 317, 58).at(o),
        Side::North,
        south,
        &mut rng,
    );
    lb.rooms_along(
        1,
        IRect::new(29, 86, 317, 129).at(o),
        Side::South,
        south,
        &mut rng,
    );
    if storey == 0 {
        lb.corridor(
            1,
            IRect::new(3, 84, 27, 131).at(o),
            FRAC_PI_2,
            id,
            1,
            storey,
        );
        let hall = lb.lobby(
            1,
            vec![
                IRect::new(3, 131, 317, 200).at(o),
                IRect::new(3, 200, 148, 267).at(o),
                IRect::new(180, 200, 317, 267).at(o),
            ],
        );
        lb.stair(1, (150 + o.0, 202 + o.1), hall);
    } else {
        lb.corridor(
            1,
            IRect::new(3, 84, 27, 176).at(o),
            FRAC_PI_2,
            id,
            1,
            storey,
        );
        let north = lb.corridor(1, IRect::new(3, 176, 317, 200).at(o), 0.0, id, 2, storey);
        lb.rooms_along(
            1,
            IRect::new(29, 131, 317, 174).at(o),
            Side::North,
            north,
            &mut rng,
        );
        lb.rooms_along(
            1,
            IRect::new(3, 202, 148, 267).at(o),
            Side::South,
            north,
            &mut rng,
        );
        lb.rooms_along(
            1,
            IRect::new(180, 202, 317, 267).at(o),
            Side::South,
            north,
            &mut rng,
        );
        lb.stair(1, (150 + o.0, 202 + o.1), north);
    }
    south
}

/// The covered bridge on storey 1: 10 m long, 2.4 m wide, from the east end of building 0's
/// corridor to the west end of building 1's south leg. Each half is labelled with the building
/// it is closer to.
fn bridge(lb: &mut LevelBuilder, b0: usize, b1: usize, corridors: &mut Vec<Corridor>) {
    let id = corridors.len() as u16;
    corridors.push(Corridor {
        id,
        storey: lb.storey(),
        shape: Shape::Bridge,
    });
    lb.level.solids.push(IRect::new(420, 75, 520, 78));
    lb.level.solids.push(IRect::new(420, 102, 520, 105));
    let top = lb.cfg.ceiling_height - 0.2;
    let mut halves = [0usize; 2];
    for (b, half) in halves.iter_mut().enumerate() {
        let building = b as u8;
        let r = IRect::new(420 + 50 * b as i32, 78, 470 + 50 * b as i32, 102);
        let place = lb.place(building, PlaceKind::Bridge, Some(id), Some(0.0));
        let key = rng::hash(&[rng::text("bridge"), b as u64]);
        *half = lb.zone(Zone {
            kind: ZoneKind::Bridge,
            rects: vec![r],
            place,
            top,
            key,
            group: 2,
        });
    }
    let link_top = (lb.cfg.ceiling_height - 0.5).max(lb.cfg.door_height);
    lb.opening(
        IRect::new(417, 80, 420, 100),
        b0,
        halves[0],
        false,
        1,
        DoorState::Leafless,
        true,
        0.0,
        link_top,
    );
    lb.opening(
        IRect::new(520, 80, 523, 100),
        b1,
        halves[1],
        false,
        -1,
        DoorState::Leafless,
        true,
        0.0,
        link_top,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zones_never_overlap() -> Result<(), String> {
        let plan = build(&DefaultWorldConfig::default(), 3);
        for level in &plan.levels {
            let rects: Vec<(usize, IRect)> = level
                .zones
                .iter()
                .enumerate()
                .flat_map(|(i, z)| z.rects.iter().map(move |r| (i, *r)))
                .collect();
            for (i, (za, a)) in rects.iter().enumerate() {
                if a.w() <= 0 || a.h() <= 0 {
                    return Err(format!("empty rect {a:?} in zone {za}"));
                }
                for (zb, b) in &rects[i + 1..] {
                    if a.overlaps(b) {
                        return Err(format!("zones {za} and {zb} overlap: {a:?} {b:?}"));
                    }
                }
            }
        }
        Ok(())
    }

    #[test]
    fn repeated_storeys_share_their_layout() {
        let plan = build(&DefaultWorldConfig::default(), 11);
        let rooms = |s: usize| -> Vec<IRect> {
            plan.levels[s]
                .zones
                .iter()
                .filter(|z| z.place.building == 0 && matches!(z.kind, ZoneKind::Room(_)))
                .map(|z| z.rects[0])
                .collect()
        };
        assert_eq!(rooms(1), rooms(2));
        assert_ne!(rooms(0), rooms(1));
    }
}
