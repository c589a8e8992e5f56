//! Images without a board are rejected, fast.

use calib::find_chessboard;
use image::GrayImage;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn timed(name: &str, img: &GrayImage) {
    let t = Instant::now();
    let r = find_chessboard(img, 9, 6);
    println!("{name}: {:.2} ms", t.elapsed().as_secs_f64() * 1e3);
    assert!(r.is_none(), "{name}: found a board");
}

#[test]
fn no_board_no_corners() {
    timed(
        "blank",
        &GrayImage::from_pixel(640, 480, image::Luma([128])),
    );
    timed("black", &GrayImage::new(640, 480));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let noise = GrayImage::from_fn(640, 480, |_, _| image::Luma([rng.random::<u8>()]));
    timed("noise", &noise);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let blocks = GrayImage::from_fn(640, 480, |x, y| {
        let _ = (x, y);
        image::Luma([if rng.random_bool(0.5) { 0 } else { 255 }])
    });
    timed("binary noise", &blocks);
    for (w, h) in [(0, 0), (1, 1), (15, 15), (16, 16), (40, 3), (3, 40)] {
        timed(&format!("{w}x{h}"), &GrayImage::new(w, h));
    }
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/aruco_real/singlemarkersoriginal.jpg"
    );
    let img = image::open(path).expect("image").to_luma8();
    timed("singlemarkersoriginal.jpg", &img);
}
