//! Figures drawn through [`Figure`], kind by kind: the cumulative distributions, errors over
//! time and top-down views here, the error maps, scatter plots and reliability diagrams in their
//! submodules (with the tests of those kinds' preparation, which share their fixtures). They sit
//! under `figure`, above every kind's module, so that no kind's module refers up to [`Figure`].

use super::*;

type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn noisy(n: usize, scale: f64) -> Vec<f64> {
    // deterministic, skewed "errors": mostly small, a long tail
    (0..n)
        .map(|i| {
            let u = ((i as f64 * 0.618_034) % 1.0).max(1e-6);
            scale * (-u.ln()) * (1.0 + 0.3 * (i as f64 * 0.01).sin())
        })
        .collect()
}

fn figures() -> Vec<Figure> {
    let a = noisy(3000, 0.3);
    let b: Vec<f64> = noisy(3000, 0.5).iter().map(|v| v * 1.4).collect();
    let xy: Vec<[f64; 2]> = (0..800)
        .map(|i| {
            let t = i as f64 * 0.01;
            [20.0 * t.cos(), 8.0 * (2.0 * t).sin()]
        })
        .collect();
    let est: Vec<[f64; 2]> = xy.iter().map(|p| [p[0] + 0.4, p[1] - 0.3]).collect();
    vec![
        error_cdf(
            "CDF",
            &[
                Series::new("cuts handled", a.clone()),
                Series::new("cuts ignored", b.clone()),
            ],
            &[Series::new("cuts handled", b.clone())],
        ),
        error_over_time(
            "Over time",
            &[Series::new("net", a)],
            &[Series::new("net", b)],
            Some(&[10, 2000]),
        ),
        trajectory_top_down("Top", &xy, &[Track::new("net", est)], true),
    ]
}

#[test]
fn png_and_svg_files_are_written_at_the_figure_size() -> TestResult {
    let dir = tempfile::tempdir()?;
    for (i, fig) in figures().iter().enumerate() {
        let png = dir.path().join(format!("f{i}.png"));
        let svg = dir.path().join(format!("f{i}.svg"));
        fig.save_png(&png)?;
        fig.save_svg(&svg)?;
        let img = image::open(&png)?;
        assert_eq!((img.width(), img.height()), fig.size());
        let text = std::fs::read_to_string(&svg)?;
        assert!(text.starts_with("<svg") && text.contains(SVG_FONT_STACK));
    }
    Ok(())
}

#[test]
fn svg_names_every_series() -> TestResult {
    let figs = figures();
    let cdf = figs[0].to_svg()?;
    assert!(cdf.contains("cuts handled") && cdf.contains("cuts ignored"));
    assert!(cdf.contains("position error (m)") && cdf.contains("rotation error (deg)"));
    let time = figs[1].to_svg()?;
    assert!(time.contains("net") && time.contains("scene cut"));
    let top = figs[2].to_svg()?;
    assert!(top.contains("ground truth") && top.contains("net") && top.contains("x (m)"));
    Ok(())
}

#[test]
fn empty_input_is_an_error() {
    let empty = [Series::new("e", Vec::new())];
    let bad = [
        error_cdf("t", &[], &[]),
        error_cdf("t", &empty, &[]),
        error_over_time("t", &[], &[], None),
        error_over_time("t", &empty, &empty, None),
        trajectory_top_down("t", &[], &[], true),
    ];
    for fig in bad {
        assert_rejected(&fig);
    }
}

#[test]
fn nan_values_are_left_out_not_fatal() -> TestResult {
    let v = vec![0.1, f64::NAN, 0.3, f64::INFINITY, 0.2];
    let s = [Series::new("n", v)];
    let svg = error_cdf("t", &s, &s).to_svg()?;
    assert!(svg.contains("2 non-finite left out"));
    error_over_time("t", &s, &s, Some(&[1, 99])).to_png()?;
    let xy = [[0.0, 0.0], [f64::NAN, 1.0], [1.0, 1.0]];
    trajectory_top_down("t", &xy, &[Track::new("e", xy.to_vec())], true).to_png()?;
    let all_nan = [Series::new("n", vec![f64::NAN; 3])];
    assert!(error_cdf("t", &all_nan, &[]).to_png().is_err());
    Ok(())
}

#[test]
fn huge_values_are_an_error_not_a_hang() {
    let huge = [Series::new("h", vec![0.0, f64::MAX])];
    assert!(error_over_time("t", &huge, &[], None).to_png().is_err());
    let far = [[0.0, 0.0], [f64::MAX, -f64::MAX]];
    assert!(trajectory_top_down("t", &far, &[], false).to_png().is_err());
}

#[test]
fn single_values_and_zero_errors_draw() -> TestResult {
    let zero = [Series::new("z", vec![0.0])];
    error_cdf("t", &zero, &zero).to_png()?;
    error_over_time("t", &zero, &[], None).to_png()?;
    trajectory_top_down("t", &[[1.0, 1.0]], &[], false).to_png()?;
    Ok(())
}

/// Test helper: `fig` is refused as bad input in both output formats.
fn assert_rejected(fig: &Figure) {
    assert!(
        matches!(fig.to_png(), Err(ReportError::BadInput(_))),
        "{fig:?}"
    );
    assert!(
        matches!(fig.to_svg(), Err(ReportError::BadInput(_))),
        "{fig:?}"
    );
}

mod error_map {
    use crate::decimate::{MAX_TRACK_POINTS, quantile_range};
    use crate::errmap::{ErrorMap, prepare_error_map};
    use crate::error::ReportError;
    use crate::figure::{Figure, error_map};
    use crate::font::SVG_FONT_STACK;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    /// A loop walk with estimates off by a growing amount, and its errors.
    fn walk(n: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<f64>) {
        let gt: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * std::f64::consts::TAU;
                [12.0 * t.cos(), 5.0 * t.sin()]
            })
            .collect();
        let off: Vec<f64> = (0..n).map(|i| 0.05 + (i % 97) as f64 * 0.01).collect();
        let est = gt.iter().zip(&off).map(|(p, d)| [p[0] + d, p[1]]).collect();
        (gt, est, off)
    }

    fn full_map() -> ErrorMap {
        let (ground_truth, estimates, errors_m) = walk(500);
        ErrorMap {
            title: "Held-out walk".into(),
            ground_truth,
            estimates,
            errors_m,
            links: true,
            floor_plan: vec![[-14.0, -6.0, 0.0, 6.0], [0.0, -6.0, 14.0, 6.0]],
            color_max_m: None,
        }
    }

    #[test]
    fn png_and_svg_are_drawn_at_the_figure_size() -> TestResult {
        let fig = Figure::from(full_map());
        let dir = tempfile::tempdir()?;
        let (svg, png, _) = fig.save_both(dir.path(), "map")?;
        let img = image::open(&png)?;
        assert_eq!((img.width(), img.height()), fig.size());
        assert!(svg.starts_with("<svg") && svg.contains(SVG_FONT_STACK));
        assert!(svg.contains("Held-out walk") && svg.contains("ground truth"));
        // the colour bar and its scale
        assert!(svg.contains("position error (m)"));
        assert!(svg.contains("scale ends at the 95th percentile"));
        assert!(svg.contains("floor plan") && svg.contains("ground truth → estimate"));
        Ok(())
    }

    #[test]
    fn colour_scale_is_clipped_at_the_95th_percentile_or_as_asked() -> TestResult {
        let mut f = full_map();
        let plot = prepare_error_map(&f)?;
        let (p95, _) = quantile_range(f.errors_m.iter().copied(), 0.95, 1.0).unwrap_or_default();
        assert_eq!(plot.color_max, p95);
        // dots run from the smallest to the largest error, worst drawn last
        assert!(plot.dots.windows(2).all(|w| w[0].1 <= w[1].1));
        f.color_max_m = Some(10.0);
        let plot = prepare_error_map(&f)?;
        assert_eq!(plot.color_max, 10.0);
        assert!(!plot.dots_label.contains("scale ends"));
        f.color_max_m = Some(0.0);
        assert!(matches!(
            prepare_error_map(&f),
            Err(ReportError::BadInput(_))
        ));
        Ok(())
    }

    #[test]
    fn floor_plan_is_clipped_to_the_view_not_widening_it() -> TestResult {
        let mut f = full_map();
        let view = prepare_error_map(&f)?.bounds;
        f.floor_plan = vec![[-500.0, -500.0, 500.0, 500.0], [900.0, 900.0, 901.0, 901.0]];
        let plot = prepare_error_map(&f)?;
        assert_eq!(plot.bounds, view);
        assert_eq!(plot.rooms, vec![view]);
        assert!(plot.walls.is_empty());
        Ok(())
    }

    #[test]
    fn long_walks_are_decimated() -> TestResult {
        let (gt, est, err) = walk(100_000);
        let fig = error_map("long", &gt, &est, &err);
        let Figure::ErrorMap(f) = &fig else {
            return Err("not an error map".into());
        };
        let plot = prepare_error_map(f)?;
        assert!(plot.dots.len() <= MAX_TRACK_POINTS + 1);
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn non_finite_frames_are_left_out() -> TestResult {
        let (gt, mut est, mut err) = walk(50);
        est[3] = [f64::NAN, 0.0];
        err[7] = f64::INFINITY;
        let fig = error_map("t", &gt, &est, &err);
        assert!(fig.to_svg()?.contains("2 non-finite left out"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() {
        let (gt, est, err) = walk(10);
        let bad = [
            error_map("t", &[], &[], &[]),
            error_map("t", &gt, &est, &err[1..]),
            error_map("t", &gt[1..], &est, &err),
            error_map("t", &gt, &est, &[f64::NAN; 10]),
            error_map(
                "t",
                &[[0.0, 0.0], [f64::MAX, -f64::MAX]],
                &[[0.0; 2]; 2],
                &[1.0; 2],
            ),
        ];
        for fig in bad {
            super::assert_rejected(&fig);
        }
    }

    #[test]
    fn single_frames_and_zero_errors_draw() -> TestResult {
        error_map("t", &[[1.0, 1.0]], &[[1.0, 1.0]], &[0.0]).to_png()?;
        let (gt, _, _) = walk(20);
        error_map("t", &gt, &gt, &[0.0; 20]).to_svg()?;
        Ok(())
    }
}

mod scatter {
    use crate::decimate::MAX_SCATTER_POINTS;
    use crate::figure::{Figure, scatter};
    use crate::font::SVG_FONT_STACK;
    use crate::scatter::{Scatter, prepare_scatter};

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    /// Errors that grow with the predicted sigma, with deterministic scatter.
    fn sigma_vs_error(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let s = 0.1 + (i % 50) as f64 * 0.02;
                let u = (i as f64 * 0.618_034) % 1.0;
                [s, s * (0.5 + u)]
            })
            .collect()
    }

    #[test]
    fn png_and_svg_are_drawn_at_the_figure_size() -> TestResult {
        let fig = scatter(
            "Uncertainty",
            "predicted sigma (m)",
            "position error (m)",
            &sigma_vs_error(800),
        );
        let dir = tempfile::tempdir()?;
        let (svg, png, _) = fig.save_both(dir.path(), "scatter")?;
        let img = image::open(&png)?;
        assert_eq!((img.width(), img.height()), fig.size());
        assert!(svg.starts_with("<svg") && svg.contains(SVG_FONT_STACK));
        assert!(svg.contains("Uncertainty") && svg.contains("predicted sigma (m)"));
        assert!(svg.contains("position error (m)") && svg.contains("least squares: y = "));
        assert!(svg.contains("800 points, Pearson r = 0."));
        Ok(())
    }

    #[test]
    fn correlation_and_line_use_every_point() -> TestResult {
        let pts: Vec<[f64; 2]> = (0..20_000)
            .map(|i| [f64::from(i), 2.0 * f64::from(i) + 1.0])
            .collect();
        let fig = Scatter {
            points: pts,
            fit_line: true,
            ..Scatter::default()
        };
        let plot = prepare_scatter(&fig)?;
        assert!(plot.points.len() <= MAX_SCATTER_POINTS + 1);
        assert!(
            plot.points_label
                .starts_with("20000 points, Pearson r = 1.00, ")
        );
        assert_eq!(
            plot.fit_label.as_deref(),
            Some("least squares: y = 2 x + 1")
        );
        assert!(plot.fit_segment.is_some());
        let no_line = prepare_scatter(&Scatter {
            fit_line: false,
            ..fig
        })?;
        assert!(no_line.fit_label.is_none() && no_line.fit_segment.is_none());
        Ok(())
    }

    #[test]
    fn outliers_cut_the_axis_and_are_counted() -> TestResult {
        let mut pts = sigma_vs_error(1000);
        pts[10] = [0.5, 1000.0];
        let plot = prepare_scatter(&Scatter {
            points: pts,
            ..Scatter::default()
        })?;
        assert!(plot.y_range.1 < 10.0);
        assert!(plot.points_label.contains("1 beyond the axes"));
        Ok(())
    }

    #[test]
    fn non_finite_points_are_left_out() -> TestResult {
        let mut pts = sigma_vs_error(30);
        pts[2] = [f64::NAN, 1.0];
        pts[5] = [0.3, f64::INFINITY];
        let fig = scatter("t", "x", "y", &pts);
        let svg = fig.to_svg()?;
        assert!(svg.contains("28 points") && svg.contains("2 non-finite left out"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() {
        let bad = [
            scatter("t", "x", "y", &[]),
            scatter("t", "x", "y", &[[f64::NAN, 1.0]]),
            scatter("t", "x", "y", &[[0.0, 0.0], [f64::MAX, 1.0]]),
        ];
        for fig in bad {
            super::assert_rejected(&fig);
        }
    }

    #[test]
    fn single_and_constant_points_draw_without_a_line() -> TestResult {
        let one = scatter("t", "x", "y", &[[1.0, 2.0]]);
        assert!(one.to_svg()?.contains("1 point, Pearson r undefined"));
        let Figure::Scatter(same_x) = scatter("t", "x", "y", &[[1.0, 2.0], [1.0, 3.0]]) else {
            return Err("not a scatter plot".into());
        };
        assert!(prepare_scatter(&same_x)?.fit_label.is_none());
        Figure::from(same_x).to_png()?;
        scatter("t", "x", "y", &[[-1.0, -2.0], [0.0, 0.0]]).to_png()?;
        Ok(())
    }
}

mod reliability {
    use crate::error::Result;
    use crate::figure::reliability;
    use crate::reliability::ReliabilityCurve;

    fn curve(name: &str, f: impl Fn(f64) -> f64) -> ReliabilityCurve {
        ReliabilityCurve {
            name: name.into(),
            points: (1..20)
                .map(|k| f64::from(k) * 0.05)
                .map(|p| [p, f(p)])
                .collect(),
        }
    }

    #[test]
    fn draws_every_curve_and_the_diagonal() -> Result<()> {
        let fig = reliability(
            "Coverage",
            vec![curve("raw", |p| p * p), curve("calibrated", |p| p)],
        );
        let svg = fig.to_svg()?;
        assert!(svg.contains("Coverage") && svg.contains("raw") && svg.contains("calibrated"));
        assert!(svg.contains("ideal"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_curves_are_refused() {
        for fig in [
            reliability("t", vec![]),
            reliability("t", vec![curve("x", |_| f64::NAN)]),
            reliability("t", vec![curve("x", |p| p + 1.0)]),
        ] {
            super::assert_rejected(&fig);
        }
    }
}
