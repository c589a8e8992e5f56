//! The recorded-input loop: the file counterpart of [`crate::Pipeline`]. Frames of an image,
//! a folder, a video or any posed dataset [`data::posed`] opens go one after another through
//! the same [`Stages`] as live frames (estimators, optional cut detector and filter), and the
//! place model follows the walk with its lag; each frame's result is handed on in frame order
//! once its place is told.
//!
//! No thread and no queue: a recording has no clock to keep up with, and every frame is wanted.
//! A new recording, a gap in the frames (another split's between), a dataset's own cuts and
//! listed cut positions start a new scene: the estimators forget their history, the filter
//! and the place model start over.

use crate::error::{Result, TrackError};
use crate::stages::{Processed, Stages};
use data::blocks::BlockSplit;
use data::frames::{self, FrameSource};
use data::native::SplitName;
use data::posed::{self, SplitPlan};
use image::DynamicImage;
use learn::place::{PlaceLocalizer, PlacePrediction, PlaceTracker};
use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

/// Which frames of a posed dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Every frame.
    All,
    /// The training sequences.
    Train,
    /// The validation sequences.
    Val,
    /// The test sequences.
    Test,
}

/// One frame of a recording, decoded lazily.
pub struct RecordedFrame {
    /// Position in the input, from 0 (what cut lists count).
    pub index: usize,
    /// The reader's name for it (file stem, dataset frame name, video frame index).
    pub name: String,
    /// Sequence of a dataset frame.
    pub seq: Option<String>,
    /// Time, seconds, where the source has one.
    pub t: Option<f64>,
    /// The frame starts a new stretch of time (a new sequence, a gap, a dataset cut).
    pub new_scene: bool,
    /// The pixels, or why they could not be read.
    pub image: Result<DynamicImage>,
}

/// The frames of `input`, decoded lazily: a posed dataset's frames (of `split`, from
/// [`data::posed::open`] in any layout it reads, `blocks` splitting its sequences as training
/// did), or any frame source [`data::frames`] opens (image, image folder, video; `split` must
/// then be `All` and `blocks` none). Frames keep the reader's names and sequences, so `eval`
/// pairs the results with the same poses.
pub fn frames(
    input: &Path,
    split: Split,
    blocks: Option<BlockSplit>,
) -> Result<Box<dyn Iterator<Item = RecordedFrame>>> {
    if posed::is_dataset(input) {
        let ds = posed::open(input)?;
        let plan = blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
        let parts = ds.parts(plan);
        let want = match split {
            Split::All => None,
            Split::Train => Some(SplitName::Train),
            Split::Val => Some(SplitName::Val),
            Split::Test => Some(SplitName::Test),
        };
        let indices: Vec<usize> = (0..ds.images.len())
            .filter(|&i| want.is_none_or(|w| parts[i] == Some(w)))
            .collect();
        if indices.is_empty() {
            return Err(TrackError::Config(format!(
                "{}: the {split:?} split has no frames ({})",
                input.display(),
                ds.describe_split(plan)
            )));
        }
        let mut previous: Option<usize> = None;
        return Ok(Box::new(indices.into_iter().enumerate().map(
            move |(index, i)| {
                let img = &ds.images[i];
                let new_seq = i > 0 && ds.images[i - 1].frame.seq != img.frame.seq;
                let gap = previous.is_some_and(|p| p + 1 != i);
                previous = Some(i);
                let f = &img.frame;
                RecordedFrame {
                    index,
                    name: f.name.clone(),
                    seq: (!f.seq.is_empty()).then(|| f.seq.clone()),
                    t: f.t,
                    new_scene: gap || new_seq || ds.cuts.binary_search(&i).is_ok(),
                    image: frames::decode_image(&img.image).map_err(Into::into),
                }
            },
        )));
    }
    if split != Split::All || blocks.is_some() {
        return Err(TrackError::Config(format!(
            "{}: a split or blocks of frames need a posed dataset (native, 7-Scenes, TUM, \
             COLMAP, Cambridge, NeRF)",
            input.display()
        )));
    }
    let source: Box<dyn FrameSource + Send> = frames::open(input)?;
    Ok(Box::new(source.enumerate().map(|(index, r)| match r {
        Ok(f) => RecordedFrame {
            index,
            name: f.name,
            seq: None,
            t: f.t,
            new_scene: false,
            image: Ok(DynamicImage::ImageRgb8(f.image)),
        },
        Err(e) => RecordedFrame {
            index,
            name: format!("{index:06}"),
            seq: None,
            t: None,
            new_scene: false,
            image: Err(e.into()),
        },
    })))
}

/// What the loop made of one frame.
pub struct RecordedOutput {
    /// Position in the input.
    pub index: usize,
    /// The frame's name.
    pub name: String,
    /// Its sequence.
    pub seq: Option<String>,
    /// Its time.
    pub t: Option<f64>,
    /// The stages' results: every estimate (the last is the most refined) and the filter's.
    pub processed: Processed,
    /// The place, with a place model.
    pub place: Option<PlacePrediction>,
    /// Milliseconds from the frame's pixels to its results (estimators, filter, place model).
    pub latency_ms: f64,
}

/// How a run went.
#[derive(Debug, Default)]
pub struct RunSummary {
    /// Frames localized.
    pub done: usize,
    /// Names of the frames that could not be read (skipped).
    pub unreadable: Vec<String>,
}

/// How the place model sees the frames.
enum Places<'a> {
    /// Each frame alone.
    Each(&'a PlaceLocalizer),
    /// Along the walk, with the tracker's lag.
    Walk(&'a PlaceLocalizer, PlaceTracker<'a>),
}

/// The loop over a recording (see the module docs).
pub struct Recorded<'a> {
    stages: Stages<'a>,
    places: Option<Places<'a>>,
    cuts: Vec<u64>,
}

impl<'a> Recorded<'a> {
    /// Frames through `stages`.
    pub fn new(stages: Stages<'a>) -> Recorded<'a> {
        Recorded {
            stages,
            places: None,
            cuts: Vec::new(),
        }
    }

    /// Places every frame with `loc`: along the walk, telling each place `lag_s` seconds late
    /// ([`PlaceLocalizer::tracker`]), or each frame alone (`None`).
    pub fn with_places(mut self, loc: &'a PlaceLocalizer, lag_s: Option<f64>) -> Recorded<'a> {
        self.places = Some(match lag_s {
            Some(lag) => Places::Walk(loc, loc.tracker(lag)),
            None => Places::Each(loc),
        });
        self
    }

    /// New scenes also start at these positions in the input (sorted).
    pub fn with_cuts(mut self, cuts: Vec<u64>) -> Recorded<'a> {
        self.cuts = cuts;
        self
    }

    /// Runs `frames` through, handing each frame's output to `sink` in frame order (a frame
    /// whose place is still to be told waits). Unreadable frames are skipped and listed; a
    /// failing stage ends the run with an error naming the frame.
    pub fn run<E: From<TrackError>>(
        mut self,
        frames: impl Iterator<Item = RecordedFrame>,
        mut sink: impl FnMut(RecordedOutput) -> std::result::Result<(), E>,
    ) -> std::result::Result<RunSummary, E> {
        let mut summary = RunSummary::default();
        let mut waiting: VecDeque<RecordedOutput> = VecDeque::new();
        let mut last_seq: Option<Option<String>> = None;
        for frame in frames {
            let image = match frame.image {
                Ok(image) => image,
                Err(_) => {
                    summary.unreadable.push(frame.name);
                    continue;
                }
            };
            let name = frame.name;
            let at_frame = |e: TrackError| TrackError::Frame {
                name: name.clone(),
                source: Box::new(e),
            };
            let t0 = Instant::now();
            let starts_over = frame.new_scene
                || self.cuts.binary_search(&(frame.index as u64)).is_ok()
                || last_seq.as_ref().is_some_and(|s| *s != frame.seq);
            last_seq = Some(frame.seq.clone());
            // Frames without a clock (an image folder) are numbered at the live sources' rate,
            // so a filter sees time pass as it would live.
            let t = frame
                .t
                .unwrap_or(frame.index as f64 / crate::source::DEFAULT_FPS);
            let processed = self
                .stages
                .process(frame.index as u64, &image, t, starts_over)
                .map_err(at_frame)?;
            let (place, told) = match &mut self.places {
                Some(Places::Walk(loc, tracker)) => {
                    if starts_over {
                        tell(&mut waiting, tracker.finish(), &mut sink)?;
                    }
                    let told = loc
                        .view(&image)
                        .and_then(|view| tracker.step(&view, frame.t))
                        .map_err(|e| at_frame(e.into()))?;
                    (None, Some(told))
                }
                Some(Places::Each(loc)) => (
                    Some(loc.predict(&image).map_err(|e| at_frame(e.into()))?),
                    None,
                ),
                None => (None, None),
            };
            let out = RecordedOutput {
                index: frame.index,
                name,
                seq: frame.seq,
                t: frame.t,
                processed,
                place,
                latency_ms: t0.elapsed().as_secs_f64() * 1e3,
            };
            match told {
                Some(told) => {
                    waiting.push_back(out);
                    tell(&mut waiting, told, &mut sink)?;
                }
                None => sink(out)?,
            }
            summary.done += 1;
        }
        if let Some(Places::Walk(_, tracker)) = &mut self.places {
            tell(&mut waiting, tracker.finish(), &mut sink)?;
        }
        if let Some(out) = waiting.front() {
            return Err(TrackError::Config(format!(
                "frame {}: the place tracker never told its place",
                out.name
            ))
            .into());
        }
        Ok(summary)
    }
}

/// Hands on the waiting outputs whose places have been `told` (oldest first, one place each).
fn tell<E: From<TrackError>>(
    waiting: &mut VecDeque<RecordedOutput>,
    told: Vec<PlacePrediction>,
    sink: &mut impl FnMut(RecordedOutput) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    for place in told {
        let mut out = waiting.pop_front().ok_or_else(|| {
            TrackError::Config("the place tracker told more places than frames it was given".into())
        })?;
        out.place = Some(place);
        sink(out)?;
    }
    Ok(())
}
