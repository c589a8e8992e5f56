//! Shape-biased training's claim, guarded: under paint the network never saw, its error grows
//! less than the plain network's, on a walk whose pose is in the shapes and not in the paint.

use crate::common::{self, Palette, TRAINING_PAINT};

use geom::metrics::{Stats, position_error};
use learn::{Localizer, train};

/// The held-out paint: a dark green bar on a light yellow wall (the bar's contrast reversed).
const HELD_OUT_PAINT: Palette = [[40.0, 120.0, 50.0], [220.0, 210.0, 90.0]];

/// Median position error of `loc` on 60 frames along the walk, between the training frames.
fn median_error(loc: &Localizer, paint: Palette) -> f64 {
    let errors: Vec<f64> = (0..60)
        .map(|i| {
            let (img, truth) = common::bar_frame((f64::from(i) + 0.5) / 60.0, paint);
            let view = loc.view(&image::DynamicImage::ImageRgb8(img)).unwrap();
            position_error(&truth, &loc.predict_view(&view, 0).unwrap().pose)
        })
        .collect();
    Stats::of(&errors).unwrap().median
}

#[test]
fn shape_bias_grows_less_than_the_plain_network_under_new_paint() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    common::make_bar_walk(&data, 60);
    let growth = |shape_bias: bool| {
        let model = tmp.path().join(format!("model-{shape_bias}"));
        let mut cfg = common::tiny_config(&data, &model, 5);
        cfg.epochs = 8;
        cfg.shape_bias = shape_bias;
        train(&cfg, &mut |_| {}).unwrap();
        let loc = Localizer::load(&model).unwrap();
        let (trained, held_out) = (
            median_error(&loc, TRAINING_PAINT),
            median_error(&loc, HELD_OUT_PAINT),
        );
        eprintln!(
            "shape bias {shape_bias}: {trained:.3} m in its paint, {held_out:.3} m in new paint"
        );
        held_out / trained
    };
    let (plain, shape) = (growth(false), growth(true));
    eprintln!("growth under new paint: plain {plain:.2}x, shape-biased {shape:.2}x");
    // measured (growth shape-biased / plain): 0.75, 0.26, 0.34, 0.74 with seeds 5-8, 0.56 with
    // seed 5 at 12 epochs (AMD EPYC, 2026-12-06); held out, the shape-biased model was
    // 0.38-0.71x the plain one's error. Both trained plain: 1.0.
    assert!(
        shape < 0.85 * plain,
        "shape-biased {shape:.2}x against plain {plain:.2}x"
    );
}
