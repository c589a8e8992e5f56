//! Synthetic buildings: the procedural default building, imported models, a CPU renderer, camera
//! trajectories, appearance variants and dataset export.
//!
//! # Conventions
//! World: metres, right-handed, z up. Cameras and poses come from `geom` (camera-to-world,
//! OpenCV axes). Depth images hold z along the optical axis in metres, as 7-Scenes and TUM do.
#![deny(missing_docs)]

pub mod dataset;
mod error;
pub mod import;
pub mod preview;
pub mod procedural;
pub mod render;
pub mod trajectory;
pub mod variants;
pub mod world;

pub use error::{Result, SynthError};
pub use world::{Material, Pattern, Place, PlaceKind, Triangle, Variant, World};
