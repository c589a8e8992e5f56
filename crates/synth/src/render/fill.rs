//! Filling a scan's gaps: pixels where a render of a scan sees nothing take the colours around
//! them.
//!
//! A scan has holes where its depth camera saw nothing (screens, glass, dark or far surfaces,
//! places it never looked), and a render through them shows black. A photo taken there shows
//! something, and a network or a corner detector trained on the renders learns the black
//! shapes and their sharp outlines, which no photo has. Push-pull (Gortler et al. 1996, "The
//! Lumigraph") fills each gap from its surroundings, smoothly and in time linear in the pixels:
//! seen pixels are averaged down a pyramid until every level-`n` pixel holds some colour, and
//! each gap pixel takes the bilinear blend of the level above.
//!
//! Why hand-written: the image crates have no inpainting (OpenCV's `inpaint` is the peer, and
//! needs no more than this for gaps that carry no structure of their own).

/// Replaces the colour of every pixel whose `depth` is 0 (nothing seen) by the push-pull fill of
/// the seen ones. An image with no seen pixel, or no gap, is left as it is.
pub fn fill_empty(rgb: &mut image::RgbImage, depth: &[f32]) {
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    if depth.len() != w * h || !depth.contains(&0.0) || !depth.iter().any(|&d| d > 0.0) {
        return;
    }
    let base = Level {
        w,
        h,
        color: rgb.pixels().map(|p| p.0.map(f32::from)).collect(),
        weight: depth
            .iter()
            .map(|&d| f32::from(u8::from(d > 0.0)))
            .collect(),
    };
    let mut pyramid = vec![base];
    while pyramid.last().is_some_and(|l| l.w > 1 || l.h > 1) {
        let next = pyramid.last().map(Level::halved);
        pyramid.extend(next);
    }
    // Pull: from the coarsest level down, gaps take the level above's colour.
    for k in (0..pyramid.len() - 1).rev() {
        let (fine, coarse) = pyramid.split_at_mut(k + 1);
        fine[k].fill_from(&coarse[0]);
    }
    for ((p, c), &d) in rgb.pixels_mut().zip(&pyramid[0].color).zip(depth) {
        if d <= 0.0 {
            p.0 = c.map(|v| v.round().clamp(0.0, 255.0) as u8);
        }
    }
}

/// One level of the pyramid: colours (meaningful where `weight` > 0) and the share of the
/// level-0 pixels below each that were seen.
struct Level {
    w: usize,
    h: usize,
    color: Vec<[f32; 3]>,
    weight: Vec<f32>,
}

impl Level {
    /// The next level: each pixel the weighted mean of (up to) 2x2 pixels of this one.
    fn halved(&self) -> Level {
        let (w, h) = (self.w.div_ceil(2), self.h.div_ceil(2));
        let mut color = vec![[0.0; 3]; w * h];
        let mut weight = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let (mut acc, mut wsum, mut n) = ([0.0f32; 3], 0.0f32, 0.0f32);
                for (sx, sy) in [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1)]
                    .into_iter()
                    .chain([(2 * x + 1, 2 * y + 1)])
                {
                    if sx >= self.w || sy >= self.h {
                        continue;
                    }
                    let i = sy * self.w + sx;
                    let wt = self.weight[i];
                    for (a, c) in acc.iter_mut().zip(self.color[i]) {
                        *a += wt * c;
                    }
                    wsum += wt;
                    n += 1.0;
                }
                let i = y * w + x;
                if wsum > 0.0 {
                    color[i] = acc.map(|a| a / wsum);
                }
                weight[i] = wsum / n;
            }
        }
        Level {
            w,
            h,
            color,
            weight,
        }
    }

    /// Blends each pixel with `coarse` (bilinear at the pixel's centre) by how much of it was
    /// unseen: a gap takes `coarse` wholly, a seen pixel keeps its colour.
    fn fill_from(&mut self, coarse: &Level) {
        for y in 0..self.h {
            for x in 0..self.w {
                let i = y * self.w + x;
                let seen = self.weight[i].min(1.0);
                if seen >= 1.0 {
                    continue;
                }
                let c = coarse.bilinear(0.5 * x as f32 - 0.25, 0.5 * y as f32 - 0.25);
                let own = self.color[i];
                self.color[i] = [0, 1, 2].map(|k| seen * own[k] + (1.0 - seen) * c[k]);
                self.weight[i] = 1.0;
            }
        }
    }

    /// Bilinear colour at pixel coordinates `(x, y)` (pixel centres at integers), clamped to
    /// the level.
    fn bilinear(&self, x: f32, y: f32) -> [f32; 3] {
        let clamp = |v: f32, n: usize| v.clamp(0.0, (n - 1) as f32);
        let (x, y) = (clamp(x, self.w), clamp(y, self.h));
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let at = |xx: usize, yy: usize| self.color[yy * self.w + xx];
        let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        [0, 1, 2].map(|k| {
            (1.0 - fy) * ((1.0 - fx) * a[k] + fx * b[k]) + fy * ((1.0 - fx) * c[k] + fx * d[k])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gap_takes_the_colours_around_it_and_seen_pixels_keep_theirs() {
        let (w, h) = (32u32, 24u32);
        // Left half red, right half blue, a hole in the middle of each half.
        let mut rgb = image::RgbImage::from_fn(w, h, |x, _| {
            if x < w / 2 {
                image::Rgb([200, 0, 0])
            } else {
                image::Rgb([0, 0, 200])
            }
        });
        let before = rgb.clone();
        let hole = |x: u32, y: u32| (5..10).contains(&x) && (8..14).contains(&y);
        let hole2 = |x: u32, y: u32| (22..28).contains(&x) && (8..14).contains(&y);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if hole(x, y) || hole2(x, y) { 0.0 } else { 2.0 }
            })
            .collect();
        for (x, y, p) in rgb.enumerate_pixels_mut() {
            if hole(x, y) || hole2(x, y) {
                *p = image::Rgb([0, 0, 0]);
            }
        }
        fill_empty(&mut rgb, &depth);
        for (x, y, p) in rgb.enumerate_pixels() {
            if hole(x, y) || hole2(x, y) {
                let want = before.get_pixel(x, y).0;
                let err = p.0.iter().zip(want).map(|(a, b)| a.abs_diff(b)).max();
                assert!(err <= Some(10), "({x}, {y}): {:?} against {want:?}", p.0);
            } else {
                assert_eq!(p, before.get_pixel(x, y), "({x}, {y}) was seen");
            }
        }
    }

    #[test]
    fn an_image_that_saw_nothing_or_everything_is_unchanged() {
        let rgb = image::RgbImage::from_fn(8, 6, |x, y| image::Rgb([x as u8, y as u8, 9]));
        for d in [0.0, 1.5] {
            let mut out = rgb.clone();
            fill_empty(&mut out, &[d; 48]);
            assert_eq!(out, rgb);
        }
    }
}
