//! The streaming visual-rhythm detector: one path column per frame, the difference between
//! consecutive columns as a time series, a low-passed baseline of that series, and an adaptive
//! threshold on the ratio between the two.
//!
//! Written by hand: the visual-rhythm method is a few hundred lines of arithmetic on small
//! buffers, and no crate implements it (PySceneDetect is Python; its detectors compare HSV means
//! of whole frames, which miss a cut inside one static camera's view).
//!
//! # The decision for frame `t`
//! - `score(t)`: mean absolute difference (grey levels, 0–255) of the path's RGB samples between
//!   frames `t - 1` and `t`, each column first brought to zero mean and a common contrast per
//!   channel: the difference of two neighbouring columns of the visual rhythm, blind to a change
//!   of overall brightness (a lamp flickering, auto-exposure, turning from a lit wall to a
//!   shaded one), which moves no camera. Gradual transitions, which are brightness changes, use
//!   the plain difference. Where the whole picture moved (a fast turn), the previous frame is
//!   first moved back by that shift ([`crate::motion`]) and the smaller of the two differences
//!   counts.
//! - `baseline(t)`: the median of `score` over the `window` frames before and after `t` (not `t`
//!   itself): a low-pass of the series that a single spike cannot move, but sustained motion
//!   (a camera pan, a hand sweeping through the view) raises.
//! - A hard cut when `score ≥ ratio · (baseline + 1)` and `score − baseline ≥ min_jump`: the
//!   frame stands out from its neighbourhood, by a factor and by an absolute margin (the `+ 1`
//!   grey level is the noise floor that keeps still, dark shots from dividing by zero). A score
//!   of at least `strong` needs only `strong_ratio`: a cut in the middle of a fast turn, whose
//!   neighbours already differ a lot.
//! - Not a cut when the content comes back within a few frames (a flash, a lamp flickering, a
//!   dropped frame shown twice): a column of the 3 frames before `t` and one of the 3 frames from
//!   `t` on differ by less than `flash · score`.
//! - Not a cut within `min_gap` frames after the previous one.
//!
//! The decision for `t` waits for frames up to `t + window`: the detector's latency. Memory is
//! `2 · window + 1` columns and one thumbnail whatever the length of the input.
//!
//! # Gradual transitions
//! Fades and dissolves change every pixel a little per frame, in one direction. A run of frames
//! whose score stays above `gradual.min_step` is a candidate; it is a transition when each path
//! pixel's net change over the run is nearly its total variation (`monotonicity ≥
//! gradual.min_monotonic`: motion goes back and forth, fades do not) and the mean net change is
//! at least `gradual.min_change` grey levels. Its kind comes from the ends: a uniform (dark,
//! white or flat) frame at the start makes a fade-in, at the end a fade-out, at neither a
//! dissolve. A hard cut ends a run. Memory stays constant: per path pixel the run keeps its
//! starting value and the running variation.

use crate::error::{CutError, Result};
use crate::motion::Profiles;
use crate::path::{PathKind, pixel_indices};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The noise floor added to the baseline in the ratio test, grey levels.
const NOISE_FLOOR: f32 = 1.0;

/// Longest flash, frames: the flash test compares this many frames on each side of a candidate.
const FLASH_FRAMES: usize = 3;

/// Settings of the gradual-transition detector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GradualConfig {
    /// A frame belongs to a candidate run when its score is at least this, grey levels.
    pub min_step: f32,
    /// Shortest transition, frames.
    pub min_len: u64,
    /// Least ratio of net change to total variation over the run (1 = perfectly monotonic).
    pub min_monotonic: f32,
    /// Least mean net change of the path over the run, grey levels.
    pub min_change: f32,
    /// A frame whose path has a standard deviation below this (grey levels) is uniform: the
    /// black, white or flat end of a fade.
    pub uniform_std: f32,
}

impl Default for GradualConfig {
    fn default() -> Self {
        GradualConfig {
            min_step: 1.0,
            min_len: 4,
            min_monotonic: 0.8,
            min_change: 20.0,
            uniform_std: 12.0,
        }
    }
}

/// Settings of the detector. The defaults were chosen on the real clips in
/// `../shared/data/scenecut_*` (see the crate's tests) and hold for rendered walks.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// Width of the thumbnail each frame is shrunk to (area averaging) before sampling the
    /// path; the height keeps the frame's aspect ratio.
    pub thumb_width: u32,
    /// The pixel path.
    pub path: PathKind,
    /// Frames on each side of `t` in the baseline (and the detector's latency), at least 1.
    pub window: usize,
    /// Least `score / (baseline + 1)` of a hard cut.
    pub ratio: f32,
    /// Least `score − baseline` of a hard cut, grey levels.
    pub min_jump: f32,
    /// A score this high (grey levels) needs only `strong_ratio` instead of `ratio`: a cut
    /// during fast camera motion, whose neighbours already differ a lot.
    pub strong: f32,
    /// Least `score / (baseline + 1)` of a strong score.
    pub strong_ratio: f32,
    /// Least frames between two hard cuts.
    pub min_gap: u64,
    /// A frame is a flash, not a cut, when frames before and after it differ by less than this
    /// fraction of its score.
    pub flash: f32,
    /// Gradual transitions, or `None` to look for hard cuts only.
    pub gradual: Option<GradualConfig>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            thumb_width: 64,
            path: PathKind::default(),
            window: 3,
            ratio: 3.0,
            min_jump: 5.0,
            strong: 30.0,
            strong_ratio: 2.0,
            min_gap: 5,
            flash: 0.5,
            gradual: Some(GradualConfig::default()),
        }
    }
}

impl Config {
    /// Checks every setting; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |msg: &str| Err(CutError::Config(msg.into()));
        if !(8..=1024).contains(&self.thumb_width) {
            return bad("thumbnail width must be 8 to 1024 pixels");
        }
        if !(1..=100).contains(&self.window) {
            return bad("window must be 1 to 100 frames");
        }
        if !(self.ratio.is_finite() && self.ratio >= 1.0) {
            return bad("ratio must be a number ≥ 1");
        }
        if !(self.min_jump.is_finite() && self.min_jump >= 0.0) {
            return bad("min_jump must be a number ≥ 0");
        }
        if !(self.strong.is_finite() && self.strong >= 0.0) {
            return bad("strong must be a number ≥ 0");
        }
        if !(self.strong_ratio.is_finite() && (1.0..=self.ratio).contains(&self.strong_ratio)) {
            return bad("strong_ratio must be between 1 and ratio");
        }
        if !(self.flash.is_finite() && (0.0..=1.0).contains(&self.flash)) {
            return bad("flash must be between 0 and 1");
        }
        if let Some(g) = self.gradual {
            let finite = [g.min_step, g.min_monotonic, g.min_change, g.uniform_std];
            if finite.iter().any(|v| !v.is_finite() || *v < 0.0) || g.min_len < 2 {
                return bad("gradual settings must be finite, ≥ 0, and min_len ≥ 2");
            }
        }
        Ok(())
    }

    /// The least score of a hard cut where the baseline is `baseline`.
    pub fn threshold(&self, baseline: f32) -> f32 {
        let level = baseline + NOISE_FLOOR;
        let adaptive = self.ratio * level;
        let strong = self.strong.max(self.strong_ratio * level);
        adaptive.min(strong).max(baseline + self.min_jump)
    }

    /// The thumbnail size for frames of `width` x `height`.
    pub fn thumb_size(&self, width: u32, height: u32) -> (u32, u32) {
        let w = self.thumb_width.min(width.max(1));
        let h = (f64::from(height) * f64::from(w) / f64::from(width.max(1))).round() as u32;
        (w, h.max(1))
    }
}

/// A hard cut: `frame` is the first frame of the new scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cut {
    /// First frame of the new scene.
    pub frame: u64,
    /// Its score (grey levels).
    pub score: f32,
    /// The baseline around it (grey levels).
    pub baseline: f32,
}

/// What kind of gradual transition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransitionKind {
    /// From a uniform frame (black, white) to a picture.
    FadeIn,
    /// From a picture to a uniform frame.
    FadeOut,
    /// From one uniform frame to another (a ramp of brightness).
    Fade,
    /// From one picture to another.
    Dissolve,
}

/// A gradual transition over frames `first..=last`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gradual {
    /// First frame that differs from the steady shot before.
    pub first: u64,
    /// Last frame that still changes.
    pub last: u64,
    /// Fade in, fade out, fade, dissolve.
    pub kind: TransitionKind,
    /// Net change over total variation (1 = monotonic).
    pub monotonicity: f32,
    /// Mean net change of the path over the transition, grey levels.
    pub change: f32,
}

/// Something the detector found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Event {
    /// A hard cut.
    Cut(Cut),
    /// A fade or dissolve.
    Gradual(Gradual),
}

/// Per-frame figures for plots: the series the decision looked at.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// Frame index of each entry.
    pub frames: Vec<u64>,
    /// Score (grey levels); `NaN` for a source's first frame.
    pub score: Vec<f32>,
    /// Baseline (grey levels).
    pub baseline: Vec<f32>,
    /// The score a hard cut needed at that frame.
    pub threshold: Vec<f32>,
}

/// One frame waiting for its decision.
struct Entry {
    index: u64,
    column: Vec<u8>,
    /// Per-channel mean and standard deviation of the column.
    stats: ColumnStats,
    /// Brightness-blind difference to the previous frame (`None` for the first frame).
    score: Option<f32>,
    /// Plain difference to the previous frame (`None` for the first frame).
    step: Option<f32>,
    decided: bool,
}

/// A candidate gradual transition in progress.
struct Run {
    first: u64,
    last: u64,
    start: Vec<u8>,
    end: Vec<u8>,
    variation: Vec<u32>,
}

/// The streaming detector: [`push`](Detector::push) each frame's thumbnail in order, collect the
/// events, and call [`finish`](Detector::finish) at the end of the input.
pub struct Detector {
    cfg: Config,
    size: (u32, u32),
    path: Vec<u32>,
    /// The previous frame's thumbnail and profiles, for the motion-compensated score.
    prev: Option<(Vec<u8>, Profiles)>,
    /// Scratch buffers of the shifted comparison.
    shifted: (Vec<u8>, Vec<u8>),
    entries: VecDeque<Entry>,
    spare: Vec<Vec<u8>>,
    /// Scratch buffer of the neighbours' scores (the decision runs once per frame).
    neighbours: Vec<f32>,
    last_cut: Option<u64>,
    run: Option<Run>,
    trace: Option<Trace>,
}

impl Detector {
    /// A detector for thumbnails of `width` x `height` (see [`Config::thumb_size`]).
    ///
    /// # Errors
    /// A bad setting or an empty thumbnail.
    pub fn new(cfg: Config, width: u32, height: u32) -> Result<Detector> {
        cfg.validate()?;
        let path = pixel_indices(cfg.path, width, height)?;
        Ok(Detector {
            cfg,
            size: (width, height),
            path,
            prev: None,
            shifted: (Vec::new(), Vec::new()),
            entries: VecDeque::with_capacity(2 * cfg.window + 2),
            spare: Vec::new(),
            neighbours: Vec::with_capacity(2 * cfg.window),
            last_cut: None,
            run: None,
            trace: None,
        })
    }

    /// Also records the per-frame series ([`Trace`]) for a plot: 16 bytes per frame.
    pub fn with_trace(mut self) -> Detector {
        self.trace = Some(Trace::default());
        self
    }

    /// The recorded series, when [`with_trace`](Self::with_trace) asked for it.
    pub fn trace(&self) -> Option<&Trace> {
        self.trace.as_ref()
    }

    /// The settings.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Number of samples (path pixels) per frame.
    pub fn path_len(&self) -> usize {
        self.path.len()
    }

    /// Feeds frame `index` (increasing; gaps allowed where frames were unreadable) as an RGB
    /// thumbnail (`3 · width · height` bytes, rows without padding). Returns the events decided
    /// by this frame; they trail the input by `window` frames.
    ///
    /// # Errors
    /// A buffer of the wrong size, or an index not after the previous one.
    pub fn push(&mut self, index: u64, rgb: &[u8]) -> Result<Vec<Event>> {
        let (w, h) = self.size;
        let want = 3 * w as usize * h as usize;
        if rgb.len() != want {
            return Err(CutError::Frame {
                frame: index,
                msg: format!(
                    "thumbnail has {} bytes, the detector expects {want} ({w}x{h} RGB)",
                    rgb.len()
                ),
            });
        }
        if let Some(prev) = self.entries.back()
            && index <= prev.index
        {
            return Err(CutError::Frame {
                frame: index,
                msg: format!("frames must come in order (previous was {})", prev.index),
            });
        }
        let mut column = self.spare.pop().unwrap_or_default();
        column.clear();
        column.reserve(3 * self.path.len());
        for &i in &self.path {
            let o = 3 * i as usize;
            column.extend_from_slice(&rgb[o..o + 3]);
        }
        let stats = ColumnStats::of(&column);
        let profiles = Profiles::of(rgb, w as usize, h as usize);
        let moved = self.moved_score(rgb, &profiles);
        let (score, step) = match self.entries.back() {
            Some(prev) => {
                let still = normalised_diff(&prev.column, prev.stats, &column, stats);
                (
                    Some(moved.map_or(still, |m| still.min(m))),
                    Some(mean_abs_diff(&prev.column, &column)),
                )
            }
            None => (None, None),
        };
        let mut keep = self.prev.take().map(|(buf, _)| buf).unwrap_or_default();
        keep.clear();
        keep.extend_from_slice(rgb);
        self.prev = Some((keep, profiles));
        self.entries.push_back(Entry {
            index,
            column,
            stats,
            score,
            step,
            decided: false,
        });
        let mut events = Vec::new();
        let k = self.cfg.window;
        if self.entries.len() > k {
            self.decide(self.entries.len() - 1 - k, &mut events);
        }
        // Keep `window` decided frames before the next one to decide.
        while self.entries.len() > 2 * k + 1 {
            if let Some(old) = self.entries.pop_front() {
                self.spare.push(old.column);
            }
        }
        Ok(events)
    }

    /// The score against the previous frame moved by the picture's overall shift (`None`
    /// without a previous frame or when the picture did not move).
    fn moved_score(&mut self, rgb: &[u8], profiles: &Profiles) -> Option<f32> {
        let (prev_rgb, prev_profiles) = self.prev.as_ref()?;
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        let (dx, dy) = profiles.shift_from(prev_profiles, (w / 12).max(1), (h / 12).max(1));
        if (dx, dy) == (0, 0) {
            return None;
        }
        let (cur, old) = &mut self.shifted;
        cur.clear();
        old.clear();
        for &i in &self.path {
            let (x, y) = ((i % w as u32) as i32, (i / w as u32) as i32);
            let (px, py) = (x + dx, y + dy);
            if px < 0 || py < 0 || px >= w || py >= h {
                continue;
            }
            let (a, b) = (3 * i as usize, 3 * (py * w + px) as usize);
            cur.extend_from_slice(&rgb[a..a + 3]);
            old.extend_from_slice(&prev_rgb[b..b + 3]);
        }
        if cur.len() < 3 * self.path.len() / 2 {
            return None;
        }
        Some(normalised_diff(
            old,
            ColumnStats::of(old),
            cur,
            ColumnStats::of(cur),
        ))
    }

    /// Decides the frames still waiting (with the frames that exist after them) and closes a
    /// transition in progress. The detector is then empty and ready for a new input.
    pub fn finish(&mut self) -> Vec<Event> {
        let mut events = Vec::new();
        for at in 0..self.entries.len() {
            if !self.entries[at].decided {
                self.decide(at, &mut events);
            }
        }
        self.end_run(&mut events);
        self.entries.clear();
        self.prev = None;
        self.last_cut = None;
        events
    }

    /// Decides entry `at`: hard cut or not, then the gradual run.
    fn decide(&mut self, at: usize, events: &mut Vec<Event>) {
        self.entries[at].decided = true;
        let index = self.entries[at].index;
        let Some(score) = self.entries[at].score else {
            self.record(index, f32::NAN, 0.0, f32::NAN);
            return;
        };
        let k = self.cfg.window;
        let lo = at.saturating_sub(k);
        let hi = (at + 1 + k).min(self.entries.len());
        self.neighbours.clear();
        self.neighbours.extend(
            (lo..hi)
                .filter(|&i| i != at)
                .filter_map(|i| self.entries[i].score),
        );
        let baseline = median(&mut self.neighbours);
        let threshold = self.cfg.threshold(baseline);
        self.record(index, score, baseline, threshold);
        let spaced = self.last_cut.is_none_or(|c| index - c >= self.cfg.min_gap);
        let is_cut = score >= threshold && spaced && !self.is_flash(at, score);
        if is_cut {
            self.last_cut = Some(index);
            self.end_run(events);
            events.push(Event::Cut(Cut {
                frame: index,
                score,
                baseline,
            }));
        } else {
            let step = self.entries[at].step.unwrap_or(0.0);
            self.follow_run(at, step, events);
        }
    }

    /// Whether the content on both sides of `at` is the same: some frame of the
    /// [`FLASH_FRAMES`] before `at` looks like some frame of the [`FLASH_FRAMES`] from `at`
    /// on. A flash (or a lamp flickering for a frame or two) changes the picture and then
    /// gives it back; a cut does not. The same test rejects both edges of the flash.
    fn is_flash(&self, at: usize, score: f32) -> bool {
        let span = FLASH_FRAMES.min(self.cfg.window);
        let before = self.entries.range(at.saturating_sub(span)..at);
        let after: Vec<&Entry> = self
            .entries
            .range(at..(at + span).min(self.entries.len()))
            .collect();
        let limit = self.cfg.flash * score;
        before.into_iter().any(|b| {
            after
                .iter()
                .any(|a| normalised_diff(&b.column, b.stats, &a.column, a.stats) < limit)
        })
    }

    fn record(&mut self, index: u64, score: f32, baseline: f32, threshold: f32) {
        if let Some(t) = &mut self.trace {
            t.frames.push(index);
            t.score.push(score);
            t.baseline.push(baseline);
            t.threshold.push(threshold);
        }
    }

    /// Extends, starts or ends the candidate gradual run with the (non-cut) frame `at`, whose
    /// plain difference to the frame before is `step`.
    fn follow_run(&mut self, at: usize, step: f32, events: &mut Vec<Event>) {
        let Some(g) = self.cfg.gradual else {
            return;
        };
        if step < g.min_step || at == 0 {
            self.end_run(events);
            return;
        }
        let (prev, cur) = (&self.entries[at - 1], &self.entries[at]);
        let run = self.run.get_or_insert_with(|| Run {
            first: cur.index,
            last: cur.index,
            start: prev.column.clone(),
            end: Vec::new(),
            variation: vec![0; prev.column.len()],
        });
        for ((v, &a), &b) in run.variation.iter_mut().zip(&prev.column).zip(&cur.column) {
            *v += u32::from(a.abs_diff(b));
        }
        run.last = cur.index;
        run.end.clear();
        run.end.extend_from_slice(&cur.column);
    }

    /// Closes the run in progress; a transition event when it qualifies.
    fn end_run(&mut self, events: &mut Vec<Event>) {
        let (Some(run), Some(g)) = (self.run.take(), self.cfg.gradual) else {
            return;
        };
        if run.last - run.first + 1 < g.min_len {
            return;
        }
        let net: u64 = run
            .start
            .iter()
            .zip(&run.end)
            .map(|(&a, &b)| u64::from(a.abs_diff(b)))
            .sum();
        let total: u64 = run.variation.iter().map(|&v| u64::from(v)).sum();
        if total == 0 {
            return;
        }
        let monotonicity = net as f32 / total as f32;
        let change = net as f32 / run.start.len().max(1) as f32;
        if monotonicity < g.min_monotonic || change < g.min_change {
            return;
        }
        let kind = match (
            std_dev(&run.start) < g.uniform_std,
            std_dev(&run.end) < g.uniform_std,
        ) {
            (true, true) => TransitionKind::Fade,
            (true, false) => TransitionKind::FadeIn,
            (false, true) => TransitionKind::FadeOut,
            (false, false) => TransitionKind::Dissolve,
        };
        events.push(Event::Gradual(Gradual {
            first: run.first,
            last: run.last,
            kind,
            monotonicity,
            change,
        }));
    }
}

/// Mean absolute difference of two equal-length byte slices.
pub(crate) fn mean_abs_diff(a: &[u8], b: &[u8]) -> f32 {
    // Sums in u32 lanes of 4096 bytes so the compiler vectorises without overflow.
    let mut total = 0u64;
    for (ca, cb) in a.chunks(4096).zip(b.chunks(4096)) {
        let s: u32 = ca
            .iter()
            .zip(cb)
            .map(|(&x, &y)| u32::from(x.abs_diff(y)))
            .sum();
        total += u64::from(s);
    }
    total as f32 / a.len().max(1) as f32
}

/// Contrast below which a column counts as flat (grey levels of standard deviation): flat
/// columns keep their noise instead of having it stretched to the other column's contrast.
const CONTRAST_FLOOR: f32 = 6.0;

/// Per-channel mean and standard deviation of an RGB column.
#[derive(Clone, Copy, Debug)]
struct ColumnStats {
    mean: [f32; 3],
    std: [f32; 3],
}

impl ColumnStats {
    fn of(column: &[u8]) -> ColumnStats {
        let mut sum = [0u64; 3];
        let mut sq = [0u64; 3];
        for px in column.chunks_exact(3) {
            for c in 0..3 {
                let v = u64::from(px[c]);
                sum[c] += v;
                sq[c] += v * v;
            }
        }
        let n = (column.len() / 3).max(1) as f64;
        let mean = sum.map(|s| s as f64 / n);
        let std = [0, 1, 2].map(|c| (sq[c] as f64 / n - mean[c] * mean[c]).max(0.0).sqrt() as f32);
        ColumnStats {
            mean: mean.map(|m| m as f32),
            std,
        }
    }
}

/// Mean absolute difference of two RGB columns after bringing each channel to zero mean and to
/// the pair's common contrast: what remains is a change of content, not of brightness or
/// exposure (an overall scale and offset per channel).
fn normalised_diff(a: &[u8], sa: ColumnStats, b: &[u8], sb: ColumnStats) -> f32 {
    let mut gain_a = [0.0f32; 3];
    let mut gain_b = [0.0f32; 3];
    for c in 0..3 {
        let (da, db) = (sa.std[c].max(CONTRAST_FLOOR), sb.std[c].max(CONTRAST_FLOOR));
        let common = 0.5 * (da + db);
        gain_a[c] = common / da;
        gain_b[c] = common / db;
    }
    let mut total = 0.0f32;
    for (pa, pb) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        for c in 0..3 {
            let x = (f32::from(pa[c]) - sa.mean[c]) * gain_a[c];
            let y = (f32::from(pb[c]) - sb.mean[c]) * gain_b[c];
            total += (x - y).abs();
        }
    }
    total / a.len().max(1) as f32
}

/// Median of `v` (reordered); 0 for an empty slice.
fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_unstable_by(f32::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Standard deviation of the bytes.
fn std_dev(v: &[u8]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let n = v.len() as f64;
    let mean = v.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
    let var = v
        .iter()
        .map(|&x| (f64::from(x) - mean).powi(2))
        .sum::<f64>()
        / n;
    var.sqrt() as f32
}
