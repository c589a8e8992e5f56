//! Confusion matrices as pictures: true class down the side, predicted class along the top,
//! each cell shaded by the fraction of its row (so small classes read as clearly as large
//! ones) with its count written in it, and the row's recall at the end.

use crate::chart::encode_png;
use crate::error::{ReportError, Result};
use crate::font::{FONT, ensure_font};
use plotters::prelude::*;
use std::path::Path;

/// Pixel size of one cell (the picture grows with the number of classes, up to [`MAX_SIDE`]).
const CELL: u32 = 34;
/// Largest grid side, pixels; more classes get smaller cells.
const MAX_SIDE: u32 = 900;
const TITLE_H: u32 = 40;
const TOP: u32 = 30;
const RIGHT: u32 = 70;
const MARGIN: u32 = 12;
const GREY: RGBColor = RGBColor(90, 90, 90);

/// A line of text at `(x, y)`.
fn text(
    s: String,
    x: i32,
    y: i32,
    size: u32,
    color: &'static RGBColor,
) -> Text<'static, (i32, i32), String> {
    Text::new(
        s,
        (x, y),
        TextStyle::from((FONT, size).into_font()).color(color),
    )
}

/// PNG bytes of the confusion matrix `counts[true][predicted]` of `classes`.
pub fn confusion_png(title: &str, classes: &[String], counts: &[Vec<usize>]) -> Result<Vec<u8>> {
    let where_ = Path::new("confusion matrix");
    ensure_font(where_)?;
    let n = classes.len();
    if n == 0 || counts.len() != n || counts.iter().any(|r| r.len() != n) {
        return Err(ReportError::BadInput(format!(
            "confusion matrix: {} classes but a {}-row table",
            n,
            counts.len()
        )));
    }
    let plot_err = |e: &dyn std::fmt::Display| ReportError::Plot {
        path: where_.to_path_buf(),
        msg: e.to_string(),
    };
    let cell = (MAX_SIDE / n as u32).clamp(4, CELL);
    let label_w = 8 * classes.iter().map(|c| c.chars().count()).max().unwrap_or(1) as u32 + 16;
    let (left, grid) = (label_w, cell * n as u32);
    let width = (left + grid + RIGHT + MARGIN).max(360);
    let height = TITLE_H + TOP + grid + MARGIN;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();

        root.draw(&text(title.to_string(), MARGIN as i32, 10, 18, &BLACK))
            .map_err(|e| plot_err(&e))?;
        let (x0, y0) = (left as i32, (TITLE_H + TOP) as i32);
        root.draw(&text(
            "predicted →".into(),
            x0,
            (TITLE_H + 8) as i32,
            13,
            &GREY,
        ))
        .map_err(|e| plot_err(&e))?;
        let small = cell >= 18;
        for (r, row) in counts.iter().enumerate() {
            let total: usize = row.iter().sum();
            let y = y0 + (r as u32 * cell) as i32;
            if small {
                root.draw(&text(
                    classes[r].clone(),
                    MARGIN as i32,
                    y + (cell as i32 - 12) / 2,
                    12,
                    &BLACK,
                ))
                .map_err(|e| plot_err(&e))?;
            }
            for (c, &count) in row.iter().enumerate() {
                let x = x0 + (c as u32 * cell) as i32;
                let f = if total > 0 {
                    count as f64 / total as f64
                } else {
                    0.0
                };
                let shade = |full: f64| (255.0 - f * (255.0 - full)) as u8;
                let color = RGBColor(shade(30.0), shade(90.0), shade(170.0));
                root.draw(&Rectangle::new(
                    [(x, y), (x + cell as i32, y + cell as i32)],
                    color.filled(),
                ))
                .map_err(|e| plot_err(&e))?;
                if small && count > 0 {
                    let ink = if f > 0.5 { &WHITE } else { &BLACK };
                    root.draw(&text(
                        count.to_string(),
                        x + 3,
                        y + (cell as i32 - 11) / 2,
                        11,
                        ink,
                    ))
                    .map_err(|e| plot_err(&e))?;
                }
            }
            let recall = if total > 0 {
                format!("{:.0} %", 100.0 * row[r] as f64 / total as f64)
            } else {
                "–".into()
            };
            root.draw(&text(
                recall,
                x0 + grid as i32 + 6,
                y + (cell as i32 - 12) / 2,
                12,
                &BLACK,
            ))
            .map_err(|e| plot_err(&e))?;
        }
        root.draw(&Rectangle::new(
            [(x0, y0), (x0 + grid as i32, y0 + grid as i32)],
            RGBColor(120, 120, 120).stroke_width(1),
        ))
        .map_err(|e| plot_err(&e))?;
        root.present().map_err(|e| plot_err(&e))?;
    }
    encode_png(&buf, width, height).map_err(|e| plot_err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_matrix_and_refuses_a_ragged_one() -> Result<()> {
        let classes: Vec<String> = ["B0/F0/C1/fwd", "B0/F0/C1/back", "B1/F2/none/none"]
            .map(String::from)
            .to_vec();
        let counts = vec![vec![40, 2, 0], vec![5, 30, 1], vec![0, 0, 12]];
        let png = confusion_png("places", &classes, &counts)?;
        let img =
            image::load_from_memory(&png).map_err(|e| ReportError::BadInput(e.to_string()))?;
        assert!(img.width() >= 360 && img.height() > 3 * CELL);
        // the diagonal cell of the first row (95 % of it) is darker than its neighbour (5 %)
        let rgb = img.to_rgb8();
        let left = 8 * 15 + 16;
        let y = TITLE_H + TOP + CELL / 2;
        let dark = rgb.get_pixel(left + 2, y).0[0];
        let light = rgb.get_pixel(left + CELL + CELL - 3, y).0[0];
        assert!(dark < light, "{dark} vs {light}");
        assert!(confusion_png("bad", &classes, &counts[..2]).is_err());
        Ok(())
    }
}
