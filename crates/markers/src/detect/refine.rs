//! Sub-pixel corners from the marker's four edges, for metric pose.
//!
//! OpenCV's default corners are contour pixels: the centres of the outermost dark pixels, half
//! a pixel inside the true edge of the black square. A marker therefore looks about one pixel
//! smaller than it is, and a pose from those corners puts it too far away: 4–6 % of the distance
//! for a marker 20 px wide. Here each edge is located where the image gradient across it peaks
//! (bilinear samples, parabolic peak), a line is fitted to those edge points by total least
//! squares, and the corners become the intersections of neighbouring lines, as AprilTag's edge
//! refinement does. Written here because OpenCV's `CORNER_REFINE_CONTOUR` needs the contour and
//! `cornerSubPix` lives in the calibration crate (and converges worse on L-shaped corners).

use image::GrayImage;
use nalgebra::{Point2, Vector2};

/// Most pixels along the edge normal to look for the edge (each way); less on small markers,
/// so that the inner end stays within the one-cell black border.
const SEARCH_PX: f64 = 2.5;
/// Least difference between the light and the dark end of a profile, linear grey levels.
const MIN_CONTRAST: f64 = 10.0;
/// The window counts as centred when the edge lies within this of its centre, pixels.
const CENTRING_TOLERANCE_PX: f64 = 0.005;
/// A refined corner further than this from the contour corner is distrusted, pixels.
const MAX_SHIFT_PX: f64 = 3.0;

/// How much work an edge fit spends.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Effort {
    /// Step of the samples along the normal, pixels.
    step_px: f64,
    /// Most window moves while centring the edge profile on the edge (see [`edge_offset`]).
    centring_steps: usize,
    /// Most edge points fitted per edge.
    max_points: usize,
}

/// For poses: a hundredth of a pixel matters (the range's error is the corners' relative one).
const FOR_POSE: Effort = Effort {
    step_px: 0.125,
    centring_steps: 5,
    max_points: 40,
};

/// For reading a small candidate's cells again (`detect`'s second pass): a tenth of a pixel is
/// a fortieth of a 4 px cell, and the fit runs on candidates that mostly are no marker.
pub(crate) const FOR_READING: Effort = Effort {
    step_px: 0.25,
    centring_steps: 2,
    max_points: 12,
};

/// Moves `corners` (a convex quad of a dark square on a light surround, any order around it)
/// onto the sub-pixel intersections of its edges; corners whose edges cannot be fitted stay.
pub fn refine_corners(gray: &GrayImage, corners: &mut [Point2<f64>; 4]) {
    refine_corners_with(gray, corners, FOR_POSE);
}

/// [`refine_corners`] at the given effort.
pub(crate) fn refine_corners_with(
    gray: &GrayImage,
    corners: &mut [Point2<f64>; 4],
    effort: Effort,
) {
    let centre = corners.iter().fold(Vector2::zeros(), |a, c| a + c.coords) / 4.0;
    let side = |k: usize| (corners[(k + 1) % 4] - corners[k % 4]).norm();
    let lines: Vec<Option<Line>> = (0..4)
        .map(|k| {
            // The black border is one cell thick across edge k: a sixth of the neighbouring
            // edges' length for a 4x4 marker, less for larger ones. Searching well under a
            // cell each way (a fourteenth: half a 4x4 cell) keeps the profile's inner end,
            // with the bilinear footprint, inside the border at any viewing angle.
            let across = side(k + 1).min(side(k + 3));
            let search = (across / 14.0).clamp(1.0, SEARCH_PX);
            fit_edge(
                gray,
                corners[k],
                corners[(k + 1) % 4],
                &centre,
                search,
                effort,
            )
        })
        .collect();
    let original = *corners;
    for k in 0..4 {
        // Corner k lies on edge k-1 (into it) and edge k (out of it).
        let (Some(a), Some(b)) = (&lines[(k + 3) % 4], &lines[k]) else {
            continue;
        };
        if let Some(p) = a.intersect(b)
            && (p - original[k]).norm() <= MAX_SHIFT_PX
        {
            corners[k] = p;
        }
    }
}

/// A line through `point` along the unit vector `dir`.
struct Line {
    point: Point2<f64>,
    dir: Vector2<f64>,
}

impl Line {
    fn intersect(&self, other: &Line) -> Option<Point2<f64>> {
        let cross = self.dir.x * other.dir.y - self.dir.y * other.dir.x;
        if cross.abs() < 1e-6 {
            return None;
        }
        let d = other.point - self.point;
        let t = (d.x * other.dir.y - d.y * other.dir.x) / cross;
        Some(self.point + self.dir * t)
    }
}

/// The edge from `a` to `b` fitted to edge points found within `search` pixels across it.
fn fit_edge(
    gray: &GrayImage,
    a: Point2<f64>,
    b: Point2<f64>,
    centre: &Vector2<f64>,
    search: f64,
    effort: Effort,
) -> Option<Line> {
    let d = b - a;
    let len = d.norm();
    if len < 4.0 {
        return None;
    }
    let along = d / len;
    let mut normal = Vector2::new(-along.y, along.x);
    if normal.dot(&(a.coords + d / 2.0 - centre)) < 0.0 {
        normal = -normal; // outwards: dark inside, light outside
    }
    // Samples away from the corners, where the neighbouring edges blur in.
    let n = ((len / 2.0) as usize).clamp(4, effort.max_points.max(4));
    let mut pts: Vec<(Point2<f64>, f64)> = Vec::with_capacity(n);
    for i in 0..n {
        let t = 0.15 + 0.7 * (i as f64 + 0.5) / n as f64;
        let p = a + d * t;
        if let Some((s, g)) = edge_offset(gray, &p, &normal, search, effort) {
            pts.push((p + normal * s, g));
        }
    }
    if pts.len() < 3 {
        return None;
    }
    // Weighted total least squares: centroid and principal direction.
    let wsum: f64 = pts.iter().map(|(_, w)| w).sum();
    let c = pts
        .iter()
        .fold(Vector2::zeros(), |acc, (p, w)| acc + p.coords * *w)
        / wsum;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (p, w) in &pts {
        let q = p.coords - c;
        sxx += w * q.x * q.x;
        sxy += w * q.x * q.y;
        syy += w * q.y * q.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let mut dir = Vector2::new(angle.cos(), angle.sin());
    if dir.dot(&along) < 0.0 {
        dir = -dir;
    }
    Some(Line {
        point: Point2::from(c),
        dir,
    })
}

/// Offset along `normal` (pixels) of the dark-to-light edge near `p`, and its contrast; `None`
/// when the edge is too weak or out of the image. The edge is where the profile's dark share,
/// integrated from the inner end, runs out: exact for a blurred step, since blur keeps area,
/// where the peak of a finite-difference gradient snaps towards pixel boundaries.
///
/// The first window is centred on `p`; it is then moved until it is centred on the edge it
/// finds (secant steps on `found − centre`). On a small marker a window around the contour
/// pixel (half a pixel inside the edge) reaches barely a pixel past the edge, where the blur
/// has not yet run out: the light end reads too dark, and the off-centre window turns that
/// into an edge moved inwards (the marker looked 1–2 % too far at 20 px). Centred, the
/// shortfalls at the two ends cancel.
fn edge_offset(
    gray: &GrayImage,
    p: &Point2<f64>,
    normal: &Vector2<f64>,
    search: f64,
    effort: Effort,
) -> Option<(f64, f64)> {
    let step = effort.step_px;
    let mut found = edge_in_window(gray, p, normal, 0.0, search, step)?;
    let (mut prev_centre, mut prev_gap) = (0.0, found.0);
    let mut centre = found.0.clamp(-search, search);
    for _ in 0..effort.centring_steps {
        found = edge_in_window(gray, p, normal, centre, search, step)?;
        let gap = found.0 - centre;
        if gap.abs() < CENTRING_TOLERANCE_PX || (gap - prev_gap).abs() < 1e-9 {
            break;
        }
        let next = centre - gap * (centre - prev_centre) / (gap - prev_gap);
        (prev_centre, prev_gap) = (centre, gap);
        centre = next.clamp(-search, search);
    }
    Some(found)
}

/// [`edge_offset`] with the profile taken over `centre ± search` along `normal` (rounded to
/// whole sampling steps of `step` pixels).
fn edge_in_window(
    gray: &GrayImage,
    p: &Point2<f64>,
    normal: &Vector2<f64>,
    centre: f64,
    search: f64,
    step: f64,
) -> Option<(f64, f64)> {
    // An even number of steps, so that the samples lie symmetrically about `centre`.
    let half_steps = ((search / step).round() as usize).max(1);
    let steps = 2 * half_steps;
    let start = centre - half_steps as f64 * step;
    let profile: Vec<f64> = (0..=steps)
        .map(|i| {
            let s = start + i as f64 * step;
            bilinear(gray, p.x + normal.x * s, p.y + normal.y * s)
        })
        .collect::<Option<_>>()?;
    let dark = (profile[0] + profile[1]) / 2.0;
    let light = (profile[steps] + profile[steps - 1]) / 2.0;
    let contrast = light - dark;
    if contrast < MIN_CONTRAST {
        return None;
    }
    // Trapezoid rule over the samples of the dark share; not clamped to 0–1, since clipping
    // the noise of the flat parts would push the edge outwards.
    let share = |v: f64| (light - v) / contrast;
    let area: f64 = profile
        .windows(2)
        .map(|w| 0.5 * (share(w[0]) + share(w[1])) * step)
        .sum();
    Some((start + area, contrast))
}

/// Grey level (sRGB-encoded, as cameras write) to linear light on the same 0–255 scale: blur
/// mixes light linearly, so only there does a blurred edge keep its area.
fn linear_light(v: f64) -> f64 {
    let c = v / 255.0;
    255.0
        * if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
}

/// [`linear_light`] of every grey level, computed once.
fn linear_lut() -> &'static [f64; 256] {
    static LUT: std::sync::OnceLock<[f64; 256]> = std::sync::OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|v| linear_light(v as f64)))
}

/// Bilinear sample in linear light, with (0, 0) at the centre of the top-left pixel; `None`
/// outside the image.
fn bilinear(gray: &GrayImage, x: f64, y: f64) -> Option<f64> {
    let (w, h) = (gray.width() as f64, gray.height() as f64);
    if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) {
        return None;
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as u32, y0 as u32);
    let (x1, y1) = (
        (x0 + 1).min(gray.width() - 1),
        (y0 + 1).min(gray.height() - 1),
    );
    let lut = linear_lut();
    let v = |x: u32, y: u32| lut[gray.get_pixel(x, y).0[0] as usize];
    Some(
        v(x0, y0) * (1.0 - fx) * (1.0 - fy)
            + v(x1, y0) * fx * (1.0 - fy)
            + v(x0, y1) * (1.0 - fx) * fy
            + v(x1, y1) * fx * fy,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dark square with exact sub-pixel edges, anti-aliased by area coverage in linear light
    /// and written sRGB-encoded, as a camera does; each pixel integrates a box `footprint`
    /// pixels wide (1: a sharp lens, more: blur).
    fn square(x0: f64, y0: f64, side: f64, footprint: f64) -> GrayImage {
        let half = footprint / 2.0;
        GrayImage::from_fn(80, 80, |x, y| {
            let cover = |p: f64, lo: f64, hi: f64| {
                (((p + half).min(hi) - (p - half).max(lo)) / footprint).clamp(0.0, 1.0)
            };
            let c = cover(x as f64, x0, x0 + side) * cover(y as f64, y0, y0 + side);
            let linear = 0.8 * (1.0 - c) + 0.02 * c;
            let srgb = if linear <= 0.003_130_8 {
                12.92 * linear
            } else {
                1.055 * linear.powf(1.0 / 2.4) - 0.055
            };
            image::Luma([(255.0 * srgb).round() as u8])
        })
    }

    #[test]
    fn contour_corners_move_onto_the_true_edges() {
        // Edges at 19.8 and 49.8 (pixel centres are integers); contour corners at pixel centres.
        let img = square(19.8, 19.8, 30.0, 1.0);
        let mut corners = [
            Point2::new(20.0, 20.0),
            Point2::new(49.0, 20.0),
            Point2::new(49.0, 49.0),
            Point2::new(20.0, 49.0),
        ];
        refine_corners(&img, &mut corners);
        let truth = [(19.8, 19.8), (49.8, 19.8), (49.8, 49.8), (19.8, 49.8)];
        for (c, t) in corners.iter().zip(truth) {
            assert!(
                (c.x - t.0).abs() < 0.1 && (c.y - t.1).abs() < 0.1,
                "{c} vs {t:?}"
            );
        }
    }

    #[test]
    fn a_small_blurred_marker_keeps_its_size() {
        // 20 px wide (a 0.2 m marker at 5 m in VGA), each pixel integrating 2 px: the search
        // window reaches about a pixel past the edge, where the blur has not run out. The side
        // found must stay within 0.05 px of the truth (0.25 % of the range).
        let img = square(20.5, 20.5, 20.0, 2.0);
        let mut corners = [
            Point2::new(21.0, 21.0),
            Point2::new(40.0, 21.0),
            Point2::new(40.0, 40.0),
            Point2::new(21.0, 40.0),
        ];
        refine_corners(&img, &mut corners);
        let side = (corners[1] - corners[0]).norm();
        assert!(
            (side - 20.0).abs() < 0.05,
            "side {side} px, corners {corners:?}"
        );
    }

    #[test]
    fn a_flat_image_leaves_the_corners_alone() {
        let img = GrayImage::from_pixel(40, 40, image::Luma([128]));
        let orig = [
            Point2::new(5.0, 5.0),
            Point2::new(30.0, 5.0),
            Point2::new(30.0, 30.0),
            Point2::new(5.0, 30.0),
        ];
        let mut corners = orig;
        refine_corners(&img, &mut corners);
        assert_eq!(corners, orig);
    }
}
