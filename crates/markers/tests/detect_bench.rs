//! Detection speed on the real photos (not a pass/fail test; no timed assertions).
//! `cargo test --release -p markers --test detect_bench -- --ignored --nocapture`
//! Compare with `~/.cache/indoorloc-peers/bin/python ../shared/tools/peers/aruco.py IMAGE
//! --dict DICT_6X6_250 --repeat 30` in the same run.

use markers::{DetectParams, Dictionary, detect, load_gray};
use std::path::PathBuf;
use std::time::Instant;

const DATA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/aruco_real"
);

fn median_ms(mut f: impl FnMut(), repeat: usize) -> f64 {
    f();
    let mut ms: Vec<f64> = (0..repeat)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    ms[ms.len() / 2]
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn detection_speed() {
    let dict = Dictionary::predefined("6x6_250").unwrap();
    let params = DetectParams::default();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    // The photos `indoorloc bench markers` times.
    for name in [
        "singlemarkersoriginal.jpg",
        "choriginal.jpg",
        "chocclusion_original.jpg",
        "img_00.jpg",
        "img_02.jpg",
        "img_03.jpg",
    ] {
        let gray = load_gray(&PathBuf::from(DATA).join(name)).unwrap();
        let single = one.install(|| median_ms(|| drop(detect(&gray, &dict, &params)), 30));
        let all = median_ms(|| drop(detect(&gray, &dict, &params)), 30);
        println!(
            "{name:<28} 1 thread {single:6.2} ms   all {} threads {all:6.2} ms",
            rayon::current_num_threads()
        );
    }
}
