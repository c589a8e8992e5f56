//! Pose regression on real posed photos: `../shared/data/fox_posed` (instant-ngp's fox, NeRF
//! `transforms.json`, read in place), every fifth photo held out. The network must beat always
//! answering the mean training position by a factor of two on the held-out photos.

use std::path::{Path, PathBuf};

use learn::HOLDOUT_EVERY;
use learn::{Arch, Schedule, TrainConfig, train};

fn fox() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/fox_posed")
}

/// Median distance from the held-out camera centres to the mean training centre.
fn mean_position_baseline(dir: &Path) -> f64 {
    let (traj, images) = data::nerf::read_with_images(dir).unwrap();
    let centres: Vec<_> = traj
        .frames
        .iter()
        .zip(&images)
        .filter(|(_, image)| image.is_file())
        .map(|(f, _)| f.pose.translation)
        .collect();
    let held_out = |i: usize| i % HOLDOUT_EVERY == HOLDOUT_EVERY - 1;
    let train: Vec<_> = (0..centres.len()).filter(|&i| !held_out(i)).collect();
    let mean = train
        .iter()
        .fold(nalgebra::Vector3::zeros(), |acc, &i| acc + centres[i])
        / train.len() as f64;
    let errors: Vec<f64> = (0..centres.len())
        .filter(|&i| held_out(i))
        .map(|i| (centres[i] - mean).norm())
        .collect();
    geom::metrics::Stats::of(&errors).unwrap().median
}

#[test]
fn fox_photos_beat_the_mean_position_twice_over() {
    let dir = fox();
    assert!(
        dir.join("transforms.json").is_file(),
        "{} is missing: the real-photo test needs ../shared/data beside the checkout",
        dir.display()
    );
    let out = tempfile::tempdir().unwrap();
    let mut cfg = TrainConfig::new(&dir, out.path());
    cfg.arch = Arch::Small;
    cfg.view = Some("resize=36x64,norm=pm1".into());
    cfg.epochs = 20;
    cfg.batch_size = 8;
    cfg.lr = 2e-3;
    cfg.schedule = Schedule::Constant;
    cfg.patience = None;
    cfg.seed = 1;
    let summary = train(&cfg, &mut |_| {}).unwrap();
    assert_eq!((summary.train_frames, summary.val_frames), (40, 10));
    let baseline = mean_position_baseline(&dir);
    // The last epoch's weights, not the best ones: the held-out photos choose nothing.
    let last = summary.history.last().unwrap().val_median_pos_m;
    println!(
        "fox held-out median {last:.3} (units of the scene), mean-position baseline {baseline:.3}"
    );
    assert!(
        last <= 0.5 * baseline,
        "held-out median {last:.3} vs mean-position baseline {baseline:.3}"
    );
}
