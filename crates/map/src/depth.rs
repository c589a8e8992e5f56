//! Depth images of posed datasets, now in [`data::depth`] (the scan fusion reads them too).

pub use data::depth::{DepthImage, DepthModel, read_depth};
