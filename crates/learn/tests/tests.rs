//! Integration tests of `learn`, one module per theme, in one test binary: each binary links
//! burn, and one instead of five saves CI their link time and disk.

mod common;
mod place;
mod real_depth;
mod real_photos;
mod sequence;
mod shape_bias;
mod speed;
mod train;
mod uncertainty;
