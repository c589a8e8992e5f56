//! The building model every part of `synth` shares: triangles with materials and dominant-plane
//! ids, light sources, labelled regions of free space, and a walk graph for trajectories.
//!
//! World coordinates follow DESIGN.md: metres, right-handed, z up, each storey's floor at its
//! `floor_z`. Geometry is `f32`: a building is at most a few hundred metres across, where `f32`
//! keeps millimetres, and the renderer's inner loops run twice as wide.

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Index into [`World::materials`].
pub type MaterialId = u16;

/// Index into [`World::planes`] plus one; 0 means "not on a dominant plane" (clutter, people).
pub type PlaneId = u32;

/// One triangle of the building.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    /// Corners, counter-clockwise seen from the front (the side the normal points to).
    pub v: [Point3<f32>; 3],
    /// Texture coordinates of the corners, in metres along the surface for procedural materials
    /// (so patterns keep their real size), or 0–1 image coordinates for imported textures.
    pub uv: [[f32; 2]; 3],
    /// The material.
    pub material: MaterialId,
    /// The dominant plane the triangle lies on (see [`PlaneId`]).
    pub plane: PlaneId,
}

impl Triangle {
    /// Unit normal (counter-clockwise front face); zero for a degenerate triangle.
    pub fn normal(&self) -> Vector3<f32> {
        let n = (self.v[1] - self.v[0]).cross(&(self.v[2] - self.v[0]));
        let len = n.norm();
        if len > 0.0 { n / len } else { Vector3::zeros() }
    }

    /// Area, square metres.
    pub fn area(&self) -> f32 {
        (self.v[1] - self.v[0])
            .cross(&(self.v[2] - self.v[0]))
            .norm()
            / 2.0
    }
}

/// How a material looks in `textured` mode; `shaded` mode uses only [`Material::color`].
#[derive(Clone, Debug, PartialEq)]
pub enum Pattern {
    /// Uniform colour (paint).
    Plain,
    /// Square tiles of `size` metres with grout lines (ceiling tiles, floor tiles).
    Tiles {
        /// Tile edge, metres.
        size: f32,
    },
    /// Short-pile carpet: fine noise.
    Carpet,
    /// Wood grain (doors, furniture).
    Wood,
    /// Concrete: blotchy noise (stairwells, car parks).
    Concrete,
    /// Brick courses.
    Brick,
    /// A poster: random blocks of colour and "text" lines drawn from the material's seed.
    Poster,
    /// A cork notice board with pinned sheets drawn from the seed.
    NoticeBoard,
    /// A sign: a coloured plate with a pictogram-like shape from the seed.
    Sign,
    /// A window pane: bright sky gradient, with mullions.
    Window,
    /// A ceiling light panel: bright, with a diffuser grid (emissive).
    LightPanel,
    /// A ceiling vent: slats.
    Vent,
    /// Brushed metal (sprinklers, handles, fire extinguisher fittings).
    Metal,
    /// Woven fabric (chairs, sofas).
    Fabric,
    /// An image texture from an imported model, sampled with `uv` in 0–1.
    Image(Arc<image::RgbImage>),
    /// An image texture packed as an atlas of square cells, one per triangle, each at least
    /// `cell` texels a side and aligned to its size (a scan's, from `recon`; glTF material
    /// extras `indoorloc_atlas_cell`). Its mip levels stop where a cell is one texel: past
    /// that a texel would average the cells of unrelated triangles, and far or oblique
    /// surfaces would show their colours as speckle.
    Atlas {
        /// The atlas.
        image: Arc<image::RgbImage>,
        /// Side of the smallest cell, texels.
        cell: u32,
    },
}

impl Pattern {
    /// The image of an image texture or atlas.
    pub fn image(&self) -> Option<&Arc<image::RgbImage>> {
        match self {
            Pattern::Image(image) | Pattern::Atlas { image, .. } => Some(image),
            _ => None,
        }
    }
}

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name (from the model file, or what the generator calls it).
    pub name: String,
    /// Base colour, sRGB 0–1: the flat colour of `shaded` mode and the tint of `textured`.
    pub color: [f32; 3],
    /// The procedural pattern or image of `textured` mode.
    pub pattern: Pattern,
    /// Seed of the pattern's random content (posters, notice boards, noise).
    pub seed: u64,
    /// Light the surface gives off by itself, 0 (none) to 1 (a lit panel).
    pub emissive: f32,
    /// Shown as it is, without shading (glTF `KHR_materials_unlit`): a scan's texture is a
    /// photograph with the room's light already in it, and lighting it again would darken
    /// and double its shadows. Such a surface ignores lamps, daylight and its own `emissive`;
    /// only the atmosphere's ambient level scales it (see [`Atmosphere::DEFAULT_AMBIENT`]).
    pub unlit: bool,
}

impl Material {
    /// A plain material of one colour.
    pub fn plain(name: impl Into<String>, color: [f32; 3]) -> Self {
        Self {
            name: name.into(),
            color,
            pattern: Pattern::Plain,
            seed: 0,
            emissive: 0.0,
            unlit: false,
        }
    }
}

/// A light source (a ceiling panel, a lamp), treated as a point for shading.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Position, metres.
    pub position: Point3<f32>,
    /// Brightness relative to a typical ceiling panel (1.0).
    pub intensity: f32,
    /// Switched on.
    pub on: bool,
    /// The emissive material shown on the fixture, so a switched-off panel also looks off.
    pub fixture: Option<MaterialId>,
}

/// A dominant plane (wall, floor, ceiling): points `p` with `normal · p = offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal.
    pub normal: Vector3<f32>,
    /// Distance from the origin along the normal, metres.
    pub offset: f32,
}

/// What kind of space a region is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlaceKind {
    /// A corridor (has an id and an axis).
    Corridor,
    /// A room off a corridor.
    Room,
    /// A stairwell between storeys.
    Stairwell,
    /// A lobby or hall.
    Lobby,
    /// A covered walkway between buildings.
    Bridge,
}

/// The place label of a point of free space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Place {
    /// Building index, 0-based.
    pub building: u8,
    /// Storey index, 0 = ground floor.
    pub storey: u8,
    /// Corridor id, unique in the world, for corridors and the rooms off them.
    pub corridor: Option<u16>,
    /// The kind of space.
    pub kind: PlaceKind,
    /// Yaw (radians) of the corridor's "forward" direction, for walking-direction labels.
    pub axis: Option<f32>,
}

/// An axis-aligned box of free space with its place label.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// Lower corner (x, y), metres.
    pub min: [f32; 2],
    /// Upper corner (x, y), metres.
    pub max: [f32; 2],
    /// Floor height, metres.
    pub floor_z: f32,
    /// Ceiling height, metres.
    pub ceiling_z: f32,
    /// The label.
    pub place: Place,
}

impl Region {
    /// True when `p` lies inside (floor inclusive, ceiling exclusive).
    pub fn contains(&self, p: &Point3<f32>) -> bool {
        p.x >= self.min[0]
            && p.x <= self.max[0]
            && p.y >= self.min[1]
            && p.y <= self.max[1]
            && p.z >= self.floor_z
            && p.z < self.ceiling_z
    }
}

/// A node of the walk graph: a point on a floor where a person may stand.
#[derive(Clone, Debug, PartialEq)]
pub struct WalkNode {
    /// Point on the floor, metres.
    pub p: Point3<f32>,
    /// The region it lies in (index into [`World::regions`]).
    pub region: usize,
}

/// Where people can walk: nodes on floors joined by straight, unobstructed edges (corridor
/// centre lines, door thresholds, stairs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WalkGraph {
    /// The nodes.
    pub nodes: Vec<WalkNode>,
    /// Undirected edges between node indices.
    pub edges: Vec<[usize; 2]>,
}

impl WalkGraph {
    /// Neighbours of every node.
    pub fn adjacency(&self) -> Vec<Vec<usize>> {
        let mut adj = vec![Vec::new(); self.nodes.len()];
        for &[a, b] in &self.edges {
            adj[a].push(b);
            adj[b].push(a);
        }
        adj
    }

    /// The part of the graph whose nodes lie in regions of `regions` that `keep` accepts, with
    /// the edges between them (nodes renumbered, region indices kept). Walks on it stay in one
    /// zone of a building, e.g. one storey, so a small dataset can cover that zone densely.
    pub fn within(&self, regions: &[Region], keep: impl Fn(&Place) -> bool) -> WalkGraph {
        let mut new_index = vec![None; self.nodes.len()];
        let mut nodes = Vec::new();
        for (i, node) in self.nodes.iter().enumerate() {
            if regions.get(node.region).is_some_and(|r| keep(&r.place)) {
                new_index[i] = Some(nodes.len());
                nodes.push(node.clone());
            }
        }
        let edges = self
            .edges
            .iter()
            .filter_map(|&[a, b]| Some([(*new_index.get(a)?)?, (*new_index.get(b)?)?]))
            .collect();
        WalkGraph { nodes, edges }
    }
}

/// Conditions of the air and light as a whole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Atmosphere {
    /// Light reaching every surface regardless of sources, 0–1.
    pub ambient: f32,
    /// Daylight through windows, 0 (night) to 1 (bright day).
    pub daylight: f32,
    /// Haze (smoke) density per metre; 0 for clear air.
    pub haze: f32,
    /// Colour of the haze, sRGB 0–1.
    pub haze_color: [f32; 3],
}

impl Atmosphere {
    /// The ambient level of the default atmosphere. An unlit surface ([`Material::unlit`])
    /// shows its colour as it is at this level, and in proportion to `ambient` otherwise, so
    /// that variants which dim the air (evening, disaster) dim a scan's photographed light too.
    pub const DEFAULT_AMBIENT: f32 = 0.25;
}

impl Default for Atmosphere {
    fn default() -> Self {
        Self {
            ambient: Self::DEFAULT_AMBIENT,
            daylight: 0.6,
            haze: 0.0,
            haze_color: [0.6, 0.6, 0.6],
        }
    }
}

/// A building model ready to render and walk through.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct World {
    /// Name (the generator and seed, or the model file).
    pub name: String,
    /// All triangles.
    pub triangles: Vec<Triangle>,
    /// Materials, indexed by [`MaterialId`].
    pub materials: Vec<Material>,
    /// Dominant planes, indexed by [`PlaneId`] − 1.
    pub planes: Vec<Plane>,
    /// Light sources.
    pub lights: Vec<Light>,
    /// Labelled free space.
    pub regions: Vec<Region>,
    /// Where people walk.
    pub walk: WalkGraph,
    /// Ambient light, daylight, haze.
    pub atmosphere: Atmosphere,
}

impl World {
    /// The place label at `p`, if `p` lies in a labelled region.
    pub fn place_at(&self, p: &Point3<f32>) -> Option<&Place> {
        self.regions
            .iter()
            .find(|r| r.contains(p))
            .map(|r| &r.place)
    }

    /// Axis-aligned bounds of all triangles: (min, max); `None` for an empty world.
    pub fn bounds(&self) -> Option<(Point3<f32>, Point3<f32>)> {
        let mut it = self.triangles.iter().flat_map(|t| t.v.iter());
        let first = *it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p))))
    }

    /// Adds a material and returns its id.
    pub fn add_material(&mut self, m: Material) -> MaterialId {
        self.materials.push(m);
        (self.materials.len() - 1) as MaterialId
    }

    /// Adds a dominant plane and returns its id.
    pub fn add_plane(&mut self, p: Plane) -> PlaneId {
        self.planes.push(p);
        self.planes.len() as PlaneId
    }

    /// Hangs a flat picture (a printed marker, a photo) on a wall: a `width` x `height` metre
    /// rectangle centred at `centre`, its image upright along the unit vectors `right` and `up`,
    /// facing `right × up`. Returns the corners top-left, top-right, bottom-right, bottom-left
    /// (the image's own corners, as a marker's). Keep it a millimetre or so in front of the wall
    /// so depth ties never hide it.
    pub fn add_wall_picture(
        &mut self,
        name: impl Into<String>,
        image: Arc<image::RgbImage>,
        centre: Point3<f32>,
        right: Vector3<f32>,
        up: Vector3<f32>,
        size: [f32; 2],
    ) -> [Point3<f32>; 4] {
        let material = self.add_material(Material {
            pattern: Pattern::Image(image),
            ..Material::plain(name, [1.0; 3])
        });
        let (hx, hy) = (right * size[0] / 2.0, up * size[1] / 2.0);
        let corners = [
            centre - hx + hy,
            centre + hx + hy,
            centre + hx - hy,
            centre - hx - hy,
        ];
        // Image textures: uv in 0–1 with v = 0 at the image's top row.
        let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for [a, b, c] in [[0, 3, 2], [0, 2, 1]] {
            self.triangles.push(Triangle {
                v: [corners[a], corners[b], corners[c]],
                uv: [uv[a], uv[b], uv[c]],
                material,
                plane: 0,
            });
        }
        corners
    }
}

/// An appearance condition: the same building and trajectory under different circumstances, so
/// evaluation can hold one out.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Variant {
    /// As built: lights on, daylight, nothing changed.
    #[default]
    Normal,
    /// About half the ceiling lights switched off.
    SomeLightsOff,
    /// All lights dimmed, little daylight (evening).
    Dim,
    /// Strong low daylight through windows (morning sun), lights off.
    Daylight,
    /// People walking through the corridors, occluding the view.
    People,
    /// Furniture moved to other places.
    FurnitureMoved,
    /// Posters, notice boards and signs replaced by others.
    PostersChanged,
    /// After a disaster: debris on floors, missing ceiling tiles, smoke haze, most lights off.
    Disaster,
    /// Every surface material swapped for another (repainting, another season's light).
    TextureSwap,
}

impl Variant {
    /// Every variant, in a fixed order.
    pub const ALL: [Variant; 9] = [
        Variant::Normal,
        Variant::SomeLightsOff,
        Variant::Dim,
        Variant::Daylight,
        Variant::People,
        Variant::FurnitureMoved,
        Variant::PostersChanged,
        Variant::Disaster,
        Variant::TextureSwap,
    ];

    /// The command-line name (`some-lights-off`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            Variant::Normal => "normal",
            Variant::SomeLightsOff => "some-lights-off",
            Variant::Dim => "dim",
            Variant::Daylight => "daylight",
            Variant::People => "people",
            Variant::FurnitureMoved => "furniture-moved",
            Variant::PostersChanged => "posters-changed",
            Variant::Disaster => "disaster",
            Variant::TextureSwap => "texture-swap",
        }
    }
}

impl std::str::FromStr for Variant {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Variant::ALL
            .iter()
            .find(|v| v.name() == s)
            .copied()
            .ok_or_else(|| {
                let names: Vec<&str> = Variant::ALL.iter().map(|v| v.name()).collect();
                format!("unknown variant '{s}' (one of: {})", names.join(", "))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_normal_and_area() {
        let t = Triangle {
            v: [
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(2.0, 0.0, 0.0),
                Point3::new(0.0, 2.0, 0.0),
            ],
            uv: [[0.0; 2]; 3],
            material: 0,
            plane: 0,
        };
        assert_eq!(t.normal(), Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(t.area(), 2.0);
    }

    #[test]
    fn walk_graph_within_keeps_one_storey() {
        let region = |storey| Region {
            min: [0.0, 0.0],
            max: [1.0, 1.0],
            floor_z: 3.0 * f32::from(storey),
            ceiling_z: 3.0 * f32::from(storey) + 2.5,
            place: Place {
                building: 0,
                storey,
                corridor: None,
                kind: PlaceKind::Corridor,
                axis: None,
            },
        };
        let node = |region, z| WalkNode {
            p: Point3::new(0.5, 0.5, z),
            region,
        };
        let graph = WalkGraph {
            nodes: vec![node(0, 0.0), node(1, 3.0), node(0, 0.0), node(1, 3.0)],
            edges: vec![[0, 1], [0, 2], [1, 3], [2, 3]],
        };
        let regions = [region(0), region(1)];
        let upper = graph.within(&regions, |p| p.storey == 1);
        assert_eq!(upper.nodes, vec![node(1, 3.0), node(1, 3.0)]);
        assert_eq!(upper.edges, vec![[0, 1]]);
        assert!(graph.within(&regions, |p| p.storey == 7).nodes.is_empty());
    }

    #[test]
    fn variant_names_round_trip() {
        for v in Variant::ALL {
            assert_eq!(v.name().parse::<Variant>(), Ok(v));
        }
        assert!("foggy".parse::<Variant>().is_err());
    }

    #[test]
    fn place_lookup() {
        let place = Place {
            building: 1,
            storey: 2,
            corridor: Some(7),
            kind: PlaceKind::Corridor,
            axis: Some(0.0),
        };
        let world = World {
            regions: vec![Region {
                min: [0.0, 0.0],
                max: [10.0, 2.0],
                floor_z: 6.0,
                ceiling_z: 9.0,
                place: place.clone(),
            }],
            ..World::default()
        };
        assert_eq!(world.place_at(&Point3::new(5.0, 1.0, 7.5)), Some(&place));
        assert_eq!(world.place_at(&Point3::new(5.0, 1.0, 9.5)), None);
    }
}
