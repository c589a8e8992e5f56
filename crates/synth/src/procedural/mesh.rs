//! Emitting triangles: quads and boxes with texture coordinates in metres, wall faces with
//! holes for the things set into them, and the registry of dominant planes.
//!
//! Items set into a wall or ceiling (windows, posters, light panels, vents) are coplanar with it:
//! the host face is cut around them instead of the item floating in front. That keeps their
//! triangles on the host's dominant plane (the plane-id image shows the wall, not a hole) and
//! leaves the renderer no coincident surfaces to z-fight over.

use crate::world::{MaterialId, Plane, PlaneId, Triangle, World};
use nalgebra::{Isometry3, Point3, Vector3};
use std::collections::HashMap;

/// An axis-aligned rectangle in a surface's own 2-D coordinates (u, v), metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct R2 {
    /// Lower u.
    pub u0: f32,
    /// Lower v.
    pub v0: f32,
    /// Upper u.
    pub u1: f32,
    /// Upper v.
    pub v1: f32,
}

impl R2 {
    /// A rectangle from its corners.
    pub(crate) fn new(u0: f32, v0: f32, u1: f32, v1: f32) -> Self {
        Self { u0, v0, u1, v1 }
    }

    /// A rectangle from its centre and size.
    pub(crate) fn centered(cu: f32, cv: f32, w: f32, h: f32) -> Self {
        Self::new(cu - w / 2.0, cv - h / 2.0, cu + w / 2.0, cv + h / 2.0)
    }

    /// Grown by `m` on every side.
    pub(crate) fn grow(&self, m: f32) -> Self {
        Self::new(self.u0 - m, self.v0 - m, self.u1 + m, self.v1 + m)
    }

    /// True when the interiors intersect.
    pub(crate) fn overlaps(&self, o: &R2) -> bool {
        self.u0 < o.u1 && o.u0 < self.u1 && self.v0 < o.v1 && o.v0 < self.v1
    }

    /// True when `o` lies inside (edges may touch).
    pub(crate) fn contains(&self, o: &R2) -> bool {
        o.u0 >= self.u0 && o.u1 <= self.u1 && o.v0 >= self.v0 && o.v1 <= self.v1
    }

    /// Centre.
    pub(crate) fn center(&self) -> [f32; 2] {
        [(self.u0 + self.u1) / 2.0, (self.v0 + self.v1) / 2.0]
    }

    /// Width (along u).
    pub(crate) fn w(&self) -> f32 {
        self.u1 - self.u0
    }

    /// Height (along v).
    pub(crate) fn h(&self) -> f32 {
        self.v1 - self.v0
    }
}

/// `base` minus `holes`, as non-overlapping rectangles (each hole splits the pieces it cuts
/// into at most four: left, right, below, above).
pub(crate) fn subtract(base: R2, holes: &[R2]) -> Vec<R2> {
    let mut pieces = vec![base];
    for hole in holes {
        let mut next = Vec::with_capacity(pieces.len() + 4);
        for p in pieces {
            if !p.overlaps(hole) {
                next.push(p);
                continue;
            }
            let (mu0, mu1) = (p.u0.max(hole.u0), p.u1.min(hole.u1));
            next.push(R2::new(p.u0, p.v0, mu0, p.v1));
            next.push(R2::new(mu1, p.v0, p.u1, p.v1));
            next.push(R2::new(mu0, p.v0, mu1, hole.v0.max(p.v0)));
            next.push(R2::new(mu0, hole.v1.min(p.v1), mu1, p.v1));
        }
        pieces = next
            .into_iter()
            .filter(|r| r.w() > 1e-4 && r.h() > 1e-4)
            .collect();
    }
    pieces
}

/// A vertical surface: the plane through `origin` with unit normal `n` (horizontal); `u` runs
/// along `r = z × n` (left to right as seen from the front), `v` up from `origin.z`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    /// The point with u = 0, v = 0.
    pub origin: Point3<f32>,
    /// Unit normal (horizontal), pointing to the side the face is seen from.
    pub n: Vector3<f32>,
    /// Unit u direction.
    pub r: Vector3<f32>,
}

impl Frame {
    /// The vertical frame whose normal is `n` (horizontal) through the line `n · p = offset`,
    /// with u measured from the world origin's projection (so u continues across faces).
    pub(crate) fn vertical(n: Vector3<f32>, offset: f32, floor_z: f32) -> Self {
        let r = Vector3::z().cross(&n);
        let o = n * offset;
        Self {
            origin: Point3::new(o.x, o.y, floor_z),
            n,
            r,
        }
    }

    /// The point at (u, v).
    pub(crate) fn at(&self, u: f32, v: f32) -> Point3<f32> {
        self.origin + self.r * u + Vector3::z() * v
    }
}

/// Key of a dominant plane: its normal (quantised), offset in millimetres and group.
type PlaneKey = (i32, i32, i32, i64, u8);

/// Adds triangles to a world.
pub(crate) struct Mesh<'w> {
    /// The world being built.
    pub world: &'w mut World,
    planes: HashMap<PlaneKey, PlaneId>,
}

impl<'w> Mesh<'w> {
    /// Starts adding to `world`.
    pub(crate) fn new(world: &'w mut World) -> Self {
        Self {
            world,
            planes: HashMap::new(),
        }
    }

    /// The id of the plane `n · p = offset` of `group`, registering it the first time.
    pub(crate) fn plane(&mut self, n: Vector3<f32>, offset: f32, group: u8) -> PlaneId {
        let q = |x: f32| (x * 1000.0).round() as i32;
        let key = (
            q(n.x),
            q(n.y),
            q(n.z),
            (offset * 1000.0).round() as i64,
            group,
        );
        if let Some(&id) = self.planes.get(&key) {
            return id;
        }
        let id = self.world.add_plane(Plane { normal: n, offset });
        self.planes.insert(key, id);
        id
    }

    /// One triangle (dropped when degenerate).
    pub(crate) fn tri(
        &mut self,
        v: [Point3<f32>; 3],
        uv: [[f32; 2]; 3],
        material: MaterialId,
        plane: PlaneId,
    ) {
        let t = Triangle {
            v,
            uv,
            material,
            plane,
        };
        if t.area() > 1e-7 {
            self.world.triangles.push(t);
        }
    }

    /// A planar convex quad, counter-clockwise from the front.
    pub(crate) fn quad(
        &mut self,
        v: [Point3<f32>; 4],
        uv: [[f32; 2]; 4],
        material: MaterialId,
        plane: PlaneId,
    ) {
        self.tri([v[0], v[1], v[2]], [uv[0], uv[1], uv[2]], material, plane);
        self.tri([v[0], v[2], v[3]], [uv[0], uv[2], uv[3]], material, plane);
    }

    /// A planar convex quad turned so its front faces along `facing`.
    pub(crate) fn quad_facing(
        &mut self,
        v: [Point3<f32>; 4],
        uv: [[f32; 2]; 4],
        facing: Vector3<f32>,
        material: MaterialId,
        plane: PlaneId,
    ) {
        let n = (v[1] - v[0]).cross(&(v[2] - v[0]));
        if n.dot(&facing) >= 0.0 {
            self.quad(v, uv, material, plane);
        } else {
            self.quad(
                [v[0], v[3], v[2], v[1]],
                [uv[0], uv[3], uv[2], uv[1]],
                material,
                plane,
            );
        }
    }

    /// The rectangle `rect` of a vertical frame; texture coordinates are (u, v) minus `uv_origin`.
    pub(crate) fn frame_rect(
        &mut self,
        f: &Frame,
        rect: R2,
        uv_origin: [f32; 2],
        material: MaterialId,
        plane: PlaneId,
    ) {
        let R2 { u0, v0, u1, v1 } = rect;
        let uv = |u: f32, v: f32| [u - uv_origin[0], v - uv_origin[1]];
        self.quad(
            [f.at(u0, v0), f.at(u1, v0), f.at(u1, v1), f.at(u0, v1)],
            [uv(u0, v0), uv(u1, v0), uv(u1, v1), uv(u0, v1)],
            material,
            plane,
        );
    }

    /// A horizontal rectangle (x, y in `rect`) at height `z`, seen from above (`up`) or below;
    /// texture coordinates are world (x, y) minus `uv_origin`.
    pub(crate) fn hrect(
        &mut self,
        rect: R2,
        z: f32,
        up: bool,
        uv_origin: [f32; 2],
        material: MaterialId,
        plane: PlaneId,
    ) {
        let R2 { u0, v0, u1, v1 } = rect;
        let p = |x: f32, y: f32| Point3::new(x, y, z);
        let uv = |x: f32, y: f32| [x - uv_origin[0], y - uv_origin[1]];
        let (v, t) = (
            [p(u0, v0), p(u1, v0), p(u1, v1), p(u0, v1)],
            [uv(u0, v0), uv(u1, v0), uv(u1, v1), uv(u0, v1)],
        );
        if up {
            self.quad(v, t, material, plane);
        } else {
            self.quad(
                [v[0], v[3], v[2], v[1]],
                [t[0], t[3], t[2], t[1]],
                material,
                plane,
            );
        }
    }

    /// A box of half-size `half` centred at the origin of `pose`, faces outwards, texture
    /// coordinates in metres along each face; `bottom` false leaves out the face underneath
    /// (for things standing on a floor).
    pub(crate) fn cuboid(
        &mut self,
        pose: &Isometry3<f32>,
        half: Vector3<f32>,
        material: MaterialId,
        bottom: bool,
    ) {
        let (hx, hy, hz) = (half.x, half.y, half.z);
        let c = |x: f32, y: f32, z: f32| pose * Point3::new(x, y, z);
        // Each face: four corners counter-clockwise from outside, and its size (w, h).
        let faces: [([Point3<f32>; 4], f32, f32, bool); 6] = [
            (
                [
                    c(hx, -hy, -hz),
                    c(hx, hy, -hz),
                    c(hx, hy, hz),
                    c(hx, -hy, hz),
                ],
                2.0 * hy,
                2.0 * hz,
                true,
            ),
            (
                [
                    c(-hx, hy, -hz),
                    c(-hx, -hy, -hz),
                    c(-hx, -hy, hz),
                    c(-hx, hy, hz),
                ],
                2.0 * hy,
                2.0 * hz,
                true,
            ),
            (
                [
                    c(hx, hy, -hz),
                    c(-hx, hy, -hz),
                    c(-hx, hy, hz),
                    c(hx, hy, hz),
                ],
                2.0 * hx,
                2.0 * hz,
                true,
            ),
            (
                [
                    c(-hx, -hy, -hz),
                    c(hx, -hy, -hz),
                    c(hx, -hy, hz),
                    c(-hx, -hy, hz),
                ],
                2.0 * hx,
                2.0 * hz,
                true,
            ),
            (
                [
                    c(-hx, -hy, hz),
                    c(hx, -hy, hz),
                    c(hx, hy, hz),
                    c(-hx, hy, hz),
                ],
                2.0 * hx,
                2.0 * hy,
                true,
            ),
            (
                [
                    c(-hx, hy, -hz),
                    c(hx, hy, -hz),
                    c(hx, -hy, -hz),
                    c(-hx, -hy, -hz),
                ],
                2.0 * hx,
                2.0 * hy,
                bottom,
            ),
        ];
        for (v, w, h, keep) in faces {
            if keep {
                self.quad(v, [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]], material, 0);
            }
        }
    }

    /// An axis-aligned box between two corners (no plane id: clutter).
    pub(crate) fn aabox(
        &mut self,
        min: Point3<f32>,
        max: Point3<f32>,
        material: MaterialId,
        bottom: bool,
    ) {
        let centre = nalgebra::center(&min, &max);
        let half = (max - min) / 2.0;
        self.cuboid(
            &Isometry3::translation(centre.x, centre.y, centre.z),
            half,
            material,
            bottom,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subtraction_covers_the_rest_exactly() {
        let base = R2::new(0.0, 0.0, 4.0, 3.0);
        let holes = [R2::new(1.0, 1.0, 2.0, 2.0), R2::new(2.5, 0.0, 3.0, 3.5)];
        let pieces = subtract(base, &holes);
        let area: f32 = pieces.iter().map(|p| p.w() * p.h()).sum();
        assert!((area - (12.0 - 1.0 - 1.5)).abs() < 1e-5, "{area}");
        for (i, a) in pieces.iter().enumerate() {
            assert!(holes.iter().all(|h| !a.overlaps(h)));
            assert!(pieces[i + 1..].iter().all(|b| !a.overlaps(b)));
        }
    }

    #[test]
    fn boxes_face_outwards() {
        let mut world = World::default();
        let mut mesh = Mesh::new(&mut world);
        let centre = Point3::new(1.0, 2.0, 3.0);
        mesh.aabox(
            Point3::new(0.5, 1.5, 2.5),
            Point3::new(1.5, 2.5, 3.5),
            0,
            true,
        );
        assert_eq!(world.triangles.len(), 12);
        for t in &world.triangles {
            let c = nalgebra::center(&nalgebra::center(&t.v[0], &t.v[1]), &t.v[2]);
            assert!(t.normal().dot(&(c - centre)) > 0.0);
        }
    }

    #[test]
    fn frames_and_rects_face_their_normal() {
        let mut world = World::default();
        let mut mesh = Mesh::new(&mut world);
        for n in [Vector3::x(), -Vector3::x(), Vector3::y(), -Vector3::y()] {
            let f = Frame::vertical(n, 2.0, 0.0);
            mesh.frame_rect(&f, R2::new(-1.0, 0.0, 1.0, 2.5), [0.0, 0.0], 0, 0);
        }
        mesh.hrect(R2::new(0.0, 0.0, 1.0, 1.0), 0.0, true, [0.0, 0.0], 0, 0);
        mesh.hrect(R2::new(0.0, 0.0, 1.0, 1.0), 3.0, false, [0.0, 0.0], 0, 0);
        let want = [
            Vector3::x(),
            -Vector3::x(),
            Vector3::y(),
            -Vector3::y(),
            Vector3::z(),
            -Vector3::z(),
        ];
        for (pair, n) in world.triangles.chunks(2).zip(want) {
            for t in pair {
                assert!((t.normal() - n).norm() < 1e-6);
            }
        }
        // The u axis runs left to right seen from the front: for a wall facing −y, +x.
        let f = Frame::vertical(-Vector3::y(), -2.0, 0.0);
        assert!((f.at(1.0, 0.0) - Point3::new(1.0, 2.0, 0.0)).norm() < 1e-6);
    }
}
