//! Tests of texture baking: sizes, determinism, variety between seeds, the tint, image
//! resampling and bad inputs; and two ignored ones for a person (bake times, a contact sheet of
//! every pattern).

use super::*;
use std::sync::Arc;
use std::time::Instant;

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn mat(pattern: Pattern, color: [f32; 3], seed: u64) -> Material {
    Material {
        name: "test".into(),
        color,
        pattern,
        seed,
        emissive: 0.0,
        unlit: false,
    }
}

fn test_image() -> image::RgbImage {
    image::RgbImage::from_fn(100, 60, |x, y| {
        image::Rgb([(x * 2) as u8, (y * 4) as u8, ((x + y) % 256) as u8])
    })
}

/// Every pattern with a typical colour: (label, material).
fn all(seed: u64) -> Vec<(&'static str, Material)> {
    vec![
        ("plain", mat(Pattern::Plain, [0.85, 0.84, 0.8], seed)),
        (
            "ceiling tiles",
            mat(Pattern::Tiles { size: 0.6 }, [0.9, 0.9, 0.88], seed),
        ),
        (
            "floor tiles",
            mat(Pattern::Tiles { size: 0.3 }, [0.62, 0.58, 0.52], seed),
        ),
        ("carpet", mat(Pattern::Carpet, [0.3, 0.33, 0.4], seed)),
        ("wood", mat(Pattern::Wood, [0.62, 0.44, 0.28], seed)),
        ("concrete", mat(Pattern::Concrete, [0.6, 0.6, 0.58], seed)),
        ("brick", mat(Pattern::Brick, [0.6, 0.3, 0.22], seed)),
        ("poster", mat(Pattern::Poster, [0.95, 0.93, 0.85], seed)),
        ("poster dark", mat(Pattern::Poster, [0.12, 0.2, 0.4], seed)),
        (
            "notice board",
            mat(Pattern::NoticeBoard, [0.62, 0.45, 0.3], seed),
        ),
        ("exit sign", mat(Pattern::Sign, [0.1, 0.6, 0.3], seed)),
        ("blue sign", mat(Pattern::Sign, [0.15, 0.3, 0.6], seed)),
        ("white sign", mat(Pattern::Sign, [0.93, 0.93, 0.9], seed)),
        ("fire sign", mat(Pattern::Sign, [0.8, 0.12, 0.1], seed)),
        ("window", mat(Pattern::Window, [0.75, 0.85, 0.95], seed)),
        (
            "light panel",
            mat(Pattern::LightPanel, [0.97, 0.97, 0.95], seed),
        ),
        ("vent", mat(Pattern::Vent, [0.88, 0.88, 0.86], seed)),
        ("metal", mat(Pattern::Metal, [0.7, 0.71, 0.73], seed)),
        ("fabric", mat(Pattern::Fabric, [0.25, 0.3, 0.45], seed)),
        (
            "image",
            mat(Pattern::Image(Arc::new(test_image())), [1.0; 3], seed),
        ),
    ]
}

fn diff(a: &Texture, b: &Texture) -> f64 {
    let s: f64 = a
        .texels
        .iter()
        .zip(&b.texels)
        .map(|(p, q)| {
            p.iter()
                .zip(q)
                .map(|(&x, &y)| f64::from((i16::from(x) - i16::from(y)).abs()))
                .sum::<f64>()
        })
        .sum();
    s / (a.texels.len().max(1) * 3) as f64
}

#[test]
fn texture_sizes_are_powers_of_two() -> TestResult {
    for (name, m) in all(7) {
        let t = bake(&m);
        if !(t.width.is_power_of_two() && t.height.is_power_of_two()) {
            return Err(format!("{name}: {}x{}", t.width, t.height).into());
        }
        if t.texels.len() != (t.width * t.height) as usize {
            return Err(format!("{name}: {} texels", t.texels.len()).into());
        }
        if !(t.repeat_m[0] > 0.0 && t.repeat_m[1] > 0.0) {
            return Err(format!("{name}: repeat {:?}", t.repeat_m).into());
        }
    }
    Ok(())
}

#[test]
fn texture_bake_is_deterministic() -> TestResult {
    for ((name, a), (_, b)) in all(42).into_iter().zip(all(42)) {
        if bake(&a) != bake(&b) {
            return Err(format!("{name}: two bakes differ").into());
        }
    }
    Ok(())
}

#[test]
fn texture_posters_differ_between_seeds() -> TestResult {
    let bakes: Vec<Texture> = (0..12)
        .map(|s| bake(&mat(Pattern::Poster, [0.95, 0.93, 0.85], s)))
        .collect();
    let mut min = f64::MAX;
    for (i, a) in bakes.iter().enumerate() {
        for b in &bakes[i + 1..] {
            min = min.min(diff(a, b));
        }
    }
    println!("smallest mean absolute difference between posters: {min:.1}");
    if min < 20.0 {
        return Err(format!("posters too alike: {min:.1}").into());
    }
    for p in [
        Pattern::NoticeBoard,
        Pattern::Sign,
        Pattern::Window,
        Pattern::Carpet,
    ] {
        let d = diff(
            &bake(&mat(p.clone(), [0.6, 0.45, 0.3], 1)),
            &bake(&mat(p.clone(), [0.6, 0.45, 0.3], 2)),
        );
        println!("{p:?}: seeds 1 and 2 differ by {d:.1}");
        if d < 1.0 {
            return Err(format!("{p:?}: seeds give the same texture").into());
        }
    }
    Ok(())
}

#[test]
fn texture_tint_moves_the_mean_colour() -> TestResult {
    let grey = [0.4, 0.4, 0.4];
    let red = [0.7, 0.25, 0.2];
    for (name, a) in all(3) {
        if matches!(a.pattern, Pattern::Image(_)) {
            continue;
        }
        let g = bake(&mat(a.pattern.clone(), grey, 3)).mean_rgb();
        let r = bake(&mat(a.pattern.clone(), red, 3)).mean_rgb();
        let (dr, db) = (r[0] - g[0], r[2] - g[2]);
        // Windows show mostly sky: only their frame takes the tint.
        if dr < 0.02 || dr < db + 0.03 {
            return Err(format!("{name}: grey {g:?} -> red {r:?}").into());
        }
        let light = bake(&mat(a.pattern.clone(), [0.5; 3], 3)).mean_rgb();
        let lighter = bake(&mat(a.pattern.clone(), [0.6; 3], 3)).mean_rgb();
        if lighter.iter().sum::<f32>() <= light.iter().sum::<f32>() {
            return Err(format!("{name}: lighter tint not lighter").into());
        }
    }
    Ok(())
}

#[test]
fn texture_image_is_resampled_to_powers_of_two() -> TestResult {
    let t = bake(&mat(Pattern::Image(Arc::new(test_image())), [1.0; 3], 0));
    assert_eq!((t.width, t.height), (128, 64));
    assert_eq!(t.repeat_m, [1.0, 1.0]);
    // A horizontal ramp stays a ramp: red grows along each row.
    let row: Vec<u8> = (0..t.width).map(|x| t.texel(i64::from(x), 10)[0]).collect();
    assert!(row.windows(2).all(|w| w[1] + 2 >= w[0]), "{row:?}");
    assert!(row[120] > row[8] + 100);
    let big = Arc::new(image::RgbImage::new(3000, 10));
    let t = bake(&mat(Pattern::Image(big.clone()), [1.0; 3], 0));
    assert_eq!((t.width, t.height), (MAX_IMAGE_SIDE, 8));
    // A scan's atlas (unlit) keeps more of its texels.
    let atlas = Material {
        unlit: true,
        ..mat(Pattern::Image(big), [1.0; 3], 0)
    };
    let t = bake(&atlas);
    assert_eq!((t.width, t.height), (MAX_ATLAS_SIDE, 8));
    let exact = image::RgbImage::from_pixel(32, 16, image::Rgb([1, 2, 3]));
    let t = bake(&mat(Pattern::Image(Arc::new(exact)), [1.0; 3], 0));
    assert_eq!((t.width, t.height), (32, 16));
    assert!(t.texels.iter().all(|&p| p == [1, 2, 3]));
    let empty = image::RgbImage::new(0, 0);
    let t = bake(&mat(Pattern::Image(Arc::new(empty)), [1.0, 0.0, 0.0], 0));
    assert_eq!(
        (t.width, t.height, t.texels.clone()),
        (1, 1, vec![[255, 0, 0]])
    );
    Ok(())
}

#[test]
fn texture_tiles_tolerate_bad_sizes() {
    for size in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e9] {
        let t = bake(&mat(Pattern::Tiles { size }, [0.5; 3], 0));
        assert!(t.repeat_m[0].is_finite() && t.repeat_m[0] > 0.0);
    }
    let t = bake(&mat(Pattern::Plain, [f32::NAN, 2.0, -1.0], 0));
    assert!(!t.texels.is_empty());
}

/// Times for a person to read; speed goals are checked by `indoorloc bench render`.
#[test]
#[ignore = "timing printout, checks nothing; run with --ignored"]
fn texture_bake_times() {
    for (name, m) in all(5) {
        let mut best = f64::MAX;
        for _ in 0..5 {
            let t0 = Instant::now();
            let t = bake(&m);
            best = best.min(t0.elapsed().as_secs_f64());
            std::hint::black_box(t);
        }
        let t = bake(&m);
        println!(
            "bake {name:14} {:4}x{:<4} {:7.3} ms",
            t.width,
            t.height,
            best * 1e3
        );
    }
}

/// Writes a contact sheet of every pattern, two seeds each, to /tmp/textures.png: each cell
/// shows the texture as seen on the wall (v up), repeating patterns 2 × 2 times.
#[test]
#[ignore = "a picture for a person to look at, checks nothing; run with --ignored"]
fn texture_contact_sheet() -> TestResult {
    let cell = 180u32;
    let pad = 6u32;
    let cols = 8u32;
    let mut items = Vec::new();
    for ((name, a), (_, b)) in all(1).into_iter().zip(all(2)) {
        items.push((name, a));
        items.push((name, b));
    }
    let rows = (items.len() as u32).div_ceil(cols);
    let mut sheet = image::RgbImage::from_pixel(
        cols * (cell + pad) + pad,
        rows * (cell + pad) + pad,
        image::Rgb([40, 40, 40]),
    );
    for (i, (_, m)) in items.iter().enumerate() {
        let t = bake(m);
        let object = matches!(
            m.pattern,
            Pattern::Poster
                | Pattern::NoticeBoard
                | Pattern::Sign
                | Pattern::Window
                | Pattern::LightPanel
                | Pattern::Vent
                | Pattern::Image(_)
        );
        let reps = if object { 1.0 } else { 2.0 };
        let (aw, ah) = (t.repeat_m[0] * reps, t.repeat_m[1] * reps);
        let k = cell as f32 / aw.max(ah);
        let (cw, ch) = ((aw * k) as u32, (ah * k) as u32);
        let (ox, oy) = (
            pad + (i as u32 % cols) * (cell + pad) + (cell - cw) / 2,
            pad + (i as u32 / cols) * (cell + pad) + (cell - ch) / 2,
        );
        for y in 0..ch {
            for x in 0..cw {
                let u = x as f32 / k;
                // Image rows run down, procedural rows up the wall.
                let v = if matches!(m.pattern, Pattern::Image(_)) {
                    y as f32 / k
                } else {
                    (ch - 1 - y) as f32 / k
                };
                let p = t.sample_nearest([u, v]);
                sheet.put_pixel(ox + x, oy + y, image::Rgb(p));
            }
        }
    }
    sheet.save("/tmp/textures.png")?;
    println!(
        "contact sheet: /tmp/textures.png; order: {:?}",
        all(0).iter().map(|(n, _)| *n).collect::<Vec<_>>()
    );
    Ok(())
}
