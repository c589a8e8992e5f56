//! Writes an `eval` report for a synthetic walk and prints how long it took.
//!
//! ```text
//! cargo run --release -p report --example eval_report -- [FRAMES] [OUT_DIR]
//! ```
//! Defaults: 100 000 frames, `target/report-example`.

use geom::Pose;
use geom::metrics::PoseEvaluation;
use report::{Table, pose_eval_report, pose_summary_table};
use std::path::PathBuf;
use std::time::Instant;

/// A small deterministic generator, so the example needs no `rand`.
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args
        .next()
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(100_000);
    let out = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/report-example"));

    // a walk around a rectangular corridor loop (40 m × 16 m), 1.2 m/s at 30 fps
    let (w, h) = (40.0, 16.0);
    let perimeter = 2.0 * (w + h);
    let mut rng = Lcg(7);
    let cuts: Vec<usize> = (1..12).map(|k| k * frames / 12).collect();
    let mut gt = Vec::with_capacity(frames);
    let mut est = Vec::with_capacity(frames);
    let mut drift = [0.0f64; 2];
    for i in 0..frames {
        let s = (i as f64 * 0.04) % perimeter;
        let (x, y, yaw) = if s < w {
            (s, 0.0, 0.0)
        } else if s < w + h {
            (w, s - w, 90f64.to_radians())
        } else if s < 2.0 * w + h {
            (w - (s - w - h), h, 180f64.to_radians())
        } else {
            (0.0, h - (s - 2.0 * w - h), -90f64.to_radians())
        };
        gt.push(Pose::from_euler_ypr(yaw, 0.0, 0.0, [x, y, 1.6])?);
        // slow drift that resets at each cut, plus per-frame noise and rare gross failures
        if cuts.binary_search(&i).is_ok() {
            drift = [1.5 * rng.normal(), 1.5 * rng.normal()];
        }
        drift = [0.995 * drift[0], 0.995 * drift[1]];
        let gross = if rng.uniform() < 0.002 { 6.0 } else { 0.0 };
        let ex = drift[0] + 0.12 * rng.normal() + gross * rng.normal();
        let ey = drift[1] + 0.12 * rng.normal() + gross * rng.normal();
        let eyaw = (1.5 + 3.0 * drift[0].abs()) * rng.normal();
        est.push(Pose::from_euler_ypr(
            yaw + eyaw.to_radians(),
            0.0,
            0.0,
            [x + ex, y + ey, 1.6 + 0.05 * rng.normal()],
        )?);
    }

    let t0 = Instant::now();
    let ev = PoseEvaluation::of(&gt, &est)?;
    let t_eval = t0.elapsed();
    let xy = |p: &[Pose]| -> Vec<[f64; 2]> {
        p.iter()
            .map(|p| [p.translation.x, p.translation.y])
            .collect()
    };
    let (gt_xy, est_xy) = (xy(&gt), xy(&est));
    let mut inputs = Table::new("Inputs", ["input", "value"]);
    inputs.push_row(["ground truth", "synthetic corridor loop"]);
    inputs.push_row(["estimate", "drift + noise + 0.2 % gross errors"]);
    let t1 = Instant::now();
    let path = pose_eval_report(
        &out,
        "Evaluation: synthetic corridor loop",
        &ev,
        &gt_xy,
        &est_xy,
        Some(&cuts),
        &[inputs],
    )?;
    let t_report = t1.elapsed();
    print!("{}", pose_summary_table(&ev));
    println!(
        "{frames} frames: metrics {:.1} ms, report {:.1} ms, total {:.1} ms -> {}",
        t_eval.as_secs_f64() * 1e3,
        t_report.as_secs_f64() * 1e3,
        (t_eval + t_report).as_secs_f64() * 1e3,
        path.display()
    );
    Ok(())
}
