//! Speed of one training step of the small network, batch 32, 1x120x160, as `torch_apr.py
//! --arch small` times it, and of one-image inference. Run with
//! `cargo test --release -p learn --test tests speed -- --ignored --nocapture`; `indoorloc bench
//! train|infer` gives the same figures beside PyTorch's.

use learn::Arch;
use learn::bench::{infer_ms, train_step_ms};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
#[ignore = "timing; run in release"]
fn small_net_training_step_and_inference() {
    let step = median(train_step_ms(Arch::Small, [1, 120, 160], 32, 3, 10).unwrap());
    println!(
        "small net train step, batch 32, 1x120x160: median {step:.1} ms ({} threads)",
        rayon::current_num_threads()
    );
    let one = median(infer_ms(Arch::Small, [1, 120, 160], 3, 20).unwrap());
    println!("small net inference, one 1x120x160 image: median {one:.2} ms");
}
