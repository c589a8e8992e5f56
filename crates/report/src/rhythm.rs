//! The scene-cut picture: the visual rhythm (one column per frame) on top, the difference
//! series with the detector's threshold beneath it on the same frame axis, detected cuts as
//! red lines through both, gradual transitions shaded, gold cuts (when known) as green ticks.

use crate::chart::encode_png;
use crate::error::{ReportError, Result};
use crate::font::{FONT, ensure_font};
use plotters::prelude::*;
use std::path::Path;

/// Everything the picture shows.
#[derive(Clone, Debug)]
pub struct RhythmPlot<'a> {
    /// Title above the picture.
    pub title: &'a str,
    /// The visual rhythm: column `i` is frame `i · stride`.
    pub rhythm: &'a image::RgbImage,
    /// Frames per rhythm column.
    pub stride: u64,
    /// Frame index of each series entry.
    pub frames: &'a [u64],
    /// The difference series (non-finite values are skipped).
    pub score: &'a [f32],
    /// The score a cut needed at each frame.
    pub threshold: &'a [f32],
    /// Detected hard cuts.
    pub cuts: &'a [u64],
    /// Detected gradual transitions, `[first, last]`.
    pub gradual: &'a [[u64; 2]],
    /// Gold hard cuts, if known.
    pub gold: &'a [u64],
}

const WIDTH: u32 = 1200;
const RHYTHM_H: u32 = 170;
const CHART_H: u32 = 300;
const TITLE_H: u32 = 34;
const LEFT: u32 = 60;
const RIGHT: u32 = 20;
/// Most points drawn per series: longer series keep each bucket's largest value (spikes are
/// what the picture is about).
const MAX_POINTS: usize = 2400;

/// PNG bytes of the picture.
pub fn rhythm_png(p: &RhythmPlot<'_>) -> Result<Vec<u8>> {
    let where_ = Path::new("visual rhythm plot");
    ensure_font(where_)?;
    if p.frames.len() != p.score.len() || p.frames.len() != p.threshold.len() {
        return Err(ReportError::BadInput(
            "visual rhythm plot: series of different lengths".into(),
        ));
    }
    let plot_err = |e: &dyn std::fmt::Display| ReportError::Plot {
        path: where_.to_path_buf(),
        msg: e.to_string(),
    };
    let height = TITLE_H + RHYTHM_H + CHART_H;
    // Frames `0..span` along the x axis.
    let span = p
        .frames
        .last()
        .map_or(0, |&f| f + 1)
        .max(p.stride * u64::from(p.rhythm.width()))
        .max(1) as f64;
    let inner_w = WIDTH - LEFT - RIGHT;
    let x_of = |frame: f64| LEFT as i32 + (frame / span * f64::from(inner_w)) as i32;
    let mut buf = vec![255u8; WIDTH as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (WIDTH, height)).into_drawing_area();
        root.draw(&Text::new(
            p.title.to_string(),
            (LEFT as i32, 8),
            TextStyle::from((FONT, 20).into_font()).color(&BLACK),
        ))
        .map_err(|e| plot_err(&e))?;
        // The rhythm, stretched to the plot's width (nearest neighbour keeps cuts sharp).
        let strip_w = ((p.stride * u64::from(p.rhythm.width())) as f64 / span * f64::from(inner_w))
            .round()
            .clamp(1.0, f64::from(inner_w)) as u32;
        let strip = image::imageops::resize(
            p.rhythm,
            strip_w,
            RHYTHM_H - 10,
            image::imageops::FilterType::Nearest,
        );
        let element = BitMapElement::with_owned_buffer(
            (LEFT as i32, TITLE_H as i32),
            (strip_w, RHYTHM_H - 10),
            strip.into_raw(),
        )
        .ok_or_else(|| ReportError::BadInput("visual rhythm: bad buffer".into()))?;
        root.draw(&element).map_err(|e| plot_err(&e))?;
        let (top, bottom) = (TITLE_H as i32, (TITLE_H + RHYTHM_H - 10) as i32);
        for &[a, b] in p.gradual {
            root.draw(&Rectangle::new(
                [(x_of(a as f64), bottom), (x_of(b as f64 + 1.0), bottom + 6)],
                RGBColor(240, 150, 30).filled(),
            ))
            .map_err(|e| plot_err(&e))?;
        }
        for &c in p.cuts {
            let x = x_of(c as f64);
            root.draw(&PathElement::new(
                vec![(x, top), (x, bottom)],
                RED.stroke_width(1),
            ))
            .map_err(|e| plot_err(&e))?;
        }
        for &g in p.gold {
            let x = x_of(g as f64);
            root.draw(&PathElement::new(
                vec![(x, top - 8), (x, top - 1)],
                RGBColor(0, 150, 0).stroke_width(3),
            ))
            .map_err(|e| plot_err(&e))?;
        }

        let chart_area = root.split_vertically(TITLE_H + RHYTHM_H).1;
        let (xs, score, threshold) = decimate(p.frames, p.score, p.threshold);
        let y_max = score
            .iter()
            .chain(&threshold)
            .copied()
            .filter(|v| v.is_finite())
            .fold(1.0f32, f32::max)
            * 1.05;
        let mut chart = ChartBuilder::on(&chart_area)
            .margin_left(LEFT - 50)
            .margin_right(RIGHT)
            .margin_bottom(6)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(0f64..span, 0f32..y_max)
            .map_err(|e| plot_err(&e))?;
        chart
            .configure_mesh()
            .x_desc("frame")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .y_desc("column difference (grey levels)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| plot_err(&e))?;
        for &[a, b] in p.gradual {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(a as f64, 0.0), (b as f64 + 1.0, y_max)],
                    RGBColor(240, 150, 30).mix(0.25).filled(),
                )))
                .map_err(|e| plot_err(&e))?;
        }
        chart
            .draw_series(LineSeries::new(
                xs.iter()
                    .zip(&threshold)
                    .filter(|(_, v)| v.is_finite())
                    .map(|(&x, &v)| (x, v)),
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(|e| plot_err(&e))?
            .label("threshold")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RGBColor(150, 150, 150)));
        chart
            .draw_series(LineSeries::new(
                xs.iter()
                    .zip(&score)
                    .filter(|(_, v)| v.is_finite())
                    .map(|(&x, &v)| (x, v)),
                RGBColor(30, 90, 200).stroke_width(1),
            ))
            .map_err(|e| plot_err(&e))?
            .label("difference")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RGBColor(30, 90, 200)));
        chart
            .draw_series(p.cuts.iter().map(|&c| {
                PathElement::new(
                    vec![(c as f64, 0.0), (c as f64, y_max)],
                    RED.stroke_width(1),
                )
            }))
            .map_err(|e| plot_err(&e))?
            .label("detected cut")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RED));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .draw()
            .map_err(|e| plot_err(&e))?;
        root.present().map_err(|e| plot_err(&e))?;
    }
    encode_png(&buf, WIDTH, height).map_err(|e| plot_err(&e))
}

/// At most [`MAX_POINTS`] points: each bucket's largest score and threshold.
fn decimate(frames: &[u64], score: &[f32], threshold: &[f32]) -> (Vec<f64>, Vec<f32>, Vec<f32>) {
    let bucket = frames.len().div_ceil(MAX_POINTS).max(1);
    let max_of = |v: &[f32]| {
        v.iter()
            .copied()
            .filter(|x| x.is_finite())
            .fold(f32::NAN, f32::max)
    };
    let xs = frames.chunks(bucket).map(|c| c[0] as f64).collect();
    let s = score.chunks(bucket).map(max_of).collect();
    let t = threshold.chunks(bucket).map(max_of).collect();
    (xs, s, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_rhythm_series_and_cuts() -> Result<()> {
        let rhythm = image::RgbImage::from_fn(100, 30, |x, _| image::Rgb([(x * 2) as u8, 0, 0]));
        let frames: Vec<u64> = (0..100).collect();
        let score: Vec<f32> = (0..100).map(|i| if i == 40 { 50.0 } else { 2.0 }).collect();
        let threshold = vec![10.0; 100];
        let png = rhythm_png(&RhythmPlot {
            title: "test",
            rhythm: &rhythm,
            stride: 1,
            frames: &frames,
            score: &score,
            threshold: &threshold,
            cuts: &[40],
            gradual: &[[60, 70]],
            gold: &[40],
        })?;
        let img = image::load_from_memory(&png)
            .map_err(|e| ReportError::BadInput(e.to_string()))?
            .to_rgb8();
        assert_eq!(img.dimensions(), (WIDTH, TITLE_H + RHYTHM_H + CHART_H));
        // the cut line is red in the rhythm strip
        let x = LEFT + (40.0 / 100.0 * f64::from(WIDTH - LEFT - RIGHT)) as u32;
        assert_eq!(img.get_pixel(x, TITLE_H + 20).0, [255, 0, 0]);
        let bad = rhythm_png(&RhythmPlot {
            frames: &frames[..5],
            ..RhythmPlot {
                title: "x",
                rhythm: &rhythm,
                stride: 1,
                frames: &frames,
                score: &score,
                threshold: &threshold,
                cuts: &[],
                gradual: &[],
                gold: &[],
            }
        });
        assert!(bad.is_err());
        Ok(())
    }
}
