//! Localizes every image of a folder (or a video, or a posed dataset) with a trained model:
//! the frames go through `track`'s recorded-input loop with the network as its estimator, one
//! line per frame with the position and its uncertainty.
//!
//! ```text
//! cargo run --release -p lab --example localize_folder -- MODEL INPUT
//! ```

use std::error::Error;
use std::path::PathBuf;
use track::{NetworkEstimator, Recorded, Split, Stages, TrackError};

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: localize_folder MODEL INPUT";
    let model = PathBuf::from(args.next().ok_or(usage)?);
    let input = PathBuf::from(args.next().ok_or(usage)?);
    // 16 Monte-Carlo-dropout passes give the uncertainty; 0 would be one plain pass.
    let network = NetworkEstimator::load(&model, 16)?;
    let stages = Stages::new(vec![Box::new(network)], None, false);
    let frames = track::frames(&input, Split::All, None)?;
    let summary = Recorded::new(stages).run(frames, |out| {
        if let Some(e) = out.processed.last() {
            let [x, y, z] = e.pose.position();
            println!(
                "{:<16} {x:8.3} {y:8.3} {z:8.3}  ± {:.3} m  ({:.0} ms)",
                out.name,
                e.sigma_pos_m(),
                out.latency_ms
            );
        }
        Ok::<(), TrackError>(())
    })?;
    println!(
        "{} frames localized, {} unreadable",
        summary.done,
        summary.unreadable.len()
    );
    Ok(())
}
