//! Stair shafts: a dog-leg stair per building, from every storey to the next.
//!
//! The shaft (2.8 m × 6.0 m inside, door in the middle of its lower-y wall) holds, per storey:
//! a landing at floor level by the door (y 0–1.6 m), flight A rising along the left half
//! (x 0–1.3 m) to a mid landing at the far end (y 4.6–6.0 m), and flight B rising back along
//! the right half (x 1.5–2.8 m) to the next storey's landing. A spine wall (x 1.3–1.5 m) between
//! the flights is part of the plan, so the grid gives it walls like any other. Risers are about
//! 0.175 m and treads 0.3 m, as building codes ask. Flights are slabs with steps on top and a
//! sloped soffit below, so the space beneath them is visible from the storey below.
//!
//! Walk nodes follow the flights' centre lines on the treads, so the walk graph climbs from one
//! storey to the next through the shaft.

use super::mesh::{Mesh, R2};
use super::plan::{CELL, Level, Shaft};
use crate::world::MaterialId;
use nalgebra::{Point3, Vector3};

/// Landing depth (y) from the door wall, metres.
const LANDING: f32 = 1.6;
/// Length of a flight along y, metres.
const FLIGHT: f32 = 3.0;
/// Flight A spans x 0 – this, metres.
const A_X1: f32 = 1.3;
/// Flight B spans x this – [`WIDTH`], metres.
const B_X0: f32 = 1.5;
/// Inner width of the shaft, metres.
const WIDTH: f32 = 2.8;
/// Thickness of flights and landings, metres.
const SLAB: f32 = 0.2;

/// The shaft's interior lower corner, metres.
fn origin(shaft: &Shaft) -> (f32, f32) {
    (shaft.origin.0 as f32 * CELL, shaft.origin.1 as f32 * CELL)
}

/// Risers per flight (half a storey) and the rise of each, metres.
fn risers(level: &Level) -> (usize, f32) {
    let half = (level.next_z - level.floor_z) / 2.0;
    let n = ((half / 0.175).round() as usize).max(4);
    (n, half / n as f32)
}

/// Emits the stairs of `shaft` on `level`: its flights and mid landing (below the top storey),
/// the underside of its landing slab (above the ground floor), and a railing on the top storey
/// where the open well has no flight going up.
pub(crate) fn emit(
    mesh: &mut Mesh,
    level: &Level,
    shaft: &Shaft,
    concrete: MaterialId,
    metal: MaterialId,
) {
    let (x0, y0) = origin(shaft);
    let z = level.floor_z;
    if !level.top {
        let (n, rise) = risers(level);
        let mid = z + n as f32 * rise;
        flight(
            mesh,
            (x0, x0 + A_X1),
            y0 + LANDING,
            1.0,
            z,
            n,
            rise,
            concrete,
        );
        flight(
            mesh,
            (x0 + B_X0, x0 + WIDTH),
            y0 + LANDING + FLIGHT,
            -1.0,
            mid,
            n,
            rise,
            concrete,
        );
        let landing = R2::new(x0, y0 + LANDING + FLIGHT, x0 + WIDTH, y0 + 6.0);
        mesh.hrect(landing, mid, true, [0.0, 0.0], concrete, 0);
        mesh.hrect(landing, mid - SLAB, false, [0.0, 0.0], concrete, 0);
    }
    if level.storey > 0 {
        let slab = R2::new(x0, y0, x0 + WIDTH, y0 + LANDING);
        mesh.hrect(slab, z - SLAB, false, [0.0, 0.0], concrete, 0);
    }
    if level.top {
        let (a, b) = (
            Point3::new(x0, y0 + LANDING - 0.03, z),
            Point3::new(x0 + A_X1, y0 + LANDING + 0.03, z + 1.0),
        );
        mesh.aabox(a, b, metal, false);
    }
}

/// One flight: `n` steps of `rise` over [`FLIGHT`] metres, from `y_start` in direction `dir`
/// (±1 along y), starting at height `base`.
#[allow(clippy::too_many_arguments)]
fn flight(
    mesh: &mut Mesh,
    x: (f32, f32),
    y_start: f32,
    dir: f32,
    base: f32,
    n: usize,
    rise: f32,
    material: MaterialId,
) {
    let going = FLIGHT / n as f32;
    let back = Vector3::new(0.0, -dir, 0.0);
    for i in 0..n {
        let ya = y_start + dir * i as f32 * going;
        let yb = ya + dir * going;
        let top = base + (i + 1) as f32 * rise;
        let bottom = base + i as f32 * rise;
        mesh.hrect(
            R2::new(x.0, ya.min(yb), x.1, ya.max(yb)),
            top,
            true,
            [0.0, 0.0],
            material,
            0,
        );
        let p = |xx: f32, zz: f32| Point3::new(xx, ya, zz);
        let w = x.1 - x.0;
        mesh.quad_facing(
            [p(x.0, bottom), p(x.1, bottom), p(x.1, top), p(x.0, top)],
            [[0.0, 0.0], [w, 0.0], [w, rise], [0.0, rise]],
            back,
            material,
            0,
        );
    }
    // The sloped underside.
    let y_end = y_start + dir * FLIGHT;
    let z_end = base + n as f32 * rise;
    let len = (FLIGHT * FLIGHT + (z_end - base).powi(2)).sqrt();
    let w = x.1 - x.0;
    mesh.quad_facing(
        [
            Point3::new(x.0, y_start, base - SLAB),
            Point3::new(x.1, y_start, base - SLAB),
            Point3::new(x.1, y_end, z_end - SLAB),
            Point3::new(x.0, y_end, z_end - SLAB),
        ],
        [[0.0, 0.0], [w, 0.0], [w, len], [0.0, len]],
        -Vector3::z(),
        material,
        0,
    );
}

/// The walk node on the landing of `shaft` at `level`, 0.8 m in from the door.
pub(crate) fn landing_node(level: &Level, shaft: &Shaft) -> Point3<f32> {
    let (x0, y0) = origin(shaft);
    Point3::new(x0 + WIDTH / 2.0, y0 + 0.8, level.floor_z)
}

/// The walk nodes from this storey's landing (exclusive) up to the next storey's landing
/// (exclusive): the foot of flight A, two treads, the mid landing (two nodes), two treads of
/// flight B and its head on the next landing. Empty on the top storey.
pub(crate) fn climb(level: &Level, shaft: &Shaft) -> Vec<Point3<f32>> {
    if level.top {
        return Vec::new();
    }
    let (x0, y0) = origin(shaft);
    let z = level.floor_z;
    let (n, rise) = risers(level);
    let going = FLIGHT / n as f32;
    let mid = z + n as f32 * rise;
    let (ax, bx) = (x0 + A_X1 / 2.0, x0 + (B_X0 + WIDTH) / 2.0);
    let (i1, i2) = (n / 3, (2 * n) / 3);
    // Centre of tread i (0-based) of a flight, as (distance along the flight, height above its base).
    let tread = |i: usize| ((i as f32 + 0.5) * going, (i + 1) as f32 * rise);
    let ya = y0 + LANDING;
    let yb = y0 + LANDING + FLIGHT;
    let landing_y = y0 + LANDING + FLIGHT + 0.7;
    vec![
        Point3::new(ax, y0 + 1.2, z),
        Point3::new(ax, ya + tread(i1).0, z + tread(i1).1),
        Point3::new(ax, ya + tread(i2).0, z + tread(i2).1),
        Point3::new(ax, landing_y, mid),
        Point3::new(bx, landing_y, mid),
        Point3::new(bx, yb - tread(i1).0, mid + tread(i1).1),
        Point3::new(bx, yb - tread(i2).0, mid + tread(i2).1),
        Point3::new(bx, y0 + 1.1, level.next_z),
    ]
}
