//! Image views and augmentation for indoorloc.
#![deny(missing_docs)]

pub mod augment;
mod error;
pub mod view;

pub use error::{ImgprocError, Result};
