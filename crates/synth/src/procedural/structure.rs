//! The building's shell: wall faces (cut around the items set into them), floors, ceilings (cut
//! around light panels, vents and missing tiles), door leaves, and the boxes mounted on walls
//! and hung from ceilings.
//!
//! Walls, floors and ceilings carry dominant-plane ids: one plane per wall line and facing, per
//! floor and per ceiling height, in each building (the bridge is a group of its own). Items set
//! into a surface share its plane; furniture, fixtures and stairs get plane 0 (clutter).

use super::decor::{CeilingKind, LevelDecor, Mount, run_frame};
use super::grid::WallRun;
use super::materials::Materials;
use super::mesh::{Mesh, R2, subtract};
use super::plan::{CELL, DoorState, Level, Opening, ZoneKind};
use crate::world::MaterialId;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// Depth of the void shown above a missing ceiling tile, metres.
const PLENUM: f32 = 0.4;

/// Emits the wall faces of a level with their inset items and mounted boxes.
pub(crate) fn walls(
    mesh: &mut Mesh,
    level: &Level,
    runs: &[WallRun],
    decor: &LevelDecor,
    mats: &Materials,
) {
    for (i, run) in runs.iter().enumerate() {
        let Some(zone) = level.zones.get(run.zone) else {
            continue;
        };
        let (frame, face) = run_frame(run, level);
        let offset = frame.n.dot(&frame.origin.coords);
        let plane = mesh.plane(frame.n, offset, zone.group);
        let mut material = mats.wall(level, zone);
        // Some rooms have one wall in an accent colour.
        let accent = matches!(zone.kind, ZoneKind::Room(_))
            && zone.key % 3 == 0
            && run.normal.index() == (zone.key >> 4) % 4
            && run.lo == 0.0;
        let palette = mats
            .storey(zone.place.building, level.storey)
            .filter(|_| accent);
        if let Some(p) = palette {
            material = super::materials::pick_by(&p.accents, zone.key >> 12, material);
        }
        let items: Vec<_> = decor.wall.iter().filter(|w| w.run == i).collect();
        let holes: Vec<R2> = items
            .iter()
            .filter(|w| w.mount == Mount::Inset)
            .map(|w| w.rect)
            .collect();
        for piece in subtract(face, &holes) {
            mesh.frame_rect(&frame, piece, [0.0, 0.0], material, plane);
        }
        for item in items {
            match item.mount {
                Mount::Inset => mesh.frame_rect(
                    &frame,
                    item.rect,
                    [item.rect.u0, item.rect.v0],
                    item.material,
                    plane,
                ),
                Mount::Box { depth } => {
                    let a = frame.at(item.rect.u0, item.rect.v0);
                    let b = frame.at(item.rect.u1, item.rect.v1) + frame.n * depth;
                    mesh.aabox(a.inf(&b), a.sup(&b), item.material, true);
                }
            }
        }
    }
}

/// The opening whose door zone is `zone`, if any.
fn opening_of(level: &Level, zone: usize) -> Option<&Opening> {
    level.openings.iter().find(|o| o.zone == zone)
}

/// Emits floors and ceilings of a level, the items in its ceilings and its hanging fixtures.
pub(crate) fn floors_and_ceilings(
    mesh: &mut Mesh,
    level: &Level,
    decor: &LevelDecor,
    mats: &Materials,
) {
    for (zi, zone) in level.zones.iter().enumerate() {
        let outer = opening_of(level, zi).and_then(|o| level.zones.get(o.outer));
        let floor_mat = mats.floor(level, zone, outer);
        let ceiling_mat = mats.ceiling(level, zone);
        let zc = level.floor_z + zone.top;
        for (ri, r) in zone.rects.iter().enumerate() {
            let (a, b) = (r.min_m(), r.max_m());
            let rect = R2::new(a[0], a[1], b[0], b[1]);
            // Stair shafts have a floor on the ground storey and at landings only, and a ceiling
            // on the top storey only: in between they are open.
            let stair = zone.kind == ZoneKind::Stair;
            if !stair || level.storey == 0 || ri == 0 {
                let plane = mesh.plane(Vector3::z(), level.floor_z, zone.group);
                mesh.hrect(rect, level.floor_z, true, [0.0, 0.0], floor_mat, plane);
            }
            if stair && !level.top {
                continue;
            }
            let plane = mesh.plane(-Vector3::z(), -zc, zone.group);
            let items: Vec<_> = decor
                .ceiling
                .iter()
                .filter(|c| c.zone == zi && c.rect_index == ri)
                .collect();
            let holes: Vec<R2> = items.iter().map(|c| c.rect).collect();
            for piece in subtract(rect, &holes) {
                mesh.hrect(piece, zc, false, [0.0, 0.0], ceiling_mat, plane);
            }
            for item in items {
                match item.kind {
                    CeilingKind::Panel | CeilingKind::Vent => {
                        mesh.hrect(
                            item.rect,
                            zc,
                            false,
                            [item.rect.u0, item.rect.v0],
                            item.material,
                            plane,
                        );
                    }
                    CeilingKind::Missing => plenum(mesh, item.rect, zc, item.material),
                }
            }
        }
    }
    for f in &decor.fixtures {
        mesh.aabox(f.min, f.max, f.material, true);
    }
}

/// The dark box above a missing tile: its top and four sides, all facing into the hole.
fn plenum(mesh: &mut Mesh, r: R2, z: f32, material: MaterialId) {
    let top = z + PLENUM;
    mesh.hrect(r, top, false, [r.u0, r.v0], material, 0);
    let p = Point3::new;
    let sides = [
        (
            [
                p(r.u0, r.v0, z),
                p(r.u0, r.v1, z),
                p(r.u0, r.v1, top),
                p(r.u0, r.v0, top),
            ],
            Vector3::x(),
        ),
        (
            [
                p(r.u1, r.v0, z),
                p(r.u1, r.v1, z),
                p(r.u1, r.v1, top),
                p(r.u1, r.v0, top),
            ],
            -Vector3::x(),
        ),
        (
            [
                p(r.u0, r.v0, z),
                p(r.u1, r.v0, z),
                p(r.u1, r.v0, top),
                p(r.u0, r.v0, top),
            ],
            Vector3::y(),
        ),
        (
            [
                p(r.u0, r.v1, z),
                p(r.u1, r.v1, z),
                p(r.u1, r.v1, top),
                p(r.u0, r.v1, top),
            ],
            -Vector3::y(),
        ),
    ];
    for (v, facing) in sides {
        let w = (v[1] - v[0]).norm();
        mesh.quad_facing(
            v,
            [[0.0, 0.0], [w, 0.0], [w, PLENUM], [0.0, PLENUM]],
            facing,
            material,
            0,
        );
    }
}

/// Door leaves (thin wooden slabs with a handle) in room doorways: shut, ajar, or open into
/// the room.
pub(crate) fn doors(mesh: &mut Mesh, level: &Level, mats: &Materials, door_height: f32) {
    for op in &level.openings {
        if op.state == DoorState::Leafless {
            continue;
        }
        let Some((zone, r)) = level
            .zones
            .get(op.zone)
            .and_then(|z| z.rects.first().map(|r| (z, r)))
        else {
            continue;
        };
        let material = mats
            .door
            .get(usize::from(zone.place.building))
            .copied()
            .unwrap_or(mats.frame);
        // Work in (along the wall, through the wall) coordinates.
        let (along0, along1, through0, through1) = if op.along_y {
            (r.x0, r.x1, r.y0, r.y1)
        } else {
            (r.y0, r.y1, r.x0, r.x1)
        };
        let (a0, a1) = (along0 as f32 * CELL, along1 as f32 * CELL);
        let into = op.into as f32;
        let room_face = if op.into > 0 { through1 } else { through0 } as f32 * CELL;
        let hinge_t = room_face - into * 0.025;
        let (hinge_a, dir_a) = if op.hinge_low {
            (a0 + 0.02, 1.0)
        } else {
            (a1 - 0.02, -1.0)
        };
        let len = (a1 - a0) - 0.04;
        let angle = match op.state {
            DoorState::Closed => 0.0,
            _ => op.angle,
        };
        // Leaf direction in (along, through).
        let (da, dt) = (dir_a * angle.cos(), into * angle.sin());
        let to_xy = |a: f32, t: f32| if op.along_y { (a, t) } else { (t, a) };
        let (dx, dy) = to_xy(da, dt);
        let yaw = dy.atan2(dx);
        let (hx, hy) = to_xy(hinge_a, hinge_t);
        let height = door_height - 0.03;
        let centre = Point3::new(
            hx + dx * len / 2.0,
            hy + dy * len / 2.0,
            level.floor_z + 0.01 + height / 2.0,
        );
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        let iso = Isometry3::from_parts(Translation3::new(centre.x, centre.y, centre.z), rot);
        mesh.cuboid(
            &iso,
            Vector3::new(len / 2.0, 0.02, height / 2.0),
            material,
            true,
        );
        // The handle near the free edge, through the leaf.
        let hp = Point3::new(
            hx + dx * (len - 0.1),
            hy + dy * (len - 0.1),
            level.floor_z + 1.0,
        );
        let hiso = Isometry3::from_parts(Translation3::new(hp.x, hp.y, hp.z), rot);
        mesh.cuboid(&hiso, Vector3::new(0.06, 0.05, 0.015), mats.metal, true);
    }
}
