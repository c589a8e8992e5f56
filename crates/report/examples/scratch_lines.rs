//! scratch
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let img = image::open("/tmp/rep3k/errors_over_time.png")?.to_rgb8();
    for x in 78..88 {
        let mut counts = std::collections::BTreeMap::new();
        for y in 80..320 { *counts.entry(img.get_pixel(x, y).0).or_insert(0) += 1; }
        println!("{x}: {:?}", counts.iter().filter(|(_, c)| **c > 5).collect::<Vec<_>>());
    }
    Ok(())
}
