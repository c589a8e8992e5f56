//! Contact sheets: a grid of labelled images in one PNG (render modes × appearance variants, or
//! any other set of pictures a person wants to compare side by side).

use crate::chart::encode_png;
use crate::error::{ReportError, Result};
use crate::font::{FONT, ensure_font};
use plotters::prelude::*;
use std::path::Path;

/// One picture of a sheet with its caption.
#[derive(Clone, Debug)]
pub struct Tile {
    /// Caption drawn under the picture.
    pub label: String,
    /// The picture.
    pub image: image::RgbImage,
}

/// Margin around and between tiles, pixels.
const GAP: u32 = 8;
/// Height of a caption line, pixels.
const CAPTION: u32 = 22;
/// Height of the title band, pixels.
const TITLE: u32 = 40;

/// PNG bytes of `tiles` laid out in rows of `columns`, each cell as large as the largest tile,
/// with the caption under each picture and `title` on top. Text uses the embedded font.
pub fn contact_sheet(title: &str, tiles: &[Tile], columns: usize) -> Result<Vec<u8>> {
    let where_ = Path::new("contact sheet");
    if tiles.is_empty() || columns == 0 {
        return Err(ReportError::BadInput(
            "contact sheet: no tiles or zero columns".into(),
        ));
    }
    ensure_font(where_)?;
    let cell_w = tiles.iter().map(|t| t.image.width()).max().unwrap_or(1);
    let cell_h = tiles.iter().map(|t| t.image.height()).max().unwrap_or(1) + CAPTION;
    let cols = columns.min(tiles.len()) as u32;
    let rows = tiles.len().div_ceil(columns) as u32;
    let width = GAP + cols * (cell_w + GAP);
    let height = TITLE + rows * (cell_h + GAP) + GAP;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    let plot_err = |e: &dyn std::fmt::Display| ReportError::Plot {
        path: where_.to_path_buf(),
        msg: e.to_string(),
    };
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        let title_style = TextStyle::from((FONT, 24).into_font()).color(&BLACK);
        root.draw(&Text::new(title.to_string(), (GAP as i32, 8), title_style))
            .map_err(|e| plot_err(&e))?;
        let caption_style = TextStyle::from((FONT, 15).into_font()).color(&RGBColor(40, 40, 40));
        for (i, tile) in tiles.iter().enumerate() {
            let (c, r) = ((i as u32) % cols, (i as u32) / cols);
            let x = GAP + c * (cell_w + GAP);
            let y = TITLE + r * (cell_h + GAP);
            let (w, h) = tile.image.dimensions();
            let element = BitMapElement::with_owned_buffer(
                (x as i32, y as i32),
                (w, h),
                tile.image.as_raw().clone(),
            )
            .ok_or_else(|| {
                ReportError::BadInput(format!("tile '{}' has a bad buffer", tile.label))
            })?;
            root.draw(&element).map_err(|e| plot_err(&e))?;
            let label_pos = (x as i32, (y + h + 3) as i32);
            root.draw(&Text::new(
                tile.label.clone(),
                label_pos,
                caption_style.clone(),
            ))
            .map_err(|e| plot_err(&e))?;
        }
        root.present().map_err(|e| plot_err(&e))?;
    }
    encode_png(&buf, width, height).map_err(|e| plot_err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lays_out_tiles_with_captions() -> Result<()> {
        let tiles: Vec<Tile> = (0..5)
            .map(|i| Tile {
                label: format!("tile {i}"),
                image: image::RgbImage::from_pixel(40, 30, image::Rgb([i * 50, 0, 0])),
            })
            .collect();
        let png = contact_sheet("Sheet", &tiles, 3)?;
        let img = image::load_from_memory(&png)
            .map_err(|e| ReportError::BadInput(e.to_string()))?
            .to_rgb8();
        assert_eq!(img.width(), GAP + 3 * (40 + GAP));
        assert_eq!(img.height(), TITLE + 2 * (30 + CAPTION + GAP) + GAP);
        // the second tile's pixels are where the layout puts them
        let p = img.get_pixel(GAP + 40 + GAP + 5, TITLE + 5);
        assert_eq!(p.0, [50, 0, 0]);
        assert!(contact_sheet("x", &[], 3).is_err());
        Ok(())
    }
}
