//! Camera trajectories through a [`World`]: natural walks along the walk graph for a hand-held or
//! head-mounted camera ([`Rig::Forward`]) and for an upward-looking robot camera
//! ([`Rig::Ceiling`]), uniform random poses in free space, random poses near a given camera path
//! ([`near_poses`], for scans), and sequences with scene cuts.
//!
//! # How a walk is made
//! 1. A **route** over [`crate::world::WalkGraph`]: a random walk that prefers going straight on,
//!    sometimes turns into a room and comes back out, rarely turns back, and after a while on one
//!    storey heads (by the shortest path, stairs included) for the storey visited least, so that a
//!    long sequence covers every storey of every building it can reach.
//! 2. A **path** through the route's nodes: corners rounded by quadratic Bézier arcs (at most
//!    0.2 m off the edges), dead ends kept sharp (the walker stops and turns round there), and a
//!    smooth lateral drift of at most [`WalkConfig::lateral_m`] (≤ 0.3 m) that fades out near
//!    corners, so the camera never leaves the unobstructed band around the edges.
//! 3. A **walker** simulated at 100 Hz and sampled at [`WalkConfig::fps`]: a pace that varies
//!    smoothly within [`WalkConfig::speed_mps`], braking for corners, stairs and dead ends, a
//!    heading that turns towards a point 1.5 m ahead at a bounded yaw rate (it never snaps), and
//!    walking only while it faces roughly where it goes; random pauses to look around; head bob
//!    and sway at the step frequency for the forward rig.
//!
//! Everything is deterministic per seed: each purpose draws from its own ChaCha8 stream, so adding
//! a draw to one part never changes another.

use crate::error::{Result, SynthError};
use crate::world::{Place, PlaceKind, World};
use geom::{Camera, Mount, Pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

mod near;
mod path;
mod random;
mod route;
mod sim;
#[cfg(test)]
pub(crate) mod test_world;
#[cfg(test)]
mod tests;

pub use near::near_poses;
pub(crate) use route::Graph;

/// How the camera is carried.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rig {
    /// Held in the hand or worn on the head, looking ahead (6-DoF, with head bob).
    Forward {
        /// Range of the camera's height above the floor, metres; each sequence draws one.
        height_m: [f32; 2],
        /// Range of the horizontal field of view, degrees; each sequence draws one
        /// ([`camera_for`]).
        hfov_deg: [f32; 2],
    },
    /// On a robot, looking straight up at the ceiling (3-DoF: x, y, heading).
    Ceiling {
        /// Camera height above the floor, metres.
        height_m: f32,
        /// Horizontal field of view, degrees.
        hfov_deg: f32,
    },
}

impl Default for Rig {
    fn default() -> Self {
        Self::forward()
    }
}

impl Rig {
    /// A person's camera: phone held up or head-mounted, 1.2–1.8 m, 50–70° field of view.
    pub fn forward() -> Self {
        Rig::Forward {
            height_m: [1.2, 1.8],
            hfov_deg: [50.0, 70.0],
        }
    }

    /// A floor robot's camera 0.3 m above the floor, looking up with a 90° lens: a wide view
    /// because the ceiling is only about 2.5 m away and its pattern repeats.
    pub fn ceiling() -> Self {
        Rig::Ceiling {
            height_m: 0.3,
            hfov_deg: 90.0,
        }
    }

    /// Which [`Mount`] the rig's poses use (what "heading" means for them).
    pub fn mount(&self) -> Mount {
        match self {
            Rig::Forward { .. } => Mount::Forward,
            Rig::Ceiling { .. } => Mount::Ceiling,
        }
    }

    /// Range of camera heights above the floor, metres.
    pub fn height_range(&self) -> [f32; 2] {
        match self {
            Rig::Forward { height_m, .. } => *height_m,
            Rig::Ceiling { height_m, .. } => [*height_m, *height_m],
        }
    }

    fn validate(&self) -> Result<()> {
        let [h0, h1] = self.height_range();
        let [f0, f1] = match self {
            Rig::Forward { hfov_deg, .. } => *hfov_deg,
            Rig::Ceiling { hfov_deg, .. } => [*hfov_deg, *hfov_deg],
        };
        if !(h0.is_finite() && h1.is_finite() && h0 > 0.0 && h0 <= h1) {
            return Err(config(format!(
                "camera height range [{h0}, {h1}] m must be positive and ordered"
            )));
        }
        if !(f0.is_finite() && f1.is_finite() && f0 > 1.0 && f0 <= f1 && f1 < 179.0) {
            return Err(config(format!(
                "field of view range [{f0}, {f1}]° must be ordered and within (1°, 179°)"
            )));
        }
        Ok(())
    }
}

/// The lowest walk frame rate: a frame every 10 s. A walk plans its path step by step, so a
/// rate of 1e-6 (a frame every 11 days of walking) took minutes per frame, and 1e-300 never
/// finished.
pub const MIN_FPS: f64 = 0.1;
/// The highest walk frame rate.
pub const MAX_FPS: f64 = 1000.0;

/// How a walk moves. [`WalkConfig::default`] is the forward rig's; [`WalkConfig::for_rig`] picks
/// the defaults that suit a rig.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WalkConfig {
    /// How the camera is carried.
    pub rig: Rig,
    /// Frames per second: 10 for a person (enough for temporal models, few near-duplicates at
    /// walking speed), 5 for the slower robot.
    pub fps: f64,
    /// Range of walking speed, m/s; the pace wanders smoothly inside it.
    pub speed_mps: [f32; 2],
    /// Chance per second of walking that the walker stops (to look around, or the robot to wait).
    pub pause_probability: f32,
    /// Range of a pause's length, seconds.
    pub pause_s: [f32; 2],
    /// Vertical head-bob amplitude (half peak-to-peak), metres; the forward rig only. Roll and
    /// pitch sway and a 1 cm side-to-side sway scale with it.
    pub head_bob_m: f32,
    /// Largest yaw rate, degrees per second (a person turns at up to about 90°/s while walking).
    pub turn_rate_deg_s: f32,
    /// Largest sideways drift from the graph's edges, metres (capped at 0.3 m: edges are only
    /// promised to be unobstructed along their line).
    pub lateral_m: f32,
    /// Chance of turning into a room when passing its door.
    pub room_probability: f32,
    /// Range of distance walked on one storey before heading for the least-visited storey,
    /// metres.
    pub storey_dwell_m: [f32; 2],
}

impl Default for WalkConfig {
    fn default() -> Self {
        Self::for_rig(Rig::forward())
    }
}

impl WalkConfig {
    /// Sensible defaults for a rig: a person walks at 0.5–1.5 m/s with pauses and head bob at
    /// 10 Hz; a robot drives at 0.4–1.0 m/s, turns at 45°/s, keeps closer to the centre line, and
    /// is sampled at 5 Hz.
    pub fn for_rig(rig: Rig) -> Self {
        match rig {
            Rig::Forward { .. } => Self {
                rig,
                fps: 10.0,
                speed_mps: [0.5, 1.5],
                pause_probability: 0.03,
                pause_s: [1.5, 5.0],
                head_bob_m: 0.015,
                turn_rate_deg_s: 90.0,
                lateral_m: 0.2,
                room_probability: 0.12,
                storey_dwell_m: [60.0, 150.0],
            },
            Rig::Ceiling { .. } => Self {
                rig,
                fps: 5.0,
                speed_mps: [0.4, 1.0],
                pause_probability: 0.01,
                pause_s: [1.0, 3.0],
                head_bob_m: 0.0,
                turn_rate_deg_s: 45.0,
                lateral_m: 0.1,
                room_probability: 0.12,
                storey_dwell_m: [60.0, 150.0],
            },
        }
    }

    fn validate(&self) -> Result<()> {
        self.rig.validate()?;
        let [v0, v1] = self.speed_mps;
        let [p0, p1] = self.pause_s;
        let [d0, d1] = self.storey_dwell_m;
        let checks: [(bool, String); 8] = [
            (
                self.fps.is_finite() && (MIN_FPS..=MAX_FPS).contains(&self.fps),
                format!(
                    "fps {} must be in [{MIN_FPS}, {MAX_FPS}] (a frame at most every {} s)",
                    self.fps,
                    1.0 / MIN_FPS
                ),
            ),
            (
                v0.is_finite() && v1.is_finite() && v0 > 0.0 && v0 <= v1 && v1 <= 10.0,
                format!("speed range [{v0}, {v1}] m/s must be positive, ordered, at most 10"),
            ),
            (
                self.pause_probability.is_finite() && self.pause_probability >= 0.0,
                format!(
                    "pause probability {} must be non-negative",
                    self.pause_probability
                ),
            ),
            (
                p0.is_finite() && p1.is_finite() && p0 >= 0.0 && p0 <= p1,
                format!("pause length range [{p0}, {p1}] s must be non-negative and ordered"),
            ),
            (
                self.head_bob_m.is_finite() && (0.0..=0.1).contains(&self.head_bob_m),
                format!("head bob {} m must be in [0, 0.1]", self.head_bob_m),
            ),
            (
                self.turn_rate_deg_s.is_finite() && self.turn_rate_deg_s >= 5.0,
                format!("turn rate {}°/s must be at least 5", self.turn_rate_deg_s),
            ),
            (
                self.lateral_m.is_finite()
                    && self.lateral_m >= 0.0
                    && self.room_probability.is_finite()
                    && (0.0..=1.0).contains(&self.room_probability),
                format!(
                    "lateral drift {} m must be non-negative and room probability {} in [0, 1]",
                    self.lateral_m, self.room_probability
                ),
            ),
            (
                d0.is_finite() && d1.is_finite() && d0 > 0.0 && d0 <= d1,
                format!("storey dwell range [{d0}, {d1}] m must be positive and ordered"),
            ),
        ];
        match checks.into_iter().find(|(ok, _)| !ok) {
            Some((_, msg)) => Err(config(msg)),
            None => Ok(()),
        }
    }
}

/// Which way the camera faces in a corridor, relative to the corridor's `axis`: a label that can
/// be learned from the image, because the view down a corridor differs by direction, and a view
/// of one of its walls differs from both.
///
/// Why three and not two: a walker who turns to a door faces the corridor's wall square on, and a
/// two-way label would then hang on a degree or two of head sway. In the study's held-out walks,
/// building 0's frames within 7.5° of square on were labelled against the answer smoothed
/// along the walk in over a third of cases (a coin toss the image cannot settle), and frames
/// within 22.5° of square on made about 60 % of the direction errors left. Split at 45°, the
/// boundaries fall where walkers seldom look.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Facing along the axis, within 45° (`cos(heading − axis) > cos 45°`).
    Forward,
    /// Facing against the axis, within 45°.
    Backward,
    /// Facing one of the corridor's walls, more across it than along.
    Across,
}

impl Direction {
    /// The label as written to `labels.csv`: `fwd`, `back` or `across`.
    pub fn name(&self) -> &'static str {
        match self {
            Direction::Forward => "fwd",
            Direction::Backward => "back",
            Direction::Across => "across",
        }
    }
}

/// The direction label of a camera with 3-DoF `heading` (radians, as in
/// [`geom::Pose::to_pose3`]) at `place`: `None` outside corridors or where the corridor has no
/// axis.
pub fn direction_of(place: &Place, heading: f64) -> Option<Direction> {
    if place.kind != PlaceKind::Corridor {
        return None;
    }
    let along = (heading - f64::from(place.axis?)).cos();
    Some(if along > std::f64::consts::FRAC_1_SQRT_2 {
        Direction::Forward
    } else if along < -std::f64::consts::FRAC_1_SQRT_2 {
        Direction::Backward
    } else {
        Direction::Across
    })
}

/// One frame of a trajectory with its labels.
#[derive(Clone, Debug, PartialEq)]
pub struct PosedFrame {
    /// Time, seconds from the start of the sequence (for [`random_poses`], the frame index).
    pub t: f64,
    /// Camera-to-world pose, OpenCV camera axes.
    pub pose: Pose,
    /// The place the camera is in; `None` only where no region covers it and the walk graph
    /// gives none either.
    pub place: Option<Place>,
    /// Which way the camera faces along a corridor (by its 3-DoF heading); `None` elsewhere.
    pub direction: Option<Direction>,
}

/// A natural walk of `frames` frames through the world's walk graph (see the module docs).
///
/// Errors: [`SynthError::Config`] for `frames == 0`, an empty walk graph (no nodes or no edges),
/// an edge naming a missing node, or a setting out of range.
pub fn walk(world: &World, cfg: &WalkConfig, frames: usize, seed: u64) -> Result<Vec<PosedFrame>> {
    cfg.validate()?;
    if frames == 0 {
        return Err(config("a walk needs at least one frame".into()));
    }
    let graph = Graph::new(world)?;
    let start = graph.random_start(&mut rng(seed, stream::START));
    sim::simulate(world, &graph, cfg, frames, seed, start, 0.0)
}

/// `n` poses drawn uniformly from the world's free space: a region picked with probability
/// proportional to its floor area, a point inside it (0.3 m from its sides where it is wide
/// enough) kept clear of the building's triangles by 0.2 m, a camera height from the rig, a
/// uniform heading, and for the forward rig a small pitch (σ 4°, within ±12°) and roll (σ 2°).
///
/// Errors: [`SynthError::Config`] for `n == 0`, a world without regions of positive area, or a
/// rig out of range.
pub fn random_poses(world: &World, rig: &Rig, n: usize, seed: u64) -> Result<Vec<PosedFrame>> {
    rig.validate()?;
    if n == 0 {
        return Err(config("random poses: need at least one pose".into()));
    }
    random::sample(world, rig, n, seed)
}

/// A sequence of `segments` walks in different places joined without transition, as an edited
/// video would be: the gold data for scene-cut detection.
///
/// Each segment is a [`walk`] of a length drawn from `frames_per_segment` (inclusive range) that
/// starts at a node away from where the previous segment ended: on another storey or building,
/// or more than 8 m away in another region (falling back to more than 3 m on small worlds). Time
/// runs on uniformly across cuts. Returns the frames and the cut indices: the first frame of
/// every segment after the first.
///
/// Errors: as [`walk`], and for `segments == 0`, an empty or reversed `frames_per_segment`, or a
/// world too small to jump at least 3 m.
pub fn with_cuts(
    world: &World,
    cfg: &WalkConfig,
    segments: usize,
    frames_per_segment: [usize; 2],
    seed: u64,
) -> Result<(Vec<PosedFrame>, Vec<usize>)> {
    cfg.validate()?;
    let [lo, hi] = frames_per_segment;
    if segments == 0 || lo == 0 || lo > hi {
        return Err(config(format!(
            "scene cuts need at least one segment and a frame range 1 ≤ lo ≤ hi, got {segments} \
             segments of [{lo}, {hi}] frames"
        )));
    }
    let graph = Graph::new(world)?;
    let mut r = rng(seed, stream::CUTS);
    let mut frames: Vec<PosedFrame> = Vec::new();
    let mut cuts = Vec::new();
    for k in 0..segments {
        let len = lo + uniform_index(&mut r, hi - lo + 1);
        let start = match frames.last() {
            None => graph.random_start(&mut r),
            Some(last) => {
                cuts.push(frames.len());
                graph.far_start(&last.pose, last.place.as_ref(), &mut r)?
            }
        };
        let seg_seed = seed ^ (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let t0 = frames.len() as f64 / cfg.fps;
        frames.extend(sim::simulate(world, &graph, cfg, len, seg_seed, start, t0)?);
    }
    Ok((frames, cuts))
}

/// A camera for a sequence of `rig`: a pinhole of `width` x `height` pixels whose horizontal
/// field of view is drawn from the rig's range (fixed for the ceiling rig), so a dataset of many
/// sequences covers the range of phones and lenses.
///
/// Errors: a zero image size or a field of view out of range.
pub fn camera_for(rig: &Rig, width: u32, height: u32, seed: u64) -> Result<Camera> {
    rig.validate()?;
    let hfov = match rig {
        Rig::Forward { hfov_deg, .. } => {
            let mut r = rng(seed, stream::CAMERA);
            uniform(&mut r, f64::from(hfov_deg[0]), f64::from(hfov_deg[1]))
        }
        Rig::Ceiling { hfov_deg, .. } => f64::from(*hfov_deg),
    };
    Ok(Camera::from_hfov(width, height, hfov.to_radians())?)
}

/// The ChaCha8 streams of each purpose, so that draws for one never shift another's.
pub(crate) mod stream {
    /// Start node of a walk.
    pub const START: u64 = 1;
    /// The route over the graph.
    pub const ROUTE: u64 = 2;
    /// The walker's person: height, pace, lateral drift, pauses.
    pub const WALKER: u64 = 3;
    /// Random poses.
    pub const RANDOM: u64 = 4;
    /// Scene-cut segments.
    pub const CUTS: u64 = 5;
    /// Camera intrinsics.
    pub const CAMERA: u64 = 6;
    /// Light switching of variants.
    pub const LIGHTS: u64 = 7;
    /// Colour changes of variants.
    pub const COLOURS: u64 = 8;
    /// Crowds of people.
    pub const CROWD: u64 = 9;
    /// Poses near a given path.
    pub const NEAR: u64 = 10;
}

/// A ChaCha8 generator for `seed` on its own `stream`.
pub(crate) fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// Uniform in `[lo, hi)`; `lo` when the range is empty (never panics, unlike `random_range`).
pub(crate) fn uniform(r: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * r.random::<f64>()
}

/// Uniform index in `0..n`; 0 for `n == 0`.
pub(crate) fn uniform_index(r: &mut impl Rng, n: usize) -> usize {
    if n == 0 {
        0
    } else {
        ((r.random::<f64>() * n as f64) as usize).min(n - 1)
    }
}

/// An index drawn with probability proportional to its weight; `None` when no weight is
/// positive.
pub(crate) fn pick_weighted(r: &mut impl Rng, weights: &[f64]) -> Option<usize> {
    let total: f64 = weights.iter().filter(|w| **w > 0.0).sum();
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    let mut x = r.random::<f64>() * total;
    let mut last = None;
    for (i, &w) in weights.iter().enumerate() {
        if w > 0.0 {
            last = Some(i);
            if x < w {
                return Some(i);
            }
            x -= w;
        }
    }
    last
}

/// How a crowd's people choose their way: along corridors, seldom into a room, rarely up or
/// down stairs (they stay on their storey, where the walker will meet them).
pub(crate) fn route_style_for_people() -> route::RouteStyle {
    route::RouteStyle {
        room_probability: 0.05,
        storey_dwell_m: None,
    }
}

pub(crate) fn config(msg: String) -> SynthError {
    SynthError::Config(msg)
}
