//! The drawing surface of the object painters (posters, notice boards, signs, windows, ceiling
//! fittings): coordinates in metres on the object, antialiased rectangles, discs, capsules and
//! frames, and the finished picture turned into a texture whose rows run up the wall.

use super::Texture;
use super::color::{Rgb, mix, to_u8};

/// A drawing surface in physical units: picture coordinates in metres, x to the right, y down
/// from the top edge (as one looks at the object).
pub(crate) struct Canvas {
    pub(crate) w: usize,
    pub(crate) h: usize,
    /// Texels per metre along x and y.
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    size_m: [f32; 2],
    pub(crate) px: Vec<Rgb>,
}

impl Canvas {
    pub(crate) fn new(w: usize, h: usize, size_m: [f32; 2], c: Rgb) -> Self {
        Self {
            w,
            h,
            sx: w as f32 / size_m[0],
            sy: h as f32 / size_m[1],
            size_m,
            px: vec![c; w * h],
        }
    }

    /// Sets every texel from `f(x_m, y_m, x, y)` at texel centres.
    pub(crate) fn fill(&mut self, mut f: impl FnMut(f32, f32, usize, usize) -> Rgb) {
        let (w, sx, sy) = (self.w, self.sx, self.sy);
        for (i, p) in self.px.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            *p = f((x as f32 + 0.5) / sx, (y as f32 + 0.5) / sy, x, y);
        }
    }

    /// Blends `f(x_m, y_m) = (colour, alpha)` over every texel.
    pub(crate) fn fill_blend(&mut self, mut f: impl FnMut(f32, f32) -> (Rgb, f32)) {
        let (w, sx, sy) = (self.w, self.sx, self.sy);
        for (i, p) in self.px.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let (c, a) = f((x as f32 + 0.5) / sx, (y as f32 + 0.5) / sy);
            *p = mix(*p, c, a.clamp(0.0, 1.0));
        }
    }

    pub(crate) fn blend(&mut self, x: usize, y: usize, c: Rgb, a: f32) {
        if a <= 0.0 || x >= self.w {
            return;
        }
        if let Some(p) = self.px.get_mut(y * self.w + x) {
            *p = mix(*p, c, a.min(1.0));
        }
    }

    /// Fills an axis-aligned rectangle (metres), with exact coverage at its edges.
    pub(crate) fn rect(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, c: Rgb, alpha: f32) {
        let (px0, px1) = ((x0 * self.sx).max(0.0), (x1 * self.sx).min(self.w as f32));
        let (py0, py1) = ((y0 * self.sy).max(0.0), (y1 * self.sy).min(self.h as f32));
        if px1 <= px0 || py1 <= py0 {
            return;
        }
        for y in py0.floor() as usize..py1.ceil() as usize {
            let cy = (py1.min(y as f32 + 1.0) - py0.max(y as f32)).clamp(0.0, 1.0);
            for x in px0.floor() as usize..px1.ceil() as usize {
                let cx = (px1.min(x as f32 + 1.0) - px0.max(x as f32)).clamp(0.0, 1.0);
                self.blend(x, y, c, alpha * cx * cy);
            }
        }
    }

    /// Blends `f(x_m, y_m) = (colour, signed distance)` over the texels of a bounding box
    /// (metres), where the distance is negative inside the shape; edges are antialiased.
    pub(crate) fn paint(&mut self, bbox: [f32; 4], mut f: impl FnMut(f32, f32) -> (Rgb, f32)) {
        let x0 = (bbox[0] * self.sx - 1.0).floor().max(0.0) as usize;
        let y0 = (bbox[1] * self.sy - 1.0).floor().max(0.0) as usize;
        let x1 = ((bbox[2] * self.sx + 1.0).ceil().max(0.0) as usize).min(self.w);
        let y1 = ((bbox[3] * self.sy + 1.0).ceil().max(0.0) as usize).min(self.h);
        let texel_m = 0.5 * (1.0 / self.sx + 1.0 / self.sy);
        for y in y0..y1 {
            for x in x0..x1 {
                let (c, d) = f((x as f32 + 0.5) / self.sx, (y as f32 + 0.5) / self.sy);
                self.blend(x, y, c, (0.5 - d / texel_m).clamp(0.0, 1.0));
            }
        }
    }

    pub(crate) fn circle(&mut self, cx: f32, cy: f32, r: f32, c: Rgb) {
        self.paint([cx - r, cy - r, cx + r, cy + r], |x, y| {
            (c, (x - cx).hypot(y - cy) - r)
        });
    }

    /// A thick line segment with round caps.
    pub(crate) fn capsule(&mut self, a: [f32; 2], b: [f32; 2], r: f32, c: Rgb) {
        let bbox = [
            a[0].min(b[0]) - r,
            a[1].min(b[1]) - r,
            a[0].max(b[0]) + r,
            a[1].max(b[1]) + r,
        ];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = (dx * dx + dy * dy).max(1e-12);
        self.paint(bbox, |x, y| {
            let t = (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0);
            (c, (x - a[0] - t * dx).hypot(y - a[1] - t * dy) - r)
        });
    }

    /// A polyline of capsules.
    pub(crate) fn stroke(&mut self, pts: &[[f32; 2]], r: f32, c: Rgb) {
        for w in pts.windows(2) {
            self.capsule(w[0], w[1], r, c);
        }
    }

    /// A rectangle outline of line width `lw`.
    pub(crate) fn frame(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, lw: f32, c: Rgb) {
        self.rect(x0, y0, x1, y0 + lw, c, 1.0);
        self.rect(x0, y1 - lw, x1, y1, c, 1.0);
        self.rect(x0, y0 + lw, x0 + lw, y1 - lw, c, 1.0);
        self.rect(x1 - lw, y0 + lw, x1, y1 - lw, c, 1.0);
    }

    /// The texture, rows flipped so that row 0 is the object's bottom edge (v up).
    pub(crate) fn into_texture(self) -> Texture {
        let mut texels = Vec::with_capacity(self.px.len());
        for row in self.px.chunks(self.w.max(1)).rev() {
            texels.extend(row.iter().map(|&c| to_u8(c)));
        }
        Texture {
            width: self.w as u32,
            height: self.h as u32,
            texels,
            repeat_m: self.size_m,
        }
    }
}
