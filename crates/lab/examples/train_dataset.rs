//! Trains a pose-regression network on a posed dataset folder (native, or any layout
//! `indoorloc train` reads), printing each epoch's validation error, and leaves a checkpoint
//! folder `localize` loads.
//!
//! ```text
//! cargo run --release -p lab --example train_dataset -- DATASET OUT [EPOCHS]
//! ```

use learn::{Progress, TrainConfig};
use std::error::Error;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: train_dataset DATASET OUT [EPOCHS]";
    let data = PathBuf::from(args.next().ok_or(usage)?);
    let out = PathBuf::from(args.next().ok_or(usage)?);
    let mut cfg = TrainConfig::new(&data, &out);
    if let Some(epochs) = args.next() {
        cfg.epochs = epochs.parse()?;
    }
    let summary = learn::train(&cfg, &mut |event| {
        if let Progress::Epoch(m) = event {
            println!(
                "epoch {:>3}: validation median {:.3} m, {:.2}°",
                m.epoch, m.val_median_pos_m, m.val_median_rot_deg
            );
        }
    })?;
    println!(
        "kept epoch {} of {} ({:.3} m, {:.2}°) in {}",
        summary.best_epoch,
        summary.epochs,
        summary.val_median_pos_m,
        summary.val_median_rot_deg,
        summary.out.display()
    );
    Ok(())
}
