//! The visual-rhythm picture for plots: the main diagonal of every frame's thumbnail as one
//! column, frames left to right. Cuts show as vertical breaks, fades as smooth vertical bands,
//! camera motion as slanted streaks.
//!
//! Memory stays bounded on long inputs: past [`MAX_COLUMNS`] columns every other column is
//! dropped and from then on only every second (fourth, ...) frame is kept.

use crate::error::Result;
use crate::path::{PathKind, pixel_indices};

/// Most columns kept.
pub const MAX_COLUMNS: usize = 2048;

/// The visual rhythm of the main diagonal, decimated to at most [`MAX_COLUMNS`] columns.
#[derive(Debug, Clone)]
pub struct RhythmImage {
    path: Vec<u32>,
    stride: u64,
    seen: u64,
    columns: Vec<Vec<u8>>,
}

impl RhythmImage {
    /// An empty rhythm for thumbnails of `width` x `height`.
    ///
    /// # Errors
    /// An empty thumbnail.
    pub fn new(width: u32, height: u32) -> Result<RhythmImage> {
        Ok(RhythmImage {
            path: pixel_indices(PathKind::Diagonal, width, height)?,
            stride: 1,
            seen: 0,
            columns: Vec::new(),
        })
    }

    /// Adds the next frame's thumbnail (RGB, the size given to [`new`](Self::new)).
    pub fn push(&mut self, rgb: &[u8]) {
        let keep = self.seen.is_multiple_of(self.stride);
        self.seen += 1;
        if !keep {
            return;
        }
        let column = self
            .path
            .iter()
            .flat_map(|&i| {
                let o = 3 * i as usize;
                rgb.get(o..o + 3).unwrap_or(&[0, 0, 0]).iter().copied()
            })
            .collect();
        self.columns.push(column);
        if self.columns.len() > MAX_COLUMNS {
            let mut i = 0;
            self.columns.retain(|_| {
                i += 1;
                i % 2 == 1
            });
            self.stride *= 2;
        }
    }

    /// Frames per column.
    pub fn stride(&self) -> u64 {
        self.stride
    }

    /// Frames pushed.
    pub fn frames(&self) -> u64 {
        self.seen
    }

    /// The picture: one column per kept frame, the diagonal top to bottom; `None` before the
    /// first frame.
    pub fn to_image(&self) -> Option<image::RgbImage> {
        let (w, h) = (self.columns.len() as u32, self.path.len() as u32);
        let mut img = image::RgbImage::new(w.max(1), h.max(1));
        if w == 0 {
            return None;
        }
        for (x, column) in self.columns.iter().enumerate() {
            for (y, px) in column.chunks_exact(3).enumerate() {
                img.put_pixel(x as u32, y as u32, image::Rgb([px[0], px[1], px[2]]));
            }
        }
        Some(img)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_columns_bounded_and_in_order() -> Result<()> {
        let mut r = RhythmImage::new(8, 6)?;
        assert!(r.to_image().is_none());
        for f in 0..(3 * MAX_COLUMNS as u64 / 2) {
            let v = (f % 251) as u8;
            r.push(&[v; 8 * 6 * 3]);
        }
        let img = r
            .to_image()
            .ok_or(crate::CutError::Config("empty".into()))?;
        assert!(img.width() as usize <= MAX_COLUMNS);
        assert_eq!(img.height(), 8);
        assert_eq!(r.stride(), 2);
        // column 1 is frame 2 (stride 2)
        assert_eq!(img.get_pixel(1, 0).0, [2, 2, 2]);
        Ok(())
    }
}
