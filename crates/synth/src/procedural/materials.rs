//! Materials of the default building: what is shared (doors, glass, metal, furniture), and each
//! storey's own palette (corridor and room paints, carpets, ceiling tiles), so that a storey can
//! be told from another by its colours. Everything here draws from the palette stream, which no
//! variant changes; the materials a variant does change (posters, signs, light panels) are made
//! later, one per item, in [`super::decor`].
//!
//! All base materials are added before any geometry, in a fixed order, so a material's id is the
//! same in every variant of a seed.

use super::plan::{Level, RoomKind, STOREYS, Zone, ZoneKind};
use super::rng::{self, Stream};
use crate::world::{Material, MaterialId, Pattern, World};

/// Paints offices are painted with (sRGB 0–1), before a little jitter.
const PAINTS: [[f32; 3]; 12] = [
    [0.92, 0.91, 0.87],
    [0.85, 0.87, 0.88],
    [0.78, 0.85, 0.90],
    [0.80, 0.88, 0.80],
    [0.92, 0.87, 0.74],
    [0.95, 0.92, 0.70],
    [0.88, 0.76, 0.68],
    [0.70, 0.78, 0.72],
    [0.82, 0.80, 0.90],
    [0.75, 0.75, 0.75],
    [0.93, 0.82, 0.80],
    [0.68, 0.80, 0.85],
];

/// Carpet colours.
const CARPETS: [[f32; 3]; 8] = [
    [0.35, 0.37, 0.42],
    [0.45, 0.40, 0.35],
    [0.30, 0.40, 0.50],
    [0.50, 0.30, 0.30],
    [0.38, 0.45, 0.36],
    [0.55, 0.52, 0.48],
    [0.28, 0.28, 0.30],
    [0.50, 0.45, 0.55],
];

/// Accent colours (posters' backgrounds, chairs, accent walls).
pub(crate) const ACCENTS: [[f32; 3]; 10] = [
    [0.80, 0.20, 0.20],
    [0.20, 0.45, 0.80],
    [0.95, 0.70, 0.15],
    [0.25, 0.60, 0.35],
    [0.55, 0.30, 0.65],
    [0.10, 0.60, 0.65],
    [0.90, 0.45, 0.20],
    [0.20, 0.20, 0.25],
    [0.85, 0.85, 0.85],
    [0.60, 0.15, 0.35],
];

/// One storey's own colours.
#[derive(Clone, Debug)]
pub(crate) struct StoreyPalette {
    /// Corridor walls.
    pub corridor_wall: MaterialId,
    /// Corridor floor tiles.
    pub corridor_floor: MaterialId,
    /// Room walls (a room picks one).
    pub room_walls: Vec<MaterialId>,
    /// Accent walls.
    pub accents: Vec<MaterialId>,
    /// Carpets (a room picks one).
    pub carpets: Vec<MaterialId>,
    /// Ceiling tiles.
    pub ceiling: MaterialId,
}

/// Every base material.
#[derive(Clone, Debug)]
pub(crate) struct Materials {
    /// Per building, per storey (index `building * STOREYS + storey`).
    pub storeys: Vec<StoreyPalette>,
    /// Lobby walls, floor, ceiling, per building.
    pub lobby: Vec<[MaterialId; 3]>,
    /// Stairwell walls, per building.
    pub stair_wall: Vec<MaterialId>,
    /// Concrete (stair floors, flights, landings, stairwell ceilings).
    pub concrete: MaterialId,
    /// Vinyl floor of storage rooms and kitchens.
    pub vinyl: MaterialId,
    /// Bridge walls, floor, ceiling.
    pub bridge: [MaterialId; 3],
    /// Door frames and lintels.
    pub frame: MaterialId,
    /// Door leaves, per building.
    pub door: Vec<MaterialId>,
    /// Window glass, per building.
    pub window: Vec<MaterialId>,
    /// Ceiling vents.
    pub vent: MaterialId,
    /// Brushed metal (sprinklers, handles, railings, cable trays).
    pub metal: MaterialId,
    /// White plastic (smoke detectors).
    pub white: MaterialId,
    /// Fire extinguisher red.
    pub red: MaterialId,
    /// Dark void above missing ceiling tiles.
    pub plenum: MaterialId,
    /// Desk and table tops (wood).
    pub woods: Vec<MaterialId>,
    /// Chair and sofa fabrics.
    pub fabrics: Vec<MaterialId>,
    /// Grey metal cabinets.
    pub cabinet: MaterialId,
    /// Leaves of plants.
    pub leaves: MaterialId,
    /// Plant pots.
    pub pot: MaterialId,
    /// Whiteboards and fridges.
    pub whiteboard: MaterialId,
    /// Kitchen counters.
    pub counter: MaterialId,
    /// Debris: broken concrete, plaster.
    pub rubble: [MaterialId; 2],
}

fn jitter(rng: &mut Stream, c: [f32; 3], amount: f32) -> [f32; 3] {
    let mut out = c;
    for ch in &mut out {
        *ch = (*ch + rng::range(rng, -amount, amount)).clamp(0.0, 1.0);
    }
    out
}

/// One colour of `list`, jittered by up to `amount` per channel.
fn vary(rng: &mut Stream, list: &[[f32; 3]], amount: f32) -> [f32; 3] {
    let c = rng::pick(rng, list).copied().unwrap_or([0.8, 0.8, 0.8]);
    jitter(rng, c, amount)
}

fn add(world: &mut World, name: &str, color: [f32; 3], pattern: Pattern, seed: u64) -> MaterialId {
    world.add_material(Material {
        name: name.to_string(),
        color,
        pattern,
        seed,
        emissive: 0.0,
        unlit: false,
    })
}

impl Materials {
    /// Adds the base materials of the building of `seed` to `world`.
    pub(crate) fn create(world: &mut World, seed: u64) -> Self {
        let mut storeys = Vec::new();
        for building in 0..2u8 {
            for storey in 0..STOREYS {
                // Storey 2 of building 0 repeats storey 1's corridor.
                let twin = if building == 0 && storey == 2 {
                    1
                } else {
                    storey
                };
                let mut c = rng::stream(&[
                    seed,
                    rng::text("palette-corridor"),
                    u64::from(building),
                    u64::from(twin),
                ]);
                let corridor_wall = {
                    let col = vary(&mut c, &PAINTS, 0.04);
                    add(
                        world,
                        "corridor paint",
                        col,
                        Pattern::Plain,
                        rng::seed(&mut c),
                    )
                };
                let corridor_floor = {
                    let base = [rng::range(&mut c, 0.45, 0.75); 3];
                    let col = jitter(&mut c, base, 0.05);
                    let size = if rng::chance(&mut c, 0.5) { 0.3 } else { 0.6 };
                    add(
                        world,
                        "corridor tiles",
                        col,
                        Pattern::Tiles { size },
                        rng::seed(&mut c),
                    )
                };
                let ceiling = {
                    let v = rng::range(&mut c, 0.82, 0.95);
                    let col = jitter(&mut c, [v, v, v * 0.98], 0.02);
                    add(
                        world,
                        "ceiling tiles",
                        col,
                        Pattern::Tiles { size: 0.6 },
                        rng::seed(&mut c),
                    )
                };
                let mut r = rng::stream(&[
                    seed,
                    rng::text("palette-rooms"),
                    u64::from(building),
                    u64::from(storey),
                ]);
                let room_walls = (0..3)
                    .map(|_| {
                        let col = vary(&mut r, &PAINTS, 0.03);
                        add(world, "room paint", col, Pattern::Plain, 0)
                    })
                    .collect();
                let accents = (0..2)
                    .map(|_| {
                        let col = vary(&mut r, &ACCENTS, 0.05);
                        let col = col.map(|x| 0.35 + 0.6 * x);
                        add(world, "accent paint", col, Pattern::Plain, 0)
                    })
                    .collect();
                let carpets = (0..2)
                    .map(|_| {
                        let col = vary(&mut r, &CARPETS, 0.04);
                        add(world, "carpet", col, Pattern::Carpet, rng::seed(&mut r))
                    })
                    .collect();
                storeys.push(StoreyPalette {
                    corridor_wall,
                    corridor_floor,
                    room_walls,
                    accents,
                    carpets,
                    ceiling,
                });
            }
        }
        let mut g = rng::stream(&[seed, rng::text("palette-shared")]);
        let lobby = (0..2)
            .map(|_| {
                let wall = vary(&mut g, &PAINTS, 0.03);
                let floor = jitter(&mut g, [0.72, 0.68, 0.60], 0.08);
                [
                    add(world, "lobby paint", wall, Pattern::Plain, 0),
                    add(
                        world,
                        "lobby stone",
                        floor,
                        Pattern::Tiles { size: 0.6 },
                        rng::seed(&mut g),
                    ),
                    add(
                        world,
                        "lobby ceiling",
                        [0.93, 0.93, 0.92],
                        Pattern::Tiles { size: 1.2 },
                        rng::seed(&mut g),
                    ),
                ]
            })
            .collect();
        let stair_wall = (0..2)
            .map(|_| {
                let col = jitter(&mut g, [0.80, 0.80, 0.78], 0.06);
                add(world, "stairwell paint", col, Pattern::Plain, 0)
            })
            .collect();
        let concrete = add(
            world,
            "concrete",
            [0.62, 0.62, 0.60],
            Pattern::Concrete,
            rng::seed(&mut g),
        );
        let vinyl = add(
            world,
            "vinyl",
            [0.70, 0.72, 0.70],
            Pattern::Tiles { size: 0.3 },
            rng::seed(&mut g),
        );
        let bridge = [
            add(world, "bridge paint", [0.88, 0.88, 0.90], Pattern::Plain, 0),
            add(
                world,
                "bridge floor",
                [0.50, 0.42, 0.35],
                Pattern::Wood,
                rng::seed(&mut g),
            ),
            add(
                world,
                "bridge ceiling",
                [0.90, 0.90, 0.90],
                Pattern::Plain,
                0,
            ),
        ];
        let frame = add(world, "door frame", [0.90, 0.90, 0.88], Pattern::Plain, 0);
        let door = (0..2)
            .map(|_| {
                let col = jitter(&mut g, [0.62, 0.45, 0.30], 0.08);
                add(world, "door", col, Pattern::Wood, rng::seed(&mut g))
            })
            .collect();
        let window = (0..2)
            .map(|_| {
                let id = add(
                    world,
                    "window",
                    [0.75, 0.85, 0.95],
                    Pattern::Window,
                    rng::seed(&mut g),
                );
                if let Some(m) = world.materials.get_mut(usize::from(id)) {
                    m.emissive = 0.8;
                }
                id
            })
            .collect();
        let vent = add(
            world,
            "vent",
            [0.85, 0.85, 0.85],
            Pattern::Vent,
            rng::seed(&mut g),
        );
        let metal = add(
            world,
            "metal",
            [0.70, 0.70, 0.72],
            Pattern::Metal,
            rng::seed(&mut g),
        );
        let white = add(
            world,
            "white plastic",
            [0.95, 0.95, 0.95],
            Pattern::Plain,
            0,
        );
        let red = add(
            world,
            "extinguisher red",
            [0.80, 0.08, 0.06],
            Pattern::Plain,
            0,
        );
        let plenum = add(
            world,
            "plenum",
            [0.10, 0.10, 0.11],
            Pattern::Concrete,
            rng::seed(&mut g),
        );
        let woods = (0..3)
            .map(|_| {
                let col = jitter(&mut g, [0.70, 0.55, 0.38], 0.12);
                add(world, "wood", col, Pattern::Wood, rng::seed(&mut g))
            })
            .collect();
        let fabrics = (0..4)
            .map(|_| {
                let col = vary(&mut g, &ACCENTS, 0.05).map(|x| 0.15 + 0.7 * x);
                add(world, "fabric", col, Pattern::Fabric, rng::seed(&mut g))
            })
            .collect();
        let cabinet = add(
            world,
            "cabinet",
            [0.60, 0.62, 0.64],
            Pattern::Metal,
            rng::seed(&mut g),
        );
        let leaves = add(
            world,
            "leaves",
            [0.20, 0.45, 0.18],
            Pattern::Fabric,
            rng::seed(&mut g),
        );
        let pot = add(world, "pot", [0.62, 0.35, 0.22], Pattern::Plain, 0);
        let whiteboard = add(world, "whiteboard", [0.96, 0.96, 0.97], Pattern::Plain, 0);
        let counter = add(world, "counter", [0.85, 0.83, 0.80], Pattern::Plain, 0);
        let rubble = [
            add(
                world,
                "rubble",
                [0.55, 0.53, 0.50],
                Pattern::Concrete,
                rng::seed(&mut g),
            ),
            add(
                world,
                "plaster",
                [0.80, 0.78, 0.74],
                Pattern::Concrete,
                rng::seed(&mut g),
            ),
        ];
        Self {
            storeys,
            lobby,
            stair_wall,
            concrete,
            vinyl,
            bridge,
            frame,
            door,
            window,
            vent,
            metal,
            white,
            red,
            plenum,
            woods,
            fabrics,
            cabinet,
            leaves,
            pot,
            whiteboard,
            counter,
            rubble,
        }
    }

    /// The palette of `building`'s `storey` (building 1's ground floor if out of range).
    pub(crate) fn storey(&self, building: u8, storey: u8) -> Option<&StoreyPalette> {
        self.storeys
            .get(usize::from(building) * usize::from(STOREYS) + usize::from(storey))
    }

    /// The material of a zone's walls.
    pub(crate) fn wall(&self, level: &Level, zone: &Zone) -> MaterialId {
        let b = usize::from(zone.place.building);
        let pal = self.storey(zone.place.building, level.storey);
        match zone.kind {
            ZoneKind::Corridor => pal.map_or(self.frame, |p| p.corridor_wall),
            ZoneKind::Room(_) => {
                pal.map_or(self.frame, |p| pick_by(&p.room_walls, zone.key, self.frame))
            }
            ZoneKind::Lobby => self.lobby.get(b).map_or(self.frame, |m| m[0]),
            ZoneKind::Stair => self.stair_wall.get(b).copied().unwrap_or(self.frame),
            ZoneKind::Door => self.frame,
            ZoneKind::Bridge => self.bridge[0],
        }
    }

    /// The material of a zone's floor; door zones use `outer`'s.
    pub(crate) fn floor(&self, level: &Level, zone: &Zone, outer: Option<&Zone>) -> MaterialId {
        let b = usize::from(zone.place.building);
        let pal = self.storey(zone.place.building, level.storey);
        match zone.kind {
            ZoneKind::Corridor => pal.map_or(self.concrete, |p| p.corridor_floor),
            ZoneKind::Room(RoomKind::Office | RoomKind::Meeting) => pal
                .map_or(self.concrete, |p| {
                    pick_by(&p.carpets, zone.key >> 8, self.concrete)
                }),
            ZoneKind::Room(_) => self.vinyl,
            ZoneKind::Lobby => self.lobby.get(b).map_or(self.concrete, |m| m[1]),
            ZoneKind::Stair => self.concrete,
            ZoneKind::Door => match outer {
                Some(o) if o.kind != ZoneKind::Door => self.floor(level, o, None),
                _ => self.concrete,
            },
            ZoneKind::Bridge => self.bridge[1],
        }
    }

    /// The material of a zone's ceiling.
    pub(crate) fn ceiling(&self, level: &Level, zone: &Zone) -> MaterialId {
        let b = usize::from(zone.place.building);
        let pal = self.storey(zone.place.building, level.storey);
        match zone.kind {
            ZoneKind::Corridor | ZoneKind::Room(_) => pal.map_or(self.concrete, |p| p.ceiling),
            ZoneKind::Lobby => self.lobby.get(b).map_or(self.concrete, |m| m[2]),
            ZoneKind::Stair => self.concrete,
            ZoneKind::Door => self.frame,
            ZoneKind::Bridge => self.bridge[2],
        }
    }
}

/// One of `list`, chosen by a hash.
pub(crate) fn pick_by(list: &[MaterialId], key: u64, fallback: MaterialId) -> MaterialId {
    if list.is_empty() {
        fallback
    } else {
        list[(key % list.len() as u64) as usize]
    }
}
