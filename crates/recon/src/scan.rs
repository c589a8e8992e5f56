//! The whole chain: fuse, extract, simplify, bake the atlas, level.

use crate::atlas::{self, AtlasConfig};
use crate::mesh::{ColoredMesh, TexturedMesh};
use crate::volume::{self, FuseConfig, FuseReport, Volume};
use crate::{ReconError, Result, extract, level, simplify, write};
use data::posed::{PosedDataset, PosedImage};
use geom::Pose;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Everything that shapes a scan's mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanConfig {
    /// Fusion: voxel, truncation, frames.
    pub fuse: FuseConfig,
    /// Simplification's error bound, metres (default: half a voxel).
    pub max_error_m: Option<f64>,
    /// Most triangles after simplification.
    pub max_triangles: usize,
    /// Largest atlas, texels (its texel starts at one voxel; its sides stay within
    /// [`atlas::MAX_SIDE`]).
    pub max_texels: usize,
}

impl Default for ScanConfig {
    fn default() -> Self {
        Self {
            fuse: FuseConfig::default(),
            max_error_m: None,
            max_triangles: 400_000,
            max_texels: 12 * 1024 * 1024,
        }
    }
}

/// A scanned room as a building model.
pub struct Scan {
    /// The textured mesh, levelled (z up).
    pub textured: TexturedMesh,
    /// The simplified mesh with vertex colours, levelled.
    pub colored: ColoredMesh,
    /// Dataset frame → the mesh's levelled frame.
    pub dataset_to_world: Pose,
    /// What fusion found.
    pub report: FuseReport,
    /// Triangles straight out of the extraction, before simplification.
    pub extracted_triangles: usize,
    /// Seconds fusing, extracting, simplifying and baking.
    pub seconds: [f64; 4],
    /// The fused volume, in the dataset's frame.
    pub volume: Volume,
}

/// Scans `frames` of `ds` (the subset [`FuseConfig::frames`] and `stride` choose); `tick` is
/// called once per fused frame.
pub fn scan(
    ds: &PosedDataset,
    frames: &[&PosedImage],
    cfg: &ScanConfig,
    tick: &(dyn Fn() + Sync),
) -> Result<Scan> {
    let chosen = volume::selected(frames, &cfg.fuse);
    let t = Instant::now();
    let (volume, report) = volume::fuse(ds, &chosen, &cfg.fuse, tick)?;
    let fuse_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let raw = extract::extract(&volume);
    let extract_s = t.elapsed().as_secs_f64();
    if raw.indices.is_empty() {
        return Err(ReconError::scan(
            &ds.root,
            format!(
                "fusing {} frames gave no surface (median TSDF residual {:.1} mm): check that \
                 the poses are camera-to-world and the depth matches the colour frames",
                report.frames,
                1e3 * report.median_residual_m
            ),
        ));
    }
    let t = Instant::now();
    let max_error = cfg.max_error_m.unwrap_or(cfg.fuse.voxel_m / 2.0) as f32;
    let simple = simplify::simplify(&raw, max_error, cfg.max_triangles);
    let simplify_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let atlas_cfg = AtlasConfig {
        texel_m: cfg.fuse.voxel_m,
        max_texels: cfg.max_texels,
    };
    let textured = atlas::bake(&simple, &volume, &atlas_cfg);
    let bake_s = t.elapsed().as_secs_f64();
    let poses: Vec<Pose> = chosen.iter().map(|i| i.frame.pose).collect();
    let to_world = level::leveling(&poses, &simple);
    Ok(Scan {
        textured: textured.transformed(&to_world),
        colored: simple.transformed(&to_world),
        dataset_to_world: to_world,
        report,
        extracted_triangles: raw.triangle_count(),
        seconds: [fuse_s, extract_s, simplify_s, bake_s],
        volume,
    })
}

impl Scan {
    /// Writes the GLB to `glb` and the PLY beside it (same name, `.ply`); returns the PLY's
    /// path. `dataset` names the scanned dataset in the GLB's extras.
    pub fn write(&self, glb: &Path, dataset: &str) -> Result<PathBuf> {
        write::write_glb(glb, &self.textured, &self.dataset_to_world, dataset)?;
        let ply = glb.with_extension("ply");
        write::write_ply(&ply, &self.colored)?;
        Ok(ply)
    }
}
