//! The procedural default building: two office buildings of three storeys joined by a covered
//! bridge, generated from a seed in a few milliseconds with no I/O, so every command, test and
//! demo has a building without a download.
//!
//! # What is in it
//! - Building 0 (42 m × 18 m): a straight double-loaded corridor per storey, a lobby on the
//!   ground floor; storeys 1 and 2 share their layout and corridor decoration on purpose, so the
//!   same corridor exists twice (the ambiguity real buildings have).
//! - Building 1 (32 m × 27 m, 10 m east): an L-shaped corridor and a hall on the ground floor,
//!   C-shaped corridors around a core of rooms above.
//! - A covered bridge on storey 1 from building 0's corridor to building 1's.
//! - Rooms (offices, meeting rooms, storage, kitchens) with doors (some open, some ajar, some
//!   shut), a dog-leg stair shaft per building, windows on outer walls; ceilings with tiles,
//!   light panels (each a [`Light`](crate::world::Light)), vents, sprinklers, smoke detectors
//!   and cable trays; posters, notice boards, signs, fire extinguishers, whiteboards and
//!   furniture that differ between storeys and buildings.
//! - Labelled regions covering all free space and a connected walk graph through corridors,
//!   open doors, stairwells and the bridge.
//!
//! # Conventions
//! Metres, z up, storey `s` at z = `s × storey_height`. Texture coordinates are metres: along
//! the wall (left to right seen from the front) and up from the storey's floor for walls, world
//! (x, y) for floors and ceilings. Items set into a surface — windows, posters, notice boards,
//! signs, whiteboards, light panels, vents — have texture coordinates in metres from their own
//! lower-left corner, so a pattern can lay itself out on the item (its size is the largest uv).
//! Every face looks into free space (counter-clockwise seen from there); walls are two-sided
//! exactly where both sides are free space.
//!
//! # Variants
//! The layout (walls, doors, planes, regions, walk graph) is the same for every variant of a
//! seed: each aspect draws from its own random stream (see `rng`), and only the furniture
//! stream ([`Variant::FurnitureMoved`]), the content stream of posters and signs
//! ([`Variant::PostersChanged`]) and the debris stream ([`Variant::Disaster`]: rubble, fallen
//! tiles, toppled furniture, holes in the ceiling) see the variant. The other variants (lights,
//! daylight, people, haze, texture swap) are applied to the finished world elsewhere; here they
//! give the normal building.

mod decor;
mod furniture;
mod grid;
mod materials;
mod mesh;
mod plan;
mod rng;
mod stairs;
mod structure;
mod walk;

use crate::world::{Atmosphere, Variant, World};
use nalgebra::Point2;

/// Tunables of the default building. Out-of-range values are clamped to what can be built.
#[derive(Clone, Debug, PartialEq)]
pub struct DefaultWorldConfig {
    /// Floor-to-floor height, metres (3.0–5.0).
    pub storey_height: f32,
    /// Height of ceilings above their floor, metres (2.4 to `storey_height` − 0.3).
    pub ceiling_height: f32,
    /// Height of door openings, metres (1.9 to `ceiling_height` − 0.3).
    pub door_height: f32,
    /// Share of room doors standing open, 0–1; of the rest, two in five are ajar and the others
    /// shut. Only open doors lead the walk graph into rooms.
    pub open_doors: f32,
    /// Place furniture (false leaves rooms, corridors and halls empty).
    pub furniture: bool,
}

impl Default for DefaultWorldConfig {
    fn default() -> Self {
        Self {
            storey_height: 3.5,
            ceiling_height: 2.9,
            door_height: 2.1,
            open_doors: 0.7,
            furniture: true,
        }
    }
}

impl DefaultWorldConfig {
    /// The same settings clamped to what the generator can build.
    fn sanitized(&self) -> Self {
        let d = Self::default();
        let finite = |x: f32, fallback: f32| if x.is_finite() { x } else { fallback };
        let storey_height = finite(self.storey_height, d.storey_height).clamp(3.0, 5.0);
        let ceiling_height =
            finite(self.ceiling_height, d.ceiling_height).clamp(2.4, storey_height - 0.3);
        let door_height = finite(self.door_height, d.door_height).clamp(1.9, ceiling_height - 0.3);
        let open_doors = finite(self.open_doors, d.open_doors).clamp(0.0, 1.0);
        Self {
            storey_height,
            ceiling_height,
            door_height,
            open_doors,
            furniture: self.furniture,
        }
    }
}

/// The default building of `seed` under `variant`, with the default settings.
pub fn default_world(seed: u64, variant: Variant) -> World {
    default_world_with(&DefaultWorldConfig::default(), seed, variant)
}

/// The default building of `seed` under `variant`, with settings `cfg`.
pub fn default_world_with(cfg: &DefaultWorldConfig, seed: u64, variant: Variant) -> World {
    let cfg = cfg.sanitized();
    let plan = plan::build(&cfg, seed);
    let mut world = World {
        name: format!("default building (seed {seed})"),
        atmosphere: Atmosphere::default(),
        ..World::default()
    };
    let mats = materials::Materials::create(&mut world, seed);
    let runs: Vec<Vec<grid::WallRun>> = plan
        .levels
        .iter()
        .map(|level| grid::Grid::new(level).wall_runs(level))
        .collect();
    world.regions = walk::regions(&plan);
    world.walk = walk::graph(&plan, &world.regions);
    let disaster = variant == Variant::Disaster;
    let decor: Vec<decor::LevelDecor> = plan
        .levels
        .iter()
        .zip(&runs)
        .map(|(level, runs)| {
            let cx = decor::Context {
                seed,
                posters_changed: variant == Variant::PostersChanged,
                disaster,
                level,
                runs,
                mats: &mats,
                door_height: cfg.door_height,
            };
            decor::decorate(&mut world, &cx)
        })
        .collect();
    let furniture_seed = rng::hash(&[
        seed,
        rng::text("furniture"),
        u64::from(variant == Variant::FurnitureMoved),
    ]);
    let walk_graph = world.walk.clone();
    let mut mesh = mesh::Mesh::new(&mut world);
    for ((level, runs), decor) in plan.levels.iter().zip(&runs).zip(&decor) {
        structure::walls(&mut mesh, level, runs, decor, &mats);
        structure::floors_and_ceilings(&mut mesh, level, decor, &mats);
        structure::doors(&mut mesh, level, &mats, cfg.door_height);
        for shaft in &level.shafts {
            stairs::emit(&mut mesh, level, shaft, mats.concrete, mats.metal);
        }
        let segments = walk::floor_segments(&walk_graph, level);
        let nodes: Vec<Point2<f32>> = walk_graph
            .nodes
            .iter()
            .filter(|n| (n.p.z - level.floor_z).abs() < 1e-3)
            .map(|n| n.p.xy())
            .collect();
        let site = furniture::Site {
            level,
            runs,
            decor,
            segments: &segments,
            nodes: &nodes,
        };
        if cfg.furniture {
            let placed = furniture::furnish(&site, &mats, furniture_seed, disaster);
            furniture::emit(&mut mesh, &placed);
        }
        if disaster {
            furniture::debris(&mut mesh, &site, &mats, seed);
        }
    }
    world
}

#[cfg(test)]
mod tests;
