//! RGB-D scans to building models: a scanned room is a building model too.
//!
//! Posed depth frames (7-Scenes, TUM RGB-D, a native dataset with `depth/`) are fused into a
//! truncated signed distance volume ([`volume`]), with the colour frames' colours averaged per
//! voxel; its zero surface is extracted as a coloured triangle mesh ([`extract`], naive surface
//! nets), simplified ([`simplify`]), levelled so that z points up ([`level`]), textured from the
//! volume's colours ([`atlas`]) and written as glTF binary and PLY ([`mod@write`]). `synth` imports
//! the GLB like any building model and renders it.
//!
//! [`scan()`] runs the whole chain; each stage is public for callers that need one step.

pub mod atlas;
mod error;
pub mod extract;
pub mod level;
pub mod mesh;
pub mod scan;
pub mod simplify;
pub mod volume;
pub mod write;

pub use error::{ReconError, Result};
pub use mesh::{ColoredMesh, TexturedMesh};
pub use scan::{Scan, ScanConfig, scan};
pub use volume::{FuseConfig, FuseReport, Volume};
