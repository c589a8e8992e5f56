//! Renders walks through the built-in building into a native posed dataset (colour images,
//! depth, poses, splits) that `train` and `localize` read.
//!
//! ```text
//! cargo run --release -p lab --example render_walk -- OUT [FRAMES]
//! ```

use std::error::Error;
use std::path::PathBuf;
use synth::dataset::{self, SynthConfig};

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().ok_or("usage: render_walk OUT [FRAMES]")?);
    let frames: usize = args.next().map_or(Ok(300), |f| f.parse())?;
    let cfg = SynthConfig {
        frames,
        // Three walks: the dataset's own split puts one aside for validation and one for test.
        sequences: 3,
        width: 160,
        height: 120,
        ..SynthConfig::default()
    };
    let summary = dataset::run(&cfg, &out, &|_done| {})?;
    println!(
        "{} frames of the default building in {} ({:.1} s rendering)",
        summary.frames,
        out.display(),
        summary.render_seconds
    );
    Ok(())
}
