//! The two meshes a scan becomes: coloured per vertex (PLY, simplification), and textured from
//! an atlas (glTF, what `synth` renders).

use geom::Pose;
use nalgebra::Point3;

/// A triangle mesh with one colour per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColoredMesh {
    /// Vertex positions, metres.
    pub positions: Vec<[f32; 3]>,
    /// Vertex colours, sRGB.
    pub colors: Vec<[u8; 3]>,
    /// Three vertex indices per triangle, counter-clockwise seen from the free space the
    /// cameras looked from.
    pub indices: Vec<u32>,
}

impl ColoredMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The corners of triangle `t`.
    pub fn triangle(&self, t: usize) -> [[f32; 3]; 3] {
        let i = &self.indices[3 * t..3 * t + 3];
        [0, 1, 2].map(|k| self.positions[i[k] as usize])
    }

    /// The mesh moved by the rigid transform `to` (`p' = R·p + t`).
    pub fn transformed(&self, to: &Pose) -> ColoredMesh {
        ColoredMesh {
            positions: transform_all(&self.positions, to),
            ..self.clone()
        }
    }

    /// Axis-aligned bounds, `None` when empty.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| {
            (
                [0, 1, 2].map(|k| lo[k].min(p[k])),
                [0, 1, 2].map(|k| hi[k].max(p[k])),
            )
        }))
    }

    /// Keeps only the vertices that triangles use, in their order of first use.
    pub fn compacted(&self) -> ColoredMesh {
        let mut map = vec![u32::MAX; self.positions.len()];
        let mut out = ColoredMesh::default();
        for &i in &self.indices {
            let slot = &mut map[i as usize];
            if *slot == u32::MAX {
                *slot = out.positions.len() as u32;
                out.positions.push(self.positions[i as usize]);
                out.colors.push(self.colors[i as usize]);
            }
            out.indices.push(*slot);
        }
        out
    }
}

/// A triangle mesh textured from one image: what the glTF file holds.
#[derive(Clone, Debug, PartialEq)]
pub struct TexturedMesh {
    /// Vertex positions, metres.
    pub positions: Vec<[f32; 3]>,
    /// Texture coordinates, 0–1, v down from the image's top row (glTF's convention).
    pub uvs: Vec<[f32; 2]>,
    /// Three vertex indices per triangle.
    pub indices: Vec<u32>,
    /// The texture atlas.
    pub atlas: image::RgbImage,
    /// Edge of one atlas texel on the surface, metres (for a typical triangle).
    pub texel_m: f64,
}

impl TexturedMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The mesh moved by the rigid transform `to`.
    pub fn transformed(&self, to: &Pose) -> TexturedMesh {
        TexturedMesh {
            positions: transform_all(&self.positions, to),
            ..self.clone()
        }
    }
}

fn transform_all(points: &[[f32; 3]], to: &Pose) -> Vec<[f32; 3]> {
    points
        .iter()
        .map(|p| {
            let q = to.transform_point(&Point3::new(
                f64::from(p[0]),
                f64::from(p[1]),
                f64::from(p[2]),
            ));
            [q.x as f32, q.y as f32, q.z as f32]
        })
        .collect()
}
