//! A small hand-built world for tests of trajectories and variants, independent of the procedural
//! generator: an L-shaped corridor with a room on the ground floor, a stair to a straight
//! corridor on the first floor.
//!
//! ```text
//!  storey 1 (z = 3.5):      a1 ── d0 ──────── d1 ──────── d2      (y = 5, corridor 2, axis +x)
//!                           │ (stairs, 5 m run, 3.5 m rise)
//!  storey 0 (z = 0):        a0 ── c0 ── c1 ── c2 ── c3 ── c4       (y = 0, corridor 0, axis +x)
//!                                             │            │
//!                                             r (room)     l1 ─ l2 ─ l3 (x = 20, corridor 1,
//!                                                                          axis +y)
//! ```

use crate::world::{
    Light, Material, Pattern, Place, PlaceKind, Region, Triangle, WalkGraph, WalkNode, World,
};
use nalgebra::Point3;

fn place(storey: u8, corridor: Option<u16>, kind: PlaceKind, axis: Option<f32>) -> Place {
    Place {
        building: 0,
        storey,
        corridor,
        kind,
        axis,
    }
}

fn region(min: [f32; 2], max: [f32; 2], floor_z: f32, place: Place) -> Region {
    Region {
        min,
        max,
        floor_z,
        ceiling_z: floor_z + 2.8,
        place,
    }
}

/// Region indices of [`world`].
pub(crate) const CORRIDOR_A: usize = 0;
pub(crate) const CORRIDOR_B: usize = 1;
pub(crate) const ROOM: usize = 2;
pub(crate) const STAIRS_0: usize = 3;
pub(crate) const STAIRS_1: usize = 4;
pub(crate) const CORRIDOR_C: usize = 5;

/// The test world (see the module docs); with lights every 2.5 m along the ceilings, their
/// fixtures sharing one panel material, and a floor, wall and ceiling of the corridors.
pub(crate) fn world() -> World {
    use std::f32::consts::FRAC_PI_2;
    let regions = vec![
        region(
            [-1.0, -1.0],
            [21.0, 1.0],
            0.0,
            place(0, Some(0), PlaceKind::Corridor, Some(0.0)),
        ),
        region(
            [19.0, 1.0],
            [21.0, 16.0],
            0.0,
            place(0, Some(1), PlaceKind::Corridor, Some(FRAC_PI_2)),
        ),
        region(
            [8.0, 1.0],
            [12.0, 5.0],
            0.0,
            place(0, Some(0), PlaceKind::Room, None),
        ),
        Region {
            ceiling_z: 3.5,
            ..region(
                [-4.0, -1.0],
                [-1.0, 6.0],
                0.0,
                place(0, None, PlaceKind::Stairwell, None),
            )
        },
        region(
            [-4.0, -1.0],
            [-1.0, 6.0],
            3.5,
            place(1, None, PlaceKind::Stairwell, None),
        ),
        region(
            [-1.0, 4.0],
            [21.0, 6.0],
            3.5,
            place(1, Some(2), PlaceKind::Corridor, Some(0.0)),
        ),
    ];
    let n = |x: f32, y: f32, z: f32, region: usize| WalkNode {
        p: Point3::new(x, y, z),
        region,
    };
    let nodes = vec![
        n(-2.5, 0.0, 0.0, STAIRS_0),    // 0 a0
        n(0.0, 0.0, 0.0, CORRIDOR_A),   // 1 c0
        n(5.0, 0.0, 0.0, CORRIDOR_A),   // 2 c1
        n(10.0, 0.0, 0.0, CORRIDOR_A),  // 3 c2
        n(15.0, 0.0, 0.0, CORRIDOR_A),  // 4 c3
        n(20.0, 0.0, 0.0, CORRIDOR_A),  // 5 c4
        n(20.0, 5.0, 0.0, CORRIDOR_B),  // 6 l1
        n(20.0, 10.0, 0.0, CORRIDOR_B), // 7 l2
        n(20.0, 15.0, 0.0, CORRIDOR_B), // 8 l3
        n(10.0, 3.5, 0.0, ROOM),        // 9 r
        n(-2.5, 5.0, 3.5, STAIRS_1),    // 10 a1
        n(0.0, 5.0, 3.5, CORRIDOR_C),   // 11 d0
        n(10.0, 5.0, 3.5, CORRIDOR_C),  // 12 d1
        n(20.0, 5.0, 3.5, CORRIDOR_C),  // 13 d2
    ];
    let edges = vec![
        [0, 1],
        [1, 2],
        [2, 3],
        [3, 4],
        [4, 5],
        [5, 6],
        [6, 7],
        [7, 8],
        [3, 9],
        [0, 10],
        [10, 11],
        [11, 12],
        [12, 13],
    ];
    let mut world = World {
        name: "test world".into(),
        regions,
        walk: WalkGraph { nodes, edges },
        ..World::default()
    };
    let wall = world.add_material(Material::plain("wall", [0.8, 0.8, 0.75]));
    let floor = world.add_material(Material {
        pattern: Pattern::Carpet,
        seed: 3,
        ..Material::plain("carpet", [0.3, 0.3, 0.35])
    });
    let panel = world.add_material(Material {
        pattern: Pattern::LightPanel,
        emissive: 1.0,
        ..Material::plain("light panel", [0.95, 0.95, 0.95])
    });
    let poster = world.add_material(Material {
        pattern: Pattern::Poster,
        seed: 11,
        ..Material::plain("poster", [0.9, 0.2, 0.2])
    });
    // Floor and a wall of corridor A, a poster on the wall.
    quad(
        &mut world,
        [-1.0, -1.0, 0.0],
        [21.0, -1.0, 0.0],
        [21.0, 1.0, 0.0],
        floor,
    );
    // The wall along corridor A, with the room's door at x = 9.5–10.5.
    quad(
        &mut world,
        [-1.0, 1.0, 0.0],
        [9.5, 1.0, 0.0],
        [9.5, 1.0, 2.8],
        wall,
    );
    quad(
        &mut world,
        [10.5, 1.0, 0.0],
        [19.0, 1.0, 0.0],
        [19.0, 1.0, 2.8],
        wall,
    );
    quad(
        &mut world,
        [4.0, 0.99, 1.2],
        [5.0, 0.99, 1.2],
        [5.0, 0.99, 2.0],
        poster,
    );
    // Light panels every 2.5 m along both ground-floor corridors and the first-floor corridor.
    let mut spots = Vec::new();
    for k in 0..9 {
        spots.push([k as f32 * 2.5, 0.0, 2.8]);
        spots.push([k as f32 * 2.5, 5.0, 6.3]);
    }
    for k in 1..7 {
        spots.push([20.0, k as f32 * 2.5, 2.8]);
    }
    for [x, y, z] in spots {
        quad(
            &mut world,
            [x - 0.3, y - 0.3, z - 0.01],
            [x + 0.3, y - 0.3, z - 0.01],
            [x + 0.3, y + 0.3, z - 0.01],
            panel,
        );
        world.lights.push(Light {
            position: Point3::new(x, y, z - 0.05),
            intensity: 1.0,
            on: true,
            fixture: Some(panel),
        });
    }
    world
}

/// Adds the parallelogram `a, b, c, a + c − b` as two triangles.
fn quad(world: &mut World, a: [f32; 3], b: [f32; 3], c: [f32; 3], material: u16) {
    let [a, b, c] = [a, b, c].map(Point3::from);
    let d = a + (c - b);
    for v in [[a, b, c], [a, c, d]] {
        world.triangles.push(Triangle {
            v,
            uv: [[0.0; 2]; 3],
            material,
            plane: 0,
        });
    }
}
