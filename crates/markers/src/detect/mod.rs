//! ArUco marker detection, step for step OpenCV's `ArucoDetector::detectMarkers`
//! (`objdetect/src/aruco/aruco_detector.cpp`) with its default parameters:
//!
//! 1. adaptive threshold (mean, C = 7) at window sizes 3, 13, 23 (`threshold`);
//! 2. contours of each thresholded image (`contours`), polygon approximation at 3 % of the
//!    contour length, convex quadrilaterals only, perimeter between 3 % and 400 % of the larger
//!    image side, corners at least 5 % of the perimeter apart; corners turned clockwise;
//! 3. near-duplicate candidates (mean corner distance below 12.5 % of the perimeter) grouped,
//!    the biggest of each group kept with its distinct smaller ones as fall-backs, groups too
//!    near the image border dropped, nesting recorded;
//! 4. each candidate sampled onto a grid of 4 pixels per cell, Otsu, border cells checked, the
//!    inner bits identified in all 4 rotations (`decode`); inner candidates first, and once a
//!    candidate is a marker the ones around it are not tried;
//! 5. corners rotated so the first is the marker's own top-left (TL, TR, BR, BL).
//!
//! Corners are where OpenCV puts them without refinement (its default): integer contour
//! pixels, so results agree with OpenCV's to the pixel.
//!
//! One step is added after OpenCV's, and finds only what its pass leaves: a second reading of
//! small candidates (`reread_small`). A contour corner can be a pixel off the square's corner,
//! and on cells of 2–4 px a grey level of JPEG noise decides where (two JPEG decoders of the same
//! file lost different markers): the grid sampled from that corner misses a row of cells and the
//! code is not read. Such a candidate is read again from sub-pixel corners. Every marker
//! OpenCV's pass finds is found as it finds it; on the re-encoded shared photos the second
//! reading finds 5 % more of the gold markers than OpenCV (`tests/recall_sweep.rs`).
//!
//! Everything is written here rather than taken from `imageproc`: that crate is not available
//! to this workspace (offline registry), and parity needs OpenCV's exact contour start points,
//! tracing order and Douglas-Peucker variant, which a generic implementation does not promise.
//! Speed comes from sharing one integral image across the three window sizes, a
//! division-free threshold, word-at-a-time run skipping in the contour scan, and rayon across
//! the window sizes and the candidates.

mod contours;
mod decode;
mod polygon;
pub mod refine;
mod threshold;

use crate::dictionary::{Dictionary, Identified};
use crate::error::MarkersError;
use crate::types::Marker;
use decode::{CornerKind, Rejected};
use image::GrayImage;
use nalgebra::Point2;
use rayon::prelude::*;
use std::path::Path;

/// Detection parameters; the defaults are OpenCV's `DetectorParameters()` (5.0).
#[derive(Clone, Debug, PartialEq)]
pub struct DetectParams {
    /// Smallest adaptive-threshold window (pixels; even sizes grow by one). OpenCV: 3.
    pub adaptive_thresh_win_size_min: u32,
    /// Largest adaptive-threshold window. OpenCV: 23.
    pub adaptive_thresh_win_size_max: u32,
    /// Step between window sizes. OpenCV: 10 (so 3, 13, 23).
    pub adaptive_thresh_win_size_step: u32,
    /// A pixel is dark when it is at least this much below its window mean. OpenCV: 7.
    pub adaptive_thresh_constant: f64,
    /// Shortest marker perimeter as a share of the larger image side. OpenCV: 0.03.
    pub min_marker_perimeter_rate: f64,
    /// Longest marker perimeter as a share of the larger image side. OpenCV: 4.0.
    pub max_marker_perimeter_rate: f64,
    /// Polygon approximation tolerance as a share of the contour length. OpenCV: 0.03.
    pub polygonal_approx_accuracy_rate: f64,
    /// Shortest quad side as a share of the contour length. OpenCV: 0.05.
    pub min_corner_distance_rate: f64,
    /// Corners closer than this to the image border (pixels) drop the candidate. OpenCV: 3.
    pub min_distance_to_border: u32,
    /// Candidates whose mean corner distance is below this share of the smaller one's perimeter
    /// are one group. OpenCV: 0.125.
    pub min_marker_distance_rate: f64,
    /// Within a group, a smaller candidate farther than this many cells from the last kept one
    /// is kept as a fall-back. OpenCV: 0.21.
    pub min_group_distance: f64,
    /// Width of the black border, in cells. OpenCV: 1.
    pub marker_border_bits: u32,
    /// Pixels per cell when sampling a candidate. OpenCV: 4.
    pub perspective_remove_pixel_per_cell: u32,
    /// Share of a cell ignored on each side when counting its pixels. OpenCV: 0.13.
    pub perspective_remove_ignored_margin_per_cell: f64,
    /// Most wrong border cells, as a share of `marker_size²`. OpenCV: 0.35.
    pub max_erroneous_bits_in_border_rate: f64,
    /// A candidate whose inside has a smaller standard deviation is taken as uniform (no Otsu).
    /// OpenCV: 5.
    pub min_otsu_std_dev: f64,
    /// Share of the dictionary's `max_correction_bits` that may be corrected. OpenCV: 0.6.
    pub error_correction_rate: f64,
    /// A cell is white when more than this share of it is white, black when less than one
    /// minus it (in between it counts as wrong). OpenCV: 0.49.
    pub valid_bit_id_threshold: f32,
    /// Also look for white-on-black markers. OpenCV: false.
    pub detect_inverted_marker: bool,
    /// Move the corners onto the sub-pixel edges of the black square ([`refine`]); off by
    /// default, as OpenCV's `CORNER_REFINE_NONE`, whose corners sit half a pixel inside the
    /// square and bias poses by a few percent of the distance. Turn it on for poses.
    pub refine_edges: bool,
}

impl Default for DetectParams {
    fn default() -> Self {
        Self {
            adaptive_thresh_win_size_min: 3,
            adaptive_thresh_win_size_max: 23,
            adaptive_thresh_win_size_step: 10,
            adaptive_thresh_constant: 7.0,
            min_marker_perimeter_rate: 0.03,
            max_marker_perimeter_rate: 4.0,
            polygonal_approx_accuracy_rate: 0.03,
            min_corner_distance_rate: 0.05,
            min_distance_to_border: 3,
            min_marker_distance_rate: 0.125,
            min_group_distance: 0.21,
            marker_border_bits: 1,
            perspective_remove_pixel_per_cell: 4,
            perspective_remove_ignored_margin_per_cell: 0.13,
            max_erroneous_bits_in_border_rate: 0.35,
            min_otsu_std_dev: 5.0,
            error_correction_rate: 0.6,
            valid_bit_id_threshold: 0.49,
            detect_inverted_marker: false,
            refine_edges: false,
        }
    }
}

impl DetectParams {
    /// The adaptive-threshold window sizes these parameters give (odd, ascending).
    pub fn window_sizes(&self) -> Vec<u32> {
        let min = self.adaptive_thresh_win_size_min.max(3);
        let max = self.adaptive_thresh_win_size_max.max(min);
        let step = self.adaptive_thresh_win_size_step.max(1);
        (0..=(max - min) / step)
            .map(|i| (min + i * step) | 1)
            .map(|w| w.min(1001))
            .collect()
    }
}

/// Loads an image (any format `image` reads; colour is converted to gray as OpenCV's
/// `COLOR_BGR2GRAY` does) and detects markers in it.
pub fn detect_file(
    path: impl AsRef<Path>,
    dict: &Dictionary,
    params: &DetectParams,
) -> Result<Vec<Marker>, MarkersError> {
    let gray = load_gray(path.as_ref())?;
    Ok(detect(&gray, dict, params))
}

/// Reads an image file as 8-bit gray the way OpenCV's `cvtColor(BGR2GRAY)` computes it. The
/// file is decoded as every command decodes frames ([`data::frames::decode_image`]): a
/// truncated JPEG is refused, not read as an image whose lower part is grey.
pub fn load_gray(path: &Path) -> Result<GrayImage, MarkersError> {
    let img = data::frames::decode_image(path)?;
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => {
            let rgb = other.to_rgb8();
            GrayImage::from_fn(rgb.width(), rgb.height(), |x, y| {
                let p = rgb.get_pixel(x, y);
                image::Luma([imgproc::view::gray_of(p[0], p[1], p[2])])
            })
        }
    })
}

/// A candidate read as a marker, with the corners it was read from.
type Read = (Identified, [[f32; 2]; 4]);

/// A quad that passed the contour filters: corners clockwise, perimeter of the corners.
#[derive(Clone, Debug)]
struct Candidate {
    corners: [[f32; 2]; 4],
    perimeter: f32,
}

/// Detects the markers of `dict` in `gray`. Markers come in OpenCV's output order (biggest
/// candidate first); an image without markers (blank, blurred, tiny) gives an empty list.
pub fn detect(gray: &GrayImage, dict: &Dictionary, params: &DetectParams) -> Vec<Marker> {
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    if w < 3 || h < 3 || dict.is_empty() {
        return Vec::new();
    }
    let candidates = find_candidates(gray, params);
    let tree = filter_too_close(w, h, candidates, dict.marker_size(), params);
    let mut markers = identify(gray, tree, dict, params);
    if params.refine_edges {
        markers
            .par_iter_mut()
            .for_each(|m| refine::refine_corners(gray, &mut m.corners));
    }
    markers
}

/// Steps 1 and 2: candidates of every window size, in OpenCV's order.
fn find_candidates(gray: &GrayImage, params: &DetectParams) -> Vec<Candidate> {
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    let windows = params.window_sizes();
    let pad = *windows.last().expect("at least one window") as usize / 2;
    let raw = gray.as_raw();
    let integral = threshold::Integral::new(raw, w, h, pad);
    let side = w.max(h) as f64;
    let min_perimeter = (params.min_marker_perimeter_rate * side) as usize;
    let max_perimeter = (params.max_marker_perimeter_rate * side) as usize;
    let per_window: Vec<Vec<Candidate>> = windows
        .par_iter()
        .map(|&win| {
            let (pw, ph) = (w + 2, h + 2);
            let mut bin = vec![0u8; pw * ph];
            integral.threshold_into(raw, win as usize, params.adaptive_thresh_constant, &mut bin);

            let mut found = Vec::new();
            let (mut points, mut approx, mut stack) = (Vec::new(), Vec::new(), Vec::new());
            contours::find_contours(&mut bin, pw, ph, &mut points, |c| {
                if c.len() < min_perimeter || c.len() > max_perimeter {
                    return;
                }
                polygon::approx_poly_dp_closed(
                    c,
                    c.len() as f64 * params.polygonal_approx_accuracy_rate,
                    &mut approx,
                    &mut stack,
                );
                if approx.len() != 4 || !polygon::is_convex(&approx) {
                    return;
                }
                let mut min_d2 = side * side;
                for j in 0..4 {
                    let (a, b) = (approx[j], approx[(j + 1) % 4]);
                    let (dx, dy) = (f64::from(a.0 - b.0), f64::from(a.1 - b.1));
                    min_d2 = min_d2.min(dx * dx + dy * dy);
                }
                let min_corner = c.len() as f64 * params.min_corner_distance_rate;
                if min_d2 < min_corner * min_corner {
                    return;
                }
                let mut corners: [[f32; 2]; 4] =
                    std::array::from_fn(|j| [approx[j].0 as f32, approx[j].1 as f32]);
                // Clockwise (in image coordinates, y down).
                let (dx1, dy1) = (
                    f64::from(corners[1][0] - corners[0][0]),
                    f64::from(corners[1][1] - corners[0][1]),
                );
                let (dx2, dy2) = (
                    f64::from(corners[2][0] - corners[0][0]),
                    f64::from(corners[2][1] - corners[0][1]),
                );
                if dx1 * dy2 - dy1 * dx2 < 0.0 {
                    corners.swap(1, 3);
                }
                found.push(corners);
            });
            // OpenCV lists contours last-found first.
            found.reverse();
            found
                .into_iter()
                .map(|corners| Candidate {
                    perimeter: perimeter(&corners),
                    corners,
                })
                .collect()
        })
        .collect();
    per_window.into_iter().flatten().collect()
}

fn perimeter(c: &[[f32; 2]; 4]) -> f32 {
    (0..4)
        .map(|i| {
            let (a, b) = (c[i], c[(i + 1) % 4]);
            ((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1])).sqrt()
        })
        .sum()
}

/// OpenCV's `getAverageDistance`: mean corner distance under the best cyclic shift.
fn average_distance(a: &[[f32; 2]; 4], b: &[[f32; 2]; 4]) -> f32 {
    let mut min_d2 = f32::MAX;
    for fc in 0..4 {
        let mut d2 = 0.0f32;
        for (c, bc) in b.iter().enumerate() {
            let m = (c + fc) % 4;
            let (dx, dy) = (a[m][0] - bc[0], a[m][1] - bc[1]);
            d2 += dx * dx + dy * dy;
        }
        min_d2 = min_d2.min(d2 / 4.0);
    }
    min_d2.sqrt()
}

/// A kept candidate with its fall-backs and its place in the nesting.
struct Node {
    candidate: Candidate,
    close: Vec<Candidate>,
    parent: Option<usize>,
    depth: usize,
}

/// Step 3: OpenCV's `filterTooCloseCandidates`.
fn filter_too_close(
    w: usize,
    h: usize,
    mut cands: Vec<Candidate>,
    marker_size: u32,
    params: &DetectParams,
) -> Vec<Node> {
    // Big to small, stable.
    cands.sort_by(|a, b| {
        b.perimeter
            .partial_cmp(&a.perimeter)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let n = cands.len();
    let mut group_id: Vec<Option<usize>> = vec![None; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut selected = vec![true; n];
    let rate = params.min_marker_distance_rate as f32;
    for i in 0..n {
        for j in i + 1..n {
            let d = average_distance(&cands[i].corners, &cands[j].corners);
            if d < cands[j].perimeter * rate {
                selected[i] = false;
                selected[j] = false;
                match (group_id[i], group_id[j]) {
                    (None, None) => {
                        group_id[i] = Some(groups.len());
                        group_id[j] = Some(groups.len());
                        groups.push(vec![i, j]);
                    }
                    (Some(g), None) => {
                        group_id[j] = Some(g);
                        groups[g].push(j);
                    }
                    (None, Some(g)) => {
                        group_id[i] = Some(g);
                        groups[g].push(i);
                    }
                    (Some(_), Some(_)) => {}
                }
            }
        }
        if selected[i] {
            selected[i] = false;
            group_id[i] = Some(groups.len());
            groups.push(vec![i]);
        }
    }
    let border = params.min_distance_to_border as f32;
    let cells = (marker_size + 2 * params.marker_border_bits) as f32;
    let module = |c: &Candidate| c.perimeter / (4.0 * cells);
    let mut close: Vec<Vec<Candidate>> = vec![Vec::new(); n];
    for group in &mut groups {
        if params.detect_inverted_marker {
            group.sort_by(|a, b| b.cmp(a));
        } else {
            group.sort();
        }
        let first = group[0];
        let too_near = cands[first].corners.iter().any(|c| {
            c[0] < border
                || c[1] < border
                || c[0] > w as f32 - 1.0 - border
                || c[1] > h as f32 - 1.0 - border
        });
        if too_near {
            continue;
        }
        selected[first] = true;
        let mut current = first;
        for &id in &group[1..] {
            let d = average_distance(&cands[id].corners, &cands[current].corners);
            if d > params.min_group_distance as f32 * module(&cands[id]) {
                current = id;
                close[first].push(cands[id].clone());
            }
        }
    }
    let mut nodes: Vec<Node> = cands
        .into_iter()
        .zip(close)
        .zip(selected)
        .filter(|(_, s)| *s)
        .map(|((candidate, close), _)| Node {
            candidate,
            close,
            parent: None,
            depth: 0,
        })
        .collect();
    // Nesting: a candidate inside a bigger one (every corner inside or on its edge).
    for i in (0..nodes.len()).rev() {
        for j in (0..i).rev() {
            let inner = nodes[i].candidate.corners;
            if inner
                .iter()
                .all(|&p| polygon::inside_or_on(&nodes[j].candidate.corners, p))
            {
                nodes[i].parent = Some(j);
                nodes[j].depth = nodes[j].depth.max(nodes[i].depth + 1);
                break;
            }
        }
    }
    nodes
}

/// Steps 4 and 5: OpenCV's `identifyCandidates`, innermost candidates first.
fn identify(
    gray: &GrayImage,
    mut nodes: Vec<Node>,
    dict: &Dictionary,
    params: &DetectParams,
) -> Vec<Marker> {
    let n = nodes.len();
    if n == 0 {
        return Vec::new();
    }
    let max_depth = nodes.iter().map(|v| v.depth).max().unwrap_or(0);
    let mut by_depth: Vec<Vec<usize>> = vec![Vec::new(); max_depth + 1];
    for (i, v) in nodes.iter().enumerate() {
        by_depth[v.depth].push(i);
    }
    let mut result: Vec<Option<Read>> = vec![None; n];
    let mut rejected: Vec<Option<Rejected>> = vec![None; n];
    let mut was = vec![false; n];
    let mut counter = 0usize;
    let mut depth = 0usize;
    while counter < n && depth <= max_depth {
        let level = &by_depth[depth];
        let found: Vec<_> = level
            .par_iter()
            .map_init(decode::Scratch::default, |scratch, &v| {
                let node = &nodes[v];
                let read = |c: &Candidate, scratch: &mut decode::Scratch| {
                    let kind = CornerKind::ContourPixels;
                    decode::identify_candidate(gray, &c.corners, kind, dict, params, scratch)
                        .map(|m| (m, c.corners))
                };
                read(&node.candidate, scratch).or_else(|rejected| {
                    node.close
                        .iter()
                        .find_map(|c| read(c, scratch).ok())
                        .ok_or(rejected)
                })
            })
            .collect();
        for (&v, f) in level.iter().zip(found) {
            was[v] = true;
            match f {
                Ok(m) => result[v] = Some(m),
                Err(r) => rejected[v] = Some(r),
            }
        }
        for &v in level {
            if result[v].is_some() {
                let mut parent = nodes[v].parent;
                while let Some(p) = parent {
                    if !was[p] {
                        was[p] = true;
                        counter += 1;
                    }
                    parent = nodes[p].parent;
                }
            }
            counter += 1;
        }
        depth += 1;
    }
    reread_small(gray, &nodes, &rejected, &mut result, dict, params);
    nodes.clear();
    result
        .into_iter()
        .flatten()
        .map(|(m, corners)| {
            let r = m.rotation as usize;
            Marker {
                id: m.id,
                corners: std::array::from_fn(|i| {
                    let c = corners[(i + 4 - r) % 4];
                    Point2::new(f64::from(c[0]), f64::from(c[1]))
                }),
            }
        })
        .collect()
}

/// Widest cells (pixels) of a candidate read again on its sub-pixel edges. A contour corner is
/// up to a pixel off the square's corner (pixel quantisation, one grey level of JPEG noise on
/// either side of the threshold): on cells of 4 px or less that shifts the sampled grid by a
/// quarter of a cell or more and spoils the reading; on wider cells it does not, and the
/// refinement's cost is not spent.
const REREAD_MAX_CELL_PX: f32 = 4.0;

/// A second pass after OpenCV's: each small candidate whose border was black but whose bits
/// were no code ([`Rejected::Code`]), though at most a row of cells (`marker_size`) from one,
/// is read again with its corners moved onto the black square's sub-pixel edges ([`refine`]).
/// A grid a pixel off spoils a row or column of cells, not the whole code; the bound keeps
/// away the dark squares with white symbols that scenes are full of (8–12 cells from any code
/// on the shared photos), which would cost a refinement each and could never be read.
/// Candidates inside a marker or around one (its cells, its quiet zone) are left alone, so
/// every marker OpenCV's pass finds stays as it found it; a reread marker keeps its contour
/// corners, as every other marker does.
fn reread_small(
    gray: &GrayImage,
    nodes: &[Node],
    rejected: &[Option<Rejected>],
    result: &mut [Option<Read>],
    dict: &Dictionary,
    params: &DetectParams,
) {
    let ancestors = |v: usize| std::iter::successors(nodes[v].parent, |&p| nodes[p].parent);
    let mut holds_marker = vec![false; nodes.len()];
    for v in (0..nodes.len()).filter(|&v| result[v].is_some()) {
        for p in ancestors(v) {
            holds_marker[p] = true;
        }
    }
    let cells = (dict.marker_size() + 2 * params.marker_border_bits) as f32;
    let again: Vec<usize> = (0..nodes.len())
        .filter(|&v| {
            let Some(Rejected::Code {
                not_black,
                not_white,
            }) = rejected[v]
            else {
                return false;
            };
            nodes[v].candidate.perimeter / (4.0 * cells) <= REREAD_MAX_CELL_PX
                && dict.nearest_distance(not_black, not_white) <= dict.marker_size()
                && !holds_marker[v]
                && !ancestors(v).any(|p| result[p].is_some())
        })
        .collect();
    let read: Vec<_> = again
        .par_iter()
        .map_init(decode::Scratch::default, |scratch, &v| {
            let candidate = &nodes[v].candidate;
            let mut corners = candidate
                .corners
                .map(|c| Point2::new(f64::from(c[0]), f64::from(c[1])));
            refine::refine_corners_with(gray, &mut corners, refine::FOR_READING);
            let edges = corners.map(|c| [c.x as f32, c.y as f32]);
            decode::identify_candidate(gray, &edges, CornerKind::Edges, dict, params, scratch)
                .ok()
                .map(|m| (m, candidate.corners))
        })
        .collect();
    for (v, m) in again.into_iter().zip(read) {
        result[v] = m;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blank_and_tiny_images_give_nothing() {
        let dict = Dictionary::predefined("4x4_50").unwrap();
        let p = DetectParams::default();
        for (w, h, v) in [
            (0, 0, 0u8),
            (1, 1, 0),
            (2, 5, 255),
            (3, 3, 0),
            (64, 48, 128),
            (200, 100, 255),
        ] {
            assert!(detect(&GrayImage::from_pixel(w, h, image::Luma([v])), &dict, &p).is_empty());
        }
    }

    #[test]
    fn window_sizes_are_opencvs() {
        assert_eq!(DetectParams::default().window_sizes(), vec![3, 13, 23]);
    }
}
