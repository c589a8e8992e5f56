//! People walking through the building: simple figures (legs, torso, neck, head, hair) that
//! follow the walk graph and occlude the view, for [`crate::Variant::People`].

use crate::trajectory::{Graph, pick_weighted, rng, stream, uniform, uniform_index};
use crate::world::{Material, MaterialId, Pattern, PlaceKind, Triangle, World};
use nalgebra::{Point3, Vector3};
use rand::Rng;
use std::collections::BTreeMap;
use std::f64::consts::TAU;

/// Length of each person's route before they walk it back, metres (about 5 minutes).
const ROUTE_M: f64 = 400.0;
/// Stride length, metres: two steps.
const STRIDE_M: f64 = 1.4;

/// People walking along the walk graph, deterministic in time: each walks a random route of
/// 400 m at their own pace (1.05–1.35 m/s) keeping to the right of the way, then walks it back,
/// so their position is a closed-form function of `t` and any frame can be rendered alone.
#[derive(Clone, Debug, PartialEq)]
pub struct Crowd {
    people: Vec<Person>,
}

#[derive(Clone, Debug, PartialEq)]
struct Person {
    /// Node indices of the route.
    route: Vec<usize>,
    /// Arc length at each route node.
    cum: Vec<f64>,
    speed: f64,
    /// Distance along the route at `t = 0`.
    offset0: f64,
    /// Keep-right distance from the edge, metres.
    lane: f64,
    height: f64,
    width: f64,
    shirt: MaterialId,
    trousers: MaterialId,
    skin: MaterialId,
    hair: MaterialId,
}

/// Where a person is at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figure {
    /// Point on the floor between the feet, metres.
    pub position: Point3<f32>,
    /// Walking direction (yaw, radians).
    pub heading: f32,
    /// Stride phase, radians: the legs swing with its sine.
    pub phase: f32,
}

impl Crowd {
    /// A crowd of `count` people spread over the corridors (each corridor in turn gets the next
    /// person, starting from a random one), adding their clothing, skin and hair materials to
    /// `world`. A world without a usable walk graph gets an empty crowd.
    pub fn new(world: &mut World, count: usize, seed: u64) -> Crowd {
        let mut r = rng(seed, stream::CROWD);
        let Ok(graph) = Graph::new(world) else {
            return Crowd { people: Vec::new() };
        };
        let groups = corridor_edges(world, &graph);
        if count == 0 || groups.is_empty() {
            return Crowd { people: Vec::new() };
        }
        let style = crate::trajectory::route_style_for_people();
        let first = uniform_index(&mut r, groups.len());
        let mut routes = Vec::with_capacity(count);
        for i in 0..count {
            let edges = &groups[(first + i) % groups.len()];
            let lengths: Vec<f64> = edges
                .iter()
                .map(|&[a, b]| (graph.pos(a) - graph.pos(b)).norm())
                .collect();
            let [a, b] = edges[pick_weighted(&mut r, &lengths).unwrap_or(0)];
            let start = if r.random_bool(0.5) { a } else { b };
            let route = graph.route(start, ROUTE_M, &style, &mut r);
            let mut cum = vec![0.0];
            for w in route.windows(2) {
                let last = cum.last().copied().unwrap_or(0.0);
                cum.push(last + (graph.pos(w[1]) - graph.pos(w[0])).norm());
            }
            let first_edge = cum.get(1).copied().unwrap_or(0.0);
            routes.push((route, cum, uniform(&mut r, 0.0, first_edge)));
        }
        let palette = Palette::add(world, seed);
        let people = routes
            .into_iter()
            .map(|(route, cum, offset0)| Person {
                route,
                cum,
                speed: uniform(&mut r, 1.05, 1.35),
                offset0,
                lane: uniform(&mut r, 0.15, 0.35),
                height: uniform(&mut r, 1.6, 1.85),
                width: uniform(&mut r, 0.42, 0.48),
                shirt: palette.shirts[uniform_index(&mut r, palette.shirts.len())],
                trousers: palette.trousers[uniform_index(&mut r, palette.trousers.len())],
                skin: palette.skin[uniform_index(&mut r, palette.skin.len())],
                hair: palette.hair[uniform_index(&mut r, palette.hair.len())],
            })
            .collect();
        Crowd { people }
    }

    /// A sensible crowd size: three people per corridor (so every corridor shows someone now
    /// and then without blocking it), or three in all where the world labels no corridors.
    pub fn suggested_count(world: &World) -> usize {
        let corridors: std::collections::BTreeSet<u16> = world
            .walk
            .nodes
            .iter()
            .filter_map(|n| world.regions.get(n.region))
            .filter(|r| r.place.kind == PlaceKind::Corridor)
            .filter_map(|r| r.place.corridor)
            .collect();
        if world.walk.edges.is_empty() {
            0
        } else {
            3 * corridors.len().max(1)
        }
    }

    /// Number of people.
    pub fn len(&self) -> usize {
        self.people.len()
    }

    /// True for a crowd of nobody.
    pub fn is_empty(&self) -> bool {
        self.people.is_empty()
    }

    /// Where everyone is at time `t` (seconds). People whose route no longer fits `world` (a
    /// different world than the crowd was made for) are left out.
    pub fn figures_at(&self, world: &World, t: f64) -> Vec<Figure> {
        self.people
            .iter()
            .filter_map(|p| p.figure(world, t))
            .collect()
    }

    /// The triangles of everyone at time `t`: about 72 per person, plane id 0 (not a dominant
    /// plane), to be added to the world's triangles for that frame only.
    pub fn triangles_at(&self, world: &World, t: f64) -> Vec<Triangle> {
        let mut out = Vec::with_capacity(self.people.len() * 72);
        for p in &self.people {
            if let Some(f) = p.figure(world, t) {
                p.body(&f, &mut out);
            }
        }
        out
    }
}

impl Crowd {
    /// As [`Crowd::triangles_at`], leaving out anyone whose body would come within
    /// `clearance_m` (horizontally) of `camera`: people walk through the camera's path
    /// unaware of it, and a camera inside a figure would show nothing but a shirt.
    pub fn triangles_clear_of(
        &self,
        world: &World,
        t: f64,
        camera: &Point3<f64>,
        clearance_m: f64,
    ) -> Vec<Triangle> {
        let mut out = Vec::with_capacity(self.people.len() * 72);
        for p in &self.people {
            let Some(f) = p.figure(world, t) else {
                continue;
            };
            if !p.within(&f, camera, clearance_m) {
                p.body(&f, &mut out);
            }
        }
        out
    }

    /// Which people come within `clearance_m` of the camera at any of `shot`'s
    /// `(time, camera centre)` pairs. Leaving them out of the whole shot (with
    /// [`Crowd::triangles_without`]) keeps anyone from popping in or out of view between two
    /// frames, which [`Crowd::triangles_clear_of`] per frame would do: a jump no real camera
    /// sees, and one a scene-cut detector rightly takes for a cut.
    pub fn too_close(
        &self,
        world: &World,
        shot: &[(f64, Point3<f64>)],
        clearance_m: f64,
    ) -> Vec<bool> {
        self.people
            .iter()
            .map(|p| {
                shot.iter().any(|(t, camera)| {
                    p.figure(world, *t)
                        .is_some_and(|f| p.within(&f, camera, clearance_m))
                })
            })
            .collect()
    }

    /// As [`Crowd::triangles_at`], without the people marked in `left_out` (indexed like
    /// [`Crowd::too_close`]'s answer).
    pub fn triangles_without(&self, world: &World, t: f64, left_out: &[bool]) -> Vec<Triangle> {
        let mut out = Vec::with_capacity(self.people.len() * 72);
        for (i, p) in self.people.iter().enumerate() {
            if left_out.get(i).copied().unwrap_or(false) {
                continue;
            }
            if let Some(f) = p.figure(world, t) {
                p.body(&f, &mut out);
            }
        }
        out
    }
}

impl Person {
    /// Whether this person, standing as `f`, comes within `clearance_m` of `camera`
    /// (horizontally, on the camera's level).
    fn within(&self, f: &Figure, camera: &Point3<f64>, clearance_m: f64) -> bool {
        let at = f.position.cast::<f64>();
        let dxy = (at.xy() - camera.xy()).norm();
        let level = camera.z >= at.z - 0.5 && camera.z <= at.z + self.height + 0.5;
        level && dxy < clearance_m + self.width / 2.0 + 0.15
    }

    fn figure(&self, world: &World, t: f64) -> Option<Figure> {
        let total = *self.cum.last()?;
        if total.is_nan() || total <= 0.0 || !t.is_finite() {
            return None;
        }
        let u = self.offset0 + self.speed * t;
        let m = u.rem_euclid(2.0 * total);
        let (s, sign) = if m <= total {
            (m, 1.0)
        } else {
            (2.0 * total - m, -1.0)
        };
        let k = self
            .cum
            .partition_point(|&c| c <= s)
            .saturating_sub(1)
            .min(self.route.len().saturating_sub(2));
        let node = |i: usize| -> Option<Vector3<f64>> {
            let n = world.walk.nodes.get(*self.route.get(i)?)?;
            Some(n.p.coords.cast::<f64>())
        };
        let (a, b) = (node(k)?, node(k + 1)?);
        let len = self.cum[k + 1] - self.cum[k];
        let local = (s - self.cum[k]).clamp(0.0, len);
        let frac = if len > 0.0 { local / len } else { 0.0 };
        let mut dir = (b - a) * sign;
        dir.z = 0.0;
        let dxy = dir.norm();
        let fwd = if dxy > 1e-9 { dir / dxy } else { Vector3::x() };
        let right = Vector3::new(fwd.y, -fwd.x, 0.0);
        // Keep right, but join the centre line at the nodes so turns do not make them jump.
        let x = (local.min(len - local) / 1.0).clamp(0.0, 1.0);
        let taper = x * x * (3.0 - 2.0 * x);
        let p = a + (b - a) * frac + right * (self.lane * taper);
        Some(Figure {
            position: Point3::from(p.cast::<f32>()),
            heading: fwd.y.atan2(fwd.x) as f32,
            phase: (TAU * u / STRIDE_M).rem_euclid(TAU) as f32,
        })
    }

    /// Boxes for legs (swinging with the stride), torso, neck, head and hair.
    fn body(&self, f: &Figure, out: &mut Vec<Triangle>) {
        let h = self.height as f32;
        let (s, c) = f.heading.sin_cos();
        let fwd = Vector3::new(c, s, 0.0);
        let right = Vector3::new(s, -c, 0.0);
        let base = f.position.coords;
        let swing = 0.2 * f.phase.sin();
        let hip = 0.47 * h;
        for (side, sign) in [(-1.0f32, 1.0f32), (1.0, -1.0)] {
            cuboid(
                out,
                Part {
                    center: base + right * (0.1 * side),
                    fwd,
                    right,
                    half: [0.065, 0.075],
                    z: [0.0, hip],
                    foot_shift: fwd * (swing * sign),
                },
                self.trousers,
            );
        }
        let part = |half: [f32; 2], z: [f32; 2]| Part {
            center: base,
            fwd,
            right,
            half,
            z,
            foot_shift: Vector3::zeros(),
        };
        cuboid(
            out,
            part([self.width as f32 / 2.0, 0.12], [hip, 0.82 * h]),
            self.shirt,
        );
        cuboid(out, part([0.05, 0.05], [0.82 * h, 0.86 * h]), self.skin);
        cuboid(out, part([0.085, 0.1], [0.86 * h, 0.96 * h]), self.skin);
        cuboid(out, part([0.09, 0.105], [0.96 * h, h]), self.hair);
    }
}

/// A box standing on the floor: `center` is the middle of its footprint at z = 0 of the
/// figure, `half` its half width (along `right`) and depth (along `fwd`), `z` its bottom and
/// top above the floor; the bottom face is moved by `foot_shift` (a swinging leg).
struct Part {
    center: Vector3<f32>,
    fwd: Vector3<f32>,
    right: Vector3<f32>,
    half: [f32; 2],
    z: [f32; 2],
    foot_shift: Vector3<f32>,
}

/// Twelve triangles of a box, wound counter-clockwise seen from outside.
fn cuboid(out: &mut Vec<Triangle>, p: Part, material: MaterialId) {
    let up = Vector3::z();
    let corner = |i: usize| -> Vector3<f32> {
        let sx = if i & 1 == 0 { -1.0 } else { 1.0 };
        let sy = if i & 2 == 0 { -1.0 } else { 1.0 };
        let top = i & 4 != 0;
        let mut v = p.center + p.right * (sx * p.half[0]) + p.fwd * (sy * p.half[1]);
        v += up * if top { p.z[1] } else { p.z[0] };
        if !top {
            v += p.foot_shift;
        }
        v
    };
    let c: [Vector3<f32>; 8] = std::array::from_fn(corner);
    let middle = c.iter().sum::<Vector3<f32>>() / 8.0;
    // Faces as corner quads (in order around the face).
    const FACES: [[usize; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    for face in FACES {
        let q = face.map(|i| c[i]);
        let w = (q[1] - q[0]).norm();
        let h = (q[3] - q[0]).norm();
        let uv = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]];
        let n = (q[1] - q[0]).cross(&(q[2] - q[0]));
        let centre = (q[0] + q[1] + q[2] + q[3]) / 4.0;
        let outward = n.dot(&(centre - middle)) >= 0.0;
        let order: [[usize; 3]; 2] = if outward {
            [[0, 1, 2], [0, 2, 3]]
        } else {
            [[0, 2, 1], [0, 3, 2]]
        };
        for tri in order {
            out.push(Triangle {
                v: tri.map(|k| Point3::from(q[k])),
                uv: tri.map(|k| uv[k]),
                material,
                plane: 0,
            });
        }
    }
}

/// The people's materials.
struct Palette {
    shirts: Vec<MaterialId>,
    trousers: Vec<MaterialId>,
    skin: Vec<MaterialId>,
    hair: Vec<MaterialId>,
}

impl Palette {
    fn add(world: &mut World, seed: u64) -> Palette {
        let mut add = |name: &str, color: [f32; 3], pattern: Pattern, k: u64| {
            world.add_material(Material {
                name: format!("person {name}"),
                color,
                pattern,
                seed: seed.wrapping_mul(31).wrapping_add(k),
                emissive: 0.0,
                unlit: false,
            })
        };
        let shirts = [
            ("shirt navy", [0.12, 0.16, 0.32]),
            ("shirt black", [0.08, 0.08, 0.09]),
            ("shirt grey", [0.45, 0.46, 0.48]),
            ("shirt white", [0.88, 0.88, 0.86]),
            ("shirt red", [0.62, 0.12, 0.12]),
            ("shirt green", [0.2, 0.4, 0.25]),
            ("shirt beige", [0.72, 0.64, 0.5]),
            ("shirt light blue", [0.55, 0.7, 0.85]),
        ];
        let trousers = [
            ("trousers denim", [0.2, 0.27, 0.42]),
            ("trousers black", [0.07, 0.07, 0.08]),
            ("trousers khaki", [0.6, 0.54, 0.4]),
            ("trousers grey", [0.32, 0.32, 0.34]),
        ];
        let skin = [
            ("skin light", [0.93, 0.78, 0.67]),
            ("skin medium", [0.78, 0.58, 0.44]),
            ("skin tan", [0.6, 0.42, 0.3]),
            ("skin dark", [0.36, 0.24, 0.17]),
        ];
        let hair = [
            ("hair black", [0.06, 0.05, 0.05]),
            ("hair brown", [0.3, 0.2, 0.12]),
            ("hair blond", [0.78, 0.66, 0.42]),
            ("hair grey", [0.62, 0.62, 0.6]),
        ];
        let mut k = 0;
        let mut many = |list: &[(&str, [f32; 3])], pattern: Pattern| -> Vec<MaterialId> {
            list.iter()
                .map(|(name, color)| {
                    k += 1;
                    add(name, *color, pattern.clone(), k)
                })
                .collect()
        };
        Palette {
            shirts: many(&shirts, Pattern::Fabric),
            trousers: many(&trousers, Pattern::Fabric),
            skin: many(&skin, Pattern::Plain),
            hair: many(&hair, Pattern::Plain),
        }
    }
}

/// Walk-graph edges grouped by corridor (both ends in the same corridor), in corridor order;
/// all edges as one group where the world labels no corridors.
fn corridor_edges(world: &World, graph: &Graph<'_>) -> Vec<Vec<[usize; 2]>> {
    let mut groups: BTreeMap<u16, Vec<[usize; 2]>> = BTreeMap::new();
    let corridor = |i: usize| {
        graph
            .place(i)
            .filter(|p| p.kind == PlaceKind::Corridor)
            .and_then(|p| p.corridor)
    };
    let valid: Vec<[usize; 2]> = world
        .walk
        .edges
        .iter()
        .copied()
        .filter(|&[a, b]| a != b && a < graph.adj.len() && b < graph.adj.len())
        .collect();
    for &[a, b] in &valid {
        if let (Some(ca), Some(cb)) = (corridor(a), corridor(b))
            && ca == cb
        {
            groups.entry(ca).or_default().push([a, b]);
        }
    }
    if groups.is_empty() {
        if valid.is_empty() {
            Vec::new()
        } else {
            vec![valid]
        }
    } else {
        groups.into_values().collect()
    }
}
