//! Printable markers: PNG (a raster for screens and the renderer) and SVG (vector, for print at
//! any size), with a white quiet zone around the black border and the dictionary and id printed
//! underneath, so a printed sheet says what it is.

use crate::dictionary::Dictionary;
use crate::error::MarkersError;
use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use image::{GrayImage, Luma};
use std::path::{Path, PathBuf};

/// White cells around the marker's black border: OpenCV asks for at least one; two leave room
/// for scissors.
pub const QUIET_ZONE_CELLS: u32 = 2;

/// The marker alone: `marker_size + 2` cells (the inner bits and the one-cell black border),
/// `cell_px` pixels each, plus `quiet_cells` white cells on every side.
pub fn marker_image(
    dict: &Dictionary,
    id: u32,
    cell_px: u32,
    quiet_cells: u32,
) -> Result<GrayImage, MarkersError> {
    let grid = marker_grid(dict, id)?;
    let n = grid.len() as u32;
    let side = (n + 2 * quiet_cells) * cell_px.max(1);
    let cell_px = cell_px.max(1);
    Ok(GrayImage::from_fn(side, side, |x, y| {
        let (cx, cy) = (x / cell_px, y / cell_px);
        let inside = (quiet_cells..quiet_cells + n).contains(&cx)
            && (quiet_cells..quiet_cells + n).contains(&cy);
        let white = !inside || grid[(cy - quiet_cells) as usize][(cx - quiet_cells) as usize];
        Luma([if white { 255 } else { 0 }])
    }))
}

/// The marker with its quiet zone and a label line (`<dictionary> id <id>`) below it.
pub fn labelled_marker_image(
    dict: &Dictionary,
    id: u32,
    cell_px: u32,
) -> Result<GrayImage, MarkersError> {
    let marker = marker_image(dict, id, cell_px, QUIET_ZONE_CELLS)?;
    let side = marker.width();
    let label_h = (side / 8).max(14);
    let mut out = GrayImage::from_pixel(side, side + label_h, Luma([255]));
    image::imageops::replace(&mut out, &marker, 0, 0);
    draw_text(
        &mut out,
        &label(dict, id),
        cell_px.max(1) as f32 * QUIET_ZONE_CELLS as f32,
        side as f32,
        label_h as f32 * 0.8,
    );
    Ok(out)
}

/// An SVG of the marker for print: the black square is `size_mm` millimetres, the quiet zone and
/// label scale with it.
pub fn marker_svg(dict: &Dictionary, id: u32, size_mm: f64) -> Result<String, MarkersError> {
    let grid = marker_grid(dict, id)?;
    let n = grid.len() as f64;
    let cell = size_mm / n;
    let margin = QUIET_ZONE_CELLS as f64 * cell;
    let side = size_mm + 2.0 * margin;
    let label_h = (side / 8.0).max(4.0);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.3}mm\" height=\"{h:.3}mm\" viewBox=\"0 0 {w:.3} {h:.3}\">\n\
         <rect width=\"{w:.3}\" height=\"{h:.3}\" fill=\"white\"/>\n",
        w = side,
        h = side + label_h
    );
    // One rectangle per horizontal run of black cells keeps the file small and seamless.
    for (r, row) in grid.iter().enumerate() {
        let mut c = 0;
        while c < row.len() {
            if row[c] {
                c += 1;
                continue;
            }
            let start = c;
            while c < row.len() && !row[c] {
                c += 1;
            }
            svg += &format!(
                "<rect x=\"{:.4}\" y=\"{:.4}\" width=\"{:.4}\" height=\"{:.4}\" fill=\"black\"/>\n",
                margin + start as f64 * cell,
                margin + r as f64 * cell,
                (c - start) as f64 * cell,
                cell
            );
        }
    }
    svg += &format!(
        "<text x=\"{:.3}\" y=\"{:.3}\" font-family=\"DejaVu Sans, sans-serif\" font-size=\"{:.3}\">{}</text>\n</svg>\n",
        margin,
        side + label_h * 0.75,
        label_h * 0.7,
        label(dict, id)
    );
    Ok(svg)
}

/// Writes `<dict>_<id>.png` and `.svg` for every id into `dir` (created if missing), atomically;
/// returns the files written.
pub fn write_markers(
    dict: &Dictionary,
    ids: &[u32],
    dir: &Path,
    cell_px: u32,
    size_mm: f64,
) -> Result<Vec<PathBuf>, MarkersError> {
    std::fs::create_dir_all(dir).map_err(|source| MarkersError::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    for &id in ids {
        let stem = format!("{}_{id}", dict.name());
        let png_path = dir.join(format!("{stem}.png"));
        let mut png = Vec::new();
        labelled_marker_image(dict, id, cell_px)?
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| MarkersError::Write {
                path: png_path.clone(),
                source: std::io::Error::other(e),
            })?;
        crate::io::write_atomic(&png_path, &png)?;
        let svg_path = dir.join(format!("{stem}.svg"));
        crate::io::write_atomic(&svg_path, marker_svg(dict, id, size_mm)?.as_bytes())?;
        files.extend([png_path, svg_path]);
    }
    Ok(files)
}

fn label(dict: &Dictionary, id: u32) -> String {
    format!("{} id {id}", dict.name())
}

/// The marker's cells with its black border, row-major, `true` = white.
fn marker_grid(dict: &Dictionary, id: u32) -> Result<Vec<Vec<bool>>, MarkersError> {
    let bits = dict
        .marker_bits(id)
        .ok_or_else(|| MarkersError::InvalidDictionary {
            name: dict.name().to_string(),
            message: format!("has no marker {id} (ids 0..{})", dict.len()),
        })?;
    let m = dict.marker_size() as usize;
    let n = m + 2;
    Ok((0..n)
        .map(|r| {
            (0..n)
                .map(|c| {
                    let inner = (1..=m).contains(&r) && (1..=m).contains(&c);
                    inner && bits[(r - 1) * m + (c - 1)]
                })
                .collect()
        })
        .collect())
}

/// Draws `text` in black with DejaVu Sans, its baseline `height` below `top`.
fn draw_text(img: &mut GrayImage, text: &str, left: f32, top: f32, height: f32) {
    let Ok(font) = FontRef::try_from_slice(dejavu::sans::regular()) else {
        return;
    };
    let scale = PxScale::from(height);
    let scaled = font.as_scaled(scale);
    let mut x = left;
    let baseline = top + scaled.ascent();
    for ch in text.chars() {
        let id = scaled.glyph_id(ch);
        let glyph = id.with_scale_and_position(scale, point(x, baseline));
        x += scaled.h_advance(id);
        let Some(outline) = font.outline_glyph(glyph) else {
            continue;
        };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                let p = img.get_pixel_mut(px as u32, py as u32);
                let ink = (coverage.clamp(0.0, 1.0) * 255.0) as u8;
                p.0[0] = p.0[0].min(255 - ink);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marker_image_has_a_black_border_inside_a_white_quiet_zone() {
        let dict = Dictionary::predefined("4x4_50").unwrap();
        let img = marker_image(&dict, 3, 10, 2).unwrap();
        assert_eq!(img.width(), (4 + 2 + 4) * 10);
        assert_eq!(img.get_pixel(5, 5).0[0], 255, "quiet zone");
        assert_eq!(img.get_pixel(25, 25).0[0], 0, "black border");
        let bits = dict.marker_bits(3).unwrap();
        let first_inner = img.get_pixel(35, 35).0[0] == 255;
        assert_eq!(first_inner, bits[0]);
    }

    #[test]
    fn files_are_written_for_every_id_and_a_missing_id_is_an_error() {
        let dict = Dictionary::predefined("6x6_250").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files = write_markers(&dict, &[0, 17], dir.path(), 8, 50.0).unwrap();
        assert_eq!(files.len(), 4);
        let svg = std::fs::read_to_string(&files[3]).unwrap();
        assert!(svg.contains("id 17") && svg.starts_with("<svg"));
        let png = image::open(&files[0]).unwrap().to_luma8();
        assert!(png.height() > png.width(), "label line below the marker");
        assert!(write_markers(&dict, &[250], dir.path(), 8, 50.0).is_err());
    }
}
