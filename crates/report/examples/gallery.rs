//! Writes one of each figure, with several overlaid methods, as PNG and SVG for a look.
//!
//! ```text
//! cargo run --release -p report --example gallery -- [OUT_DIR]
//! ```
//! Default folder: `target/report-gallery`.

use report::{ErrorCdf, ErrorOverTime, Figure, Series, TopDown, Track};
use std::path::PathBuf;

/// Deterministic pseudo-random numbers in [0, 1), so the example needs no `rand`.
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    ((*state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/report-gallery"));
    std::fs::create_dir_all(&out)?;
    let mut s = 11u64;
    let frames = 1800;
    // three methods with different error scales, the first one better after cuts
    let methods = [
        ("cuts handled", 0.25, 1.2),
        ("cuts ignored", 0.45, 2.0),
        ("PoseNet", 0.9, 4.0),
    ];
    let cuts = [450usize, 900, 1350];
    let mut pos = Vec::new();
    let mut rot = Vec::new();
    for (k, (name, m, d)) in methods.iter().enumerate() {
        let mut p = Vec::with_capacity(frames);
        let mut r = Vec::with_capacity(frames);
        for i in 0..frames {
            let since = cuts.iter().rev().find(|&&c| c <= i).map_or(i, |c| i - c);
            let bump = if k == 0 {
                0.0
            } else {
                2.0 * (-(since as f64) / 80.0).exp()
            };
            let e = -(uniform(&mut s)).ln();
            p.push(m * e + bump);
            r.push(d * -(uniform(&mut s)).ln() + 3.0 * bump);
        }
        pos.push(Series::new(*name, p));
        rot.push(Series::new(*name, r));
    }
    let gt: Vec<[f64; 2]> = (0..frames)
        .map(|i| {
            let t = i as f64 / frames as f64 * std::f64::consts::TAU;
            [12.0 * t.cos() + 3.0 * (3.0 * t).cos(), 7.0 * t.sin()]
        })
        .collect();
    let estimates: Vec<Track> = pos
        .iter()
        .take(2)
        .map(|series| {
            let pts: Vec<[f64; 2]> = gt
                .iter()
                .zip(&series.values)
                .map(|(g, e)| {
                    let a = uniform(&mut s) * std::f64::consts::TAU;
                    [g[0] + e * a.cos(), g[1] + e * a.sin()]
                })
                .collect();
            Track::new(series.name.clone(), pts)
        })
        .collect();
    let figures: [(&str, Figure); 3] = [
        (
            "cdf",
            ErrorCdf {
                title: "Position and rotation errors, three methods".into(),
                position_m: pos.clone(),
                rotation_deg: rot.clone(),
                thresholds_m: vec![0.25, 0.5],
                thresholds_deg: vec![2.0, 5.0],
            }
            .into(),
        ),
        (
            "errors_over_time",
            ErrorOverTime {
                title: "Errors over time".into(),
                position_m: pos[..2].to_vec(),
                rotation_deg: rot[..2].to_vec(),
                markers: cuts.to_vec(),
                marker_label: "scene cut".into(),
            }
            .into(),
        ),
        (
            "trajectory",
            TopDown {
                title: "Walk around the atrium".into(),
                ground_truth: gt,
                estimates,
                links: false,
            }
            .into(),
        ),
    ];
    for (stem, fig) in &figures {
        let (_, png, svg) = fig.save_both(&out, stem)?;
        println!("{}  {}", png.display(), svg.display());
    }
    Ok(())
}
