//! Fewer triangles for the renderer: meshoptimizer's edge collapse (`meshopt`) with an absolute
//! error bound, which merges the flat walls, floors and cupboard fronts of a room into large
//! triangles and keeps the detail where the surface bends. Small disconnected pieces (sensor
//! noise floating in the air) are pruned. Colour is not needed here: the atlas is baked from
//! the volume afterwards.

use crate::mesh::ColoredMesh;
use meshopt::{SimplifyOptions, VertexDataAdapter, simplify as collapse, typed_to_bytes};

/// Simplifies `mesh` until no further collapse stays within `max_error_m` of the surface, or
/// `max_triangles` is reached.
pub fn simplify(mesh: &ColoredMesh, max_error_m: f32, max_triangles: usize) -> ColoredMesh {
    if mesh.indices.is_empty() {
        return mesh.clone();
    }
    let bytes = typed_to_bytes(&mesh.positions);
    let Ok(adapter) = VertexDataAdapter::new(bytes, std::mem::size_of::<[f32; 3]>(), 0) else {
        return mesh.clone();
    };
    let indices = collapse(
        &mesh.indices,
        &adapter,
        (3 * max_triangles).min(mesh.indices.len()),
        max_error_m,
        SimplifyOptions::ErrorAbsolute | SimplifyOptions::Prune,
        None,
    );
    ColoredMesh {
        indices,
        ..mesh.clone()
    }
    .compacted()
}
