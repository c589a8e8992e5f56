//! A camera's roll from the building's straight lines: the rotation about the optical axis that
//! makes the image's straight edges run to the vanishing points of the building's three
//! directions (its Manhattan frame: up and the two horizontal wall directions).
//!
//! Why: pose networks on frozen ImageNet features hardly see roll. On the kitchen's 200
//! held-out photos every network (trained on photos or on renders of the scan) answered with
//! about a fifth of the true roll's spread (slope 0.15–0.34 against a true spread of 8.9°), and
//! roll was half of their rotation error (median 8–9° about the optical axis). Walls, doors and
//! cupboards draw that angle in every frame: with the roll taken from the lines, pan and tilt
//! kept from the network, the photo network's median rotation error fell from 10.8° to 5.7° and
//! the textured render network's from 12.9° to 9.4° (`study synth-to-real`, ARCHITECTURE.md,
//! "Renders of a scan against photos"). Only roll is
//! searched: pan and tilt searched the same way were worse than the networks' (a pitched camera's
//! vertical vanishing point lies far below the image, where a degree of tilt moves it little).
//!
//! Why by hand: no crate finds vanishing points or fits a rotation to them. The edges are the
//! strong gradient pixels (Scharr) whose neighbourhood is one straight edge (structure-tensor coherence),
//! each with the edge's direction from that tensor; a rotation's score sums, over the edges, how
//! well the line through each edge pixel along its direction passes through the nearest of the
//! three vanishing points (`1 - (sin θ / sin θ0)²`, clipped at 0). The roll is searched coarse
//! to fine, the kernel narrowing with the step.
//!
//! The lens is taken as a pinhole: edge pixels are undistorted, their directions are not.

use geom::Camera;
use image::{DynamicImage, GrayImage, imageops::FilterType};
use nalgebra::{Matrix3, Point2, UnitQuaternion, Vector3};

/// Settings of [`LineEdges::detect`] and [`ManhattanFrame::align_roll`].
#[derive(Debug, Clone, PartialEq)]
pub struct LineConfig {
    /// The image is reduced to this width before its edges are found (pixels).
    pub width: u32,
    /// Least gradient magnitude of an edge pixel, on Sobel's scale (a step of height `h` reads
    /// `4h`; the derivative is Scharr's, divided to that scale).
    pub min_gradient: f64,
    /// Half-side of the window whose structure tensor gives an edge's direction (pixels).
    pub window: i32,
    /// Least coherence of that tensor (`((λ1 − λ2) / (λ1 + λ2))²`): 1 for one straight edge.
    pub min_coherence: f64,
    /// Edges kept, the strongest spread evenly over the rest.
    pub max_edges: usize,
    /// Fewest edges with which a roll is estimated at all.
    pub min_edges: usize,
    /// Largest roll correction searched, degrees.
    pub max_roll_deg: f64,
}

impl Default for LineConfig {
    /// 320 pixels wide, gradient 80, 7x7 windows, coherence 0.8, 1500 edges (at least 100),
    /// rolls within ±15°: the settings measured on the kitchen's photos.
    fn default() -> Self {
        LineConfig {
            width: 320,
            min_gradient: 80.0,
            window: 3,
            min_coherence: 0.8,
            max_edges: 1500,
            min_edges: 100,
            max_roll_deg: 15.0,
        }
    }
}

/// One edge pixel: where it is (undistorted pixel of the reduced image), the edge's unit
/// direction, and its weight (gradient magnitude, capped).
#[derive(Debug, Clone, Copy)]
struct Edge {
    x: f64,
    y: f64,
    dx: f64,
    dy: f64,
    weight: f64,
}

/// The straight-edge pixels of one image and the camera they are seen through.
#[derive(Debug, Clone)]
pub struct LineEdges {
    edges: Vec<Edge>,
    /// Intrinsics of the reduced image.
    k: Matrix3<f64>,
}

/// Gradient magnitudes above this weigh as much as it: a few high-contrast edges (a window, a
/// screen) should not outvote the many of the walls and cupboards.
const WEIGHT_CAP: f64 = 400.0;

impl LineEdges {
    /// Finds the straight edges of `image`, seen through `camera` (its size is the image's).
    pub fn detect(image: &DynamicImage, camera: &Camera, cfg: &LineConfig) -> LineEdges {
        let width = cfg.width.min(image.width()).max(1);
        let height = ((u64::from(image.height()) * u64::from(width)) / u64::from(image.width()))
            .max(1) as u32;
        let gray = if width == image.width() {
            image.to_luma8()
        } else {
            image
                .resize_exact(width, height, FilterType::Triangle)
                .to_luma8()
        };
        let small = camera.resized(width, height);
        let mut found = edges_of(&gray, cfg);
        found.sort_by(|a, b| b.weight.total_cmp(&a.weight));
        let step = (found.len() / cfg.max_edges.max(1)).max(1);
        let edges = found
            .into_iter()
            .step_by(step)
            .take(cfg.max_edges)
            .map(|e| {
                let p = small.undistort_pixel(&Point2::new(e.x, e.y));
                Edge {
                    x: p.x,
                    y: p.y,
                    weight: e.weight.min(WEIGHT_CAP),
                    ..e
                }
            })
            .collect();
        LineEdges {
            edges,
            k: Matrix3::new(
                small.fx, 0.0, small.cx, 0.0, small.fy, small.cy, 0.0, 0.0, 1.0,
            ),
        }
    }

    /// Edge pixels found.
    pub fn len(&self) -> usize {
        self.edges.len()
    }

    /// No edge found.
    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }
}

/// Scharr's smoothing weights `[3 10 3]` over Sobel's `[1 2 1]`: the magnitudes keep Sobel's
/// scale (see [`LineConfig::min_gradient`]).
const SCHARR_GAIN: f64 = 4.0;

/// Scharr derivatives (Sobel's pulled the directions of a thin line at 30° two degrees towards
/// the nearest image axis, which biased every roll towards level) and, where the magnitude is
/// large enough, the structure tensor over the window: the pixels whose neighbourhood is one
/// straight edge, with its direction.
fn edges_of(gray: &GrayImage, cfg: &LineConfig) -> Vec<Edge> {
    let (w, h) = (gray.width() as i64, gray.height() as i64);
    let r = i64::from(cfg.window.max(1));
    if w < 2 * r + 3 || h < 2 * r + 3 {
        return Vec::new();
    }
    let px = |x: i64, y: i64| f64::from(gray.as_raw()[(y * w + x) as usize]);
    let mut gx = vec![0.0; (w * h) as usize];
    let mut gy = vec![0.0; (w * h) as usize];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = (y * w + x) as usize;
            gx[i] = (3.0 * px(x + 1, y - 1) + 10.0 * px(x + 1, y) + 3.0 * px(x + 1, y + 1)
                - 3.0 * px(x - 1, y - 1)
                - 10.0 * px(x - 1, y)
                - 3.0 * px(x - 1, y + 1))
                / SCHARR_GAIN;
            gy[i] = (3.0 * px(x - 1, y + 1) + 10.0 * px(x, y + 1) + 3.0 * px(x + 1, y + 1)
                - 3.0 * px(x - 1, y - 1)
                - 10.0 * px(x, y - 1)
                - 3.0 * px(x + 1, y - 1))
                / SCHARR_GAIN;
        }
    }
    let mut out = Vec::new();
    for y in r + 1..h - r - 1 {
        for x in r + 1..w - r - 1 {
            let i = (y * w + x) as usize;
            let magnitude = gx[i].hypot(gy[i]);
            if magnitude <= cfg.min_gradient {
                continue;
            }
            let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
            for yy in y - r..=y + r {
                for xx in x - r..=x + r {
                    let j = (yy * w + xx) as usize;
                    sxx += gx[j] * gx[j];
                    sxy += gx[j] * gy[j];
                    syy += gy[j] * gy[j];
                }
            }
            let trace = sxx + syy;
            let coherence = ((sxx - syy).powi(2) + 4.0 * sxy * sxy) / (trace * trace).max(1e-12);
            if coherence < cfg.min_coherence {
                continue;
            }
            // The dominant gradient direction; the edge runs across it.
            let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
            out.push(Edge {
                x: x as f64,
                y: y as f64,
                dx: -theta.sin(),
                dy: theta.cos(),
                weight: magnitude,
            });
        }
    }
    out
}

/// A building's three directions in its world frame: up and the two horizontal wall
/// directions (the columns of `axes`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManhattanFrame {
    /// World directions of the building's axes, one per column.
    pub axes: Matrix3<f64>,
}

/// A roll taken from the lines.
#[derive(Debug, Clone, Copy)]
pub struct RollFix {
    /// The camera-to-world rotation with its roll from the lines.
    pub rotation: UnitQuaternion<f64>,
    /// The rotation added about the optical axis, degrees.
    pub roll_deg: f64,
    /// Edge pixels that voted.
    pub edges: usize,
}

/// `(half-range, step, kernel)` of the coarse-to-fine search, in units of the largest roll:
/// the whole range in steps of a third of it, then a third of that range in tenths, and so on,
/// each kernel a little wider than its step (at ±15°: steps of 5°, 1.5°, 0.5°, 0.17°).
const LEVELS: [(f64, f64, f64); 4] = [
    (1.0, 1.0 / 3.0, 0.4),
    (1.0 / 3.0, 0.1, 1.0 / 6.0),
    (0.1, 1.0 / 30.0, 0.08),
    (1.0 / 30.0, 1.0 / 90.0, 0.053),
];

impl ManhattanFrame {
    /// The frame with `up` and the horizontal axis at `azimuth_deg` from world x (about `up`,
    /// counter-clockwise seen from above).
    pub fn about(up: Vector3<f64>, azimuth_deg: f64) -> ManhattanFrame {
        let up = up.normalize();
        let seed = if up.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let x0 = (seed - up * up.dot(&seed)).normalize();
        let turn = UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(up),
            azimuth_deg.to_radians(),
        );
        let x = turn * x0;
        let y = up.cross(&x);
        ManhattanFrame {
            axes: Matrix3::from_columns(&[x, y, up]),
        }
    }

    /// The frame about `up` whose horizontal directions best fit the lines of `views` (each
    /// seen with its known camera-to-world rotation): every whole degree of azimuth, then tenths
    /// about the best.
    pub fn fit(up: Vector3<f64>, views: &[(LineEdges, UnitQuaternion<f64>)]) -> ManhattanFrame {
        let total = |azimuth: f64| -> f64 {
            let frame = ManhattanFrame::about(up, azimuth);
            views
                .iter()
                .map(|(e, r)| frame.score(e, r, 2f64.to_radians().sin()))
                .sum()
        };
        let best = |candidates: &mut dyn Iterator<Item = f64>| {
            candidates
                .map(|a| (total(a), a))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .map_or(0.0, |(_, a)| a)
        };
        let coarse = best(&mut (0..90).map(f64::from));
        let fine = best(&mut (-10..=10).map(|k| coarse + 0.1 * f64::from(k)));
        ManhattanFrame::about(up, fine)
    }

    /// How well the edges run to this frame's vanishing points, seen with camera-to-world
    /// `rotation`; `sin0` is the sine of the angle at which an edge stops counting.
    fn score(&self, lines: &LineEdges, rotation: &UnitQuaternion<f64>, sin0: f64) -> f64 {
        let to_camera = rotation.inverse();
        let vanishing: [Vector3<f64>; 3] =
            std::array::from_fn(|a| lines.k * (to_camera * self.axes.column(a).into_owned()));
        lines
            .edges
            .iter()
            .map(|e| {
                let best = vanishing
                    .iter()
                    .filter_map(|v| {
                        // Direction from the edge pixel towards the vanishing point (or along
                        // it, when it lies at infinity).
                        let (lx, ly) = (v.x - e.x * v.z, v.y - e.y * v.z);
                        let norm = lx.hypot(ly);
                        (norm > 1e-12).then(|| {
                            let sin = (e.dx * ly - e.dy * lx).abs() / norm;
                            1.0 - (sin / sin0).powi(2)
                        })
                    })
                    .fold(0.0f64, f64::max);
                e.weight * best
            })
            .sum()
    }

    /// `rotation` (camera to world) turned about its optical axis to where the image's edges
    /// best fit this frame, within [`LineConfig::max_roll_deg`]; `None` with fewer than
    /// [`LineConfig::min_edges`] edges.
    pub fn align_roll(
        &self,
        lines: &LineEdges,
        rotation: &UnitQuaternion<f64>,
        cfg: &LineConfig,
    ) -> Option<RollFix> {
        if lines.len() < cfg.min_edges.max(1) {
            return None;
        }
        let max = cfg.max_roll_deg.to_radians();
        let mut roll = 0.0;
        for (range, step, kernel) in LEVELS {
            let n = (range / step).round() as i32;
            let sin0 = (kernel * max).sin();
            roll = (-n..=n)
                .map(|k| roll + f64::from(k) * step * max)
                .filter(|r: &f64| r.abs() <= max + 1e-12)
                .map(|r| (self.score(lines, &about_axis(rotation, r), sin0), r))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .map_or(roll, |(_, r)| r);
        }
        Some(RollFix {
            rotation: about_axis(rotation, roll),
            roll_deg: roll.to_degrees(),
            edges: lines.len(),
        })
    }
}

/// `rotation` turned by `roll` radians about the camera's optical axis (its z).
fn about_axis(rotation: &UnitQuaternion<f64>, roll: f64) -> UnitQuaternion<f64> {
    rotation * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    fn camera() -> Camera {
        Camera::new(320, 240, 280.0, 280.0, 160.0, 120.0, Default::default()).unwrap()
    }

    /// A box room 6 x 4 x 3 m (its walls along `frame`'s axes) seen from its middle: its edges
    /// and a metre grid on its walls, drawn at four times the size and reduced (antialiased).
    fn room_view(frame: &ManhattanFrame, rotation: &UnitQuaternion<f64>) -> DynamicImage {
        let cam = camera();
        let big = cam.resized(4 * cam.width, 4 * cam.height);
        let mut img = GrayImage::from_pixel(big.width, big.height, Luma([60]));
        let to_world = |p: Vector3<f64>| frame.axes * p;
        let mut segments = Vec::new();
        for x in 0..=6 {
            for y in [0, 4] {
                segments.push(([x, y, 0], [x, y, 3]));
            }
        }
        for y in 0..=4 {
            for x in [0, 6] {
                segments.push(([x, y, 0], [x, y, 3]));
            }
        }
        for z in 0..=3 {
            segments.extend([
                ([0, 0, z], [6, 0, z]),
                ([0, 4, z], [6, 4, z]),
                ([0, 0, z], [0, 4, z]),
                ([6, 0, z], [6, 4, z]),
            ]);
        }
        let point = |p: [i32; 3]| Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
        let eye = to_world(Vector3::new(3.0, 2.0, 1.5));
        for (a, b) in segments {
            let (a, b) = (point(a), point(b));
            for s in 0..8000 {
                let c =
                    rotation.inverse() * (to_world(a + (b - a) * (f64::from(s) / 8000.0)) - eye);
                if c.z < 0.1 {
                    continue;
                }
                let (u, v) = (big.fx * c.x / c.z + big.cx, big.fy * c.y / c.z + big.cy);
                for (du, dv) in [(-1.0, -1.0), (0.0, -1.0), (-1.0, 0.0), (0.0, 0.0)] {
                    let (x, y) = ((u + du + 0.5).floor(), (v + dv + 0.5).floor());
                    if x >= 0.0 && y >= 0.0 && x < f64::from(big.width) && y < f64::from(big.height)
                    {
                        img.put_pixel(x as u32, y as u32, Luma([220]));
                    }
                }
            }
        }
        DynamicImage::ImageLuma8(img).resize_exact(cam.width, cam.height, FilterType::Triangle)
    }

    /// A camera looking along the frame's first axis, pitched down and rolled.
    fn looking(frame: &ManhattanFrame, pan: f64, pitch: f64, roll: f64) -> UnitQuaternion<f64> {
        let (x, y, up) = (
            frame.axes.column(0).into_owned(),
            frame.axes.column(1).into_owned(),
            frame.axes.column(2).into_owned(),
        );
        // OpenCV camera: z forward (along x), x right (along -y), y down (along -up).
        let level = UnitQuaternion::from_rotation_matrix(
            &nalgebra::Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[-y, -up, x])),
        );
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(up), pan.to_radians())
            * level
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll.to_radians())
    }

    #[test]
    fn the_roll_comes_back_from_a_rooms_lines() {
        let frame = ManhattanFrame::about(Vector3::z(), 25.0);
        let cfg = LineConfig::default();
        for (pan, pitch, roll) in [(20.0, -15.0, 7.0), (-35.0, 10.0, -11.0), (60.0, -25.0, 3.0)] {
            let truth = looking(&frame, pan, pitch, roll);
            let lines = LineEdges::detect(&room_view(&frame, &truth), &camera(), &cfg);
            // The network's guess: the roll lost, pan and tilt kept.
            let guess = about_axis(&truth, -roll.to_radians());
            let fix = frame.align_roll(&lines, &guess, &cfg).unwrap();
            let error = fix.rotation.angle_to(&truth).to_degrees();
            assert!(
                error < 0.5,
                "pan {pan} pitch {pitch} roll {roll}: {error}° off"
            );
            assert!((fix.roll_deg - roll).abs() < 0.5);
        }
    }

    #[test]
    fn the_frame_is_fitted_from_posed_views() {
        let frame = ManhattanFrame::about(Vector3::z(), 25.0);
        let cfg = LineConfig::default();
        let views: Vec<_> = [(10.0, -10.0, 2.0), (-40.0, 5.0, -4.0), (80.0, -20.0, 0.0)]
            .iter()
            .map(|&(pan, pitch, roll)| {
                let r = looking(&frame, pan, pitch, roll);
                (
                    LineEdges::detect(&room_view(&frame, &r), &camera(), &cfg),
                    r,
                )
            })
            .collect();
        let fitted = ManhattanFrame::fit(Vector3::z(), &views);
        let x = fitted.axes.column(0);
        let azimuth = x.y.atan2(x.x).to_degrees().rem_euclid(90.0);
        assert!((azimuth - 25.0).abs() < 0.5, "azimuth {azimuth}");
    }

    #[test]
    fn a_blank_image_gives_no_roll() {
        let frame = ManhattanFrame::about(Vector3::z(), 0.0);
        let cfg = LineConfig::default();
        let blank = DynamicImage::ImageLuma8(GrayImage::from_pixel(320, 240, Luma([128])));
        let lines = LineEdges::detect(&blank, &camera(), &cfg);
        assert!(lines.is_empty());
        assert!(
            frame
                .align_roll(&lines, &UnitQuaternion::identity(), &cfg)
                .is_none()
        );
    }
}
