//! scratch
use plotters::prelude::*;
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n = 100_000usize;
    let mut s = 7u64;
    let mut r = || { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((s >> 11) as f64) / (1u64 << 53) as f64 };
    let v: Vec<f64> = (0..n).map(|_| { let u = r(); if u < 0.002 { 15.0 * r() } else { 0.3 * r() } }).collect();
    // envelope
    let b = 1200;
    let mut pts = vec![];
    for k in 0..b { let (lo, hi) = (k*n/b, (k+1)*n/b);
        let mut mn=(lo, v[lo]); let mut mx=(lo, v[lo]);
        for i in lo..hi { if v[i]<mn.1 {mn=(i,v[i]);} if v[i]>mx.1 {mx=(i,v[i]);} }
        let (a,z) = if mn.0<=mx.0 {(mn,mx)} else {(mx,mn)};
        pts.push((a.0 as f64, a.1)); if z.0!=a.0 { pts.push((z.0 as f64, z.1)); } }
    for (name, width) in [("/tmp/l1.png", 1u32), ("/tmp/l2.png", 2)] {
        let root = BitMapBackend::new(name, (1200, 400)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root).margin(40).x_label_area_size(30).y_label_area_size(30)
            .build_cartesian_2d(0.0..n as f64, 0.0..16.0)?;
        chart.draw_series(LineSeries::new(pts.iter().copied(), RGBColor(31,119,180).stroke_width(width)))?;
        root.present()?;
    }
    Ok(())
}
