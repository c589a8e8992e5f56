//! Dominant planes of an imported model: walls, floors and ceilings are many coplanar triangles,
//! which the plane-id images should show as one surface each.
//!
//! Triangles go into hash buckets by quantized normal and offset (bucket width twice the
//! tolerance, so any bucket within tolerance of another is one of its 3⁴ neighbours). Buckets
//! are then visited largest first; each unclaimed bucket seeds a cluster that claims the
//! unclaimed neighbouring buckets whose mean plane lies within tolerance of the seed's. Comparing
//! with the seed (not chaining neighbour to neighbour) keeps a finely tessellated curved wall
//! from collapsing into one "plane". Linear in the number of triangles, plus a sort of buckets.

use crate::world::{Plane, PlaneId, World};
use nalgebra::Vector3;
use std::collections::HashMap;

/// Normals within this angle, radians, are the same direction (2°).
const NORMAL_TOL: f32 = 2.0 * std::f32::consts::PI / 180.0;
/// Offsets within this distance, metres, are the same plane (2 cm).
const OFFSET_TOL: f32 = 0.02;
/// A cluster needs this much area, square metres, to be a dominant plane.
const MIN_PLANE_AREA: f32 = 1.0;

/// Triangles with nearly the same plane.
#[derive(Default)]
struct Bucket {
    /// Quantized normal and offset.
    key: [i32; 4],
    /// Total area.
    area: f32,
    /// Area-weighted sum of normals.
    normal: Vector3<f32>,
    /// Area-weighted sum of offsets.
    offset: f32,
}

impl Bucket {
    /// The bucket's mean plane.
    fn plane(&self) -> (Vector3<f32>, f32) {
        let n = self
            .normal
            .try_normalize(1e-12)
            .unwrap_or_else(Vector3::zeros);
        (n, self.offset / self.area.max(f32::MIN_POSITIVE))
    }
}

/// Clusters the world's triangles into planes: sets `world.planes` (largest first) and every
/// triangle's `plane` (0 for triangles on no plane of at least 1 m²).
pub(super) fn assign(world: &mut World) {
    let nw = 2.0 * NORMAL_TOL; // unit normals: chord ≈ angle
    let dw = 2.0 * OFFSET_TOL;
    let mut index: HashMap<[i32; 4], usize> = HashMap::new();
    let mut buckets: Vec<Bucket> = Vec::new();
    let mut of_tri: Vec<Option<usize>> = Vec::with_capacity(world.triangles.len());
    for t in &world.triangles {
        let n = t.normal();
        let area = t.area();
        if n == Vector3::zeros() || area.is_nan() || area <= 0.0 {
            of_tri.push(None);
            continue;
        }
        let d = n.dot(&t.v[0].coords);
        let key = [
            (n.x / nw).round() as i32,
            (n.y / nw).round() as i32,
            (n.z / nw).round() as i32,
            (d / dw).round() as i32,
        ];
        let b = *index.entry(key).or_insert_with(|| {
            buckets.push(Bucket {
                key,
                ..Bucket::default()
            });
            buckets.len() - 1
        });
        let bucket = &mut buckets[b];
        bucket.area += area;
        bucket.normal += n * area;
        bucket.offset += d * area;
        of_tri.push(Some(b));
    }

    let mut order: Vec<usize> = (0..buckets.len()).collect();
    order.sort_by(|&a, &b| buckets[b].area.total_cmp(&buckets[a].area).then(a.cmp(&b)));
    let cos_tol = NORMAL_TOL.cos();
    let mut cluster_of: Vec<Option<usize>> = vec![None; buckets.len()];
    let mut clusters: Vec<Bucket> = Vec::new();
    for &seed in &order {
        if cluster_of[seed].is_some() {
            continue;
        }
        let c = clusters.len();
        let (sn, sd) = buckets[seed].plane();
        let key = buckets[seed].key;
        let mut total = Bucket::default();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for dd in -1..=1 {
                        let k = [key[0] + dx, key[1] + dy, key[2] + dz, key[3] + dd];
                        let Some(&b) = index.get(&k) else { continue };
                        if cluster_of[b].is_some() {
                            continue;
                        }
                        let (n, d) = buckets[b].plane();
                        if b == seed || (n.dot(&sn) >= cos_tol && (d - sd).abs() <= OFFSET_TOL) {
                            cluster_of[b] = Some(c);
                            total.area += buckets[b].area;
                            total.normal += buckets[b].normal;
                            total.offset += buckets[b].offset;
                        }
                    }
                }
            }
        }
        clusters.push(total);
    }

    // Planes numbered largest first, so the first 255 ids (8-bit plane images) are the biggest.
    let mut big: Vec<usize> = (0..clusters.len())
        .filter(|&c| clusters[c].area >= MIN_PLANE_AREA)
        .collect();
    big.sort_by(|&a, &b| {
        clusters[b]
            .area
            .total_cmp(&clusters[a].area)
            .then(a.cmp(&b))
    });
    let mut id_of: Vec<PlaneId> = vec![0; clusters.len()];
    world.planes.clear();
    for c in big {
        let (normal, offset) = clusters[c].plane();
        id_of[c] = world.add_plane(Plane { normal, offset });
    }
    for (t, b) in world.triangles.iter_mut().zip(of_tri) {
        t.plane = b.and_then(|b| cluster_of[b]).map_or(0, |c| id_of[c]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Triangle;
    use nalgebra::Point3;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle {
            v: [a, b, c].map(|p| Point3::new(p[0], p[1], p[2])),
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        }
    }

    #[test]
    fn import_planes_merge_near_coplanar_and_skip_small() -> Result<(), String> {
        let mut world = World::default();
        // A 2 m x 2 m floor in two triangles, the second 1 cm higher and tilted by 0.5°.
        let tilt = 2.0 * (0.5f32).to_radians().tan();
        world
            .triangles
            .push(tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0]));
        world.triangles.push(tri(
            [0.0, 0.0, 0.01],
            [2.0, 2.0, 0.01],
            [0.0, 2.0, 0.01 + tilt],
        ));
        // A wall 3 cm behind a parallel wall: a separate plane.
        world
            .triangles
            .push(tri([0.0, 5.0, 0.0], [0.0, 5.0, 2.0], [2.0, 5.0, 0.0]));
        world
            .triangles
            .push(tri([0.0, 5.03, 0.0], [0.0, 5.03, 2.0], [2.0, 5.03, 0.0]));
        // A 0.1 m² scrap: no plane.
        world
            .triangles
            .push(tri([5.0, 5.0, 1.0], [5.5, 5.0, 1.0], [5.0, 5.4, 1.0]));
        assign(&mut world);
        let ids: Vec<PlaneId> = world.triangles.iter().map(|t| t.plane).collect();
        if world.planes.len() != 3 || ids[0] != ids[1] || ids[2] == ids[3] || ids[4] != 0 {
            return Err(format!("planes {:?}, ids {ids:?}", world.planes));
        }
        let floor = world.planes[(ids[0] - 1) as usize];
        if (floor.normal.z - 1.0).abs() > 1e-3 || (floor.offset - 0.005).abs() > 0.01 {
            return Err(format!("floor plane {floor:?}"));
        }
        Ok(())
    }
}
