//! Running the detector over a whole input: a video file (decoded straight to thumbnails by
//! swscale, the cheap way, in parallel stretches between keyframes where the file allows), an
//! image folder, or a native dataset's `frames/` (each image shrunk with area averaging).

use crate::detector::{Config, Cut, Detector, Event, Gradual, Trace};
use crate::error::{CutError, Result};
use crate::rhythm::RhythmImage;
use data::frames::{FrameSource, ImageFolder};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to collect besides the events.
#[derive(Clone, Copy, Debug, Default)]
pub struct Collect {
    /// The per-frame series ([`Trace`]).
    pub trace: bool,
    /// The visual-rhythm picture ([`RhythmImage`]).
    pub rhythm: bool,
}

/// How a video is decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decoding {
    /// Decoders side by side on stretches between keyframes (0: one per core, at most 8; 1: a
    /// single decoder, itself on one thread).
    pub workers: usize,
    /// Skip the loop (deblocking) filter ([`data::frames::VideoFile::open_fast`]).
    pub fast: bool,
}

impl Default for Decoding {
    /// The fastest: a decoder per core, no loop filter.
    fn default() -> Self {
        Decoding {
            workers: 0,
            fast: true,
        }
    }
}

impl Decoding {
    /// As the peers decode (PySceneDetect, `ffmpeg -threads 1`): one thread, every filter.
    pub const FULL_ONE_THREAD: Decoding = Decoding {
        workers: 1,
        fast: false,
    };
}

/// The outcome of a whole input.
#[derive(Debug)]
pub struct Detection {
    /// The folder or file the frames came from.
    pub source: PathBuf,
    /// Hard cuts, in frame order.
    pub cuts: Vec<Cut>,
    /// Gradual transitions, in frame order.
    pub gradual: Vec<Gradual>,
    /// Frames decoded and seen by the detector.
    pub frames: u64,
    /// Frames that could not be read (skipped), and the first such error.
    pub skipped: u64,
    /// The first read error, when any frame was skipped.
    pub first_error: Option<String>,
    /// The video's frame rate, where the source has one.
    pub video_fps: Option<f64>,
    /// Thumbnail size the detector worked on.
    pub thumb_size: (u32, u32),
    /// Wall time from opening the input to the last decision, seconds.
    pub seconds: f64,
    /// The series, when asked for.
    pub trace: Option<Trace>,
    /// The visual rhythm, when asked for.
    pub rhythm: Option<RhythmImage>,
}

impl Detection {
    /// Frame numbers of the hard cuts.
    pub fn cut_frames(&self) -> Vec<u64> {
        self.cuts.iter().map(|c| c.frame).collect()
    }
}

/// Where the frames of `input` are: a native dataset's `frames/` folder when `input` is such a
/// dataset, else `input` itself.
pub fn frames_path(input: &Path) -> PathBuf {
    let frames = input.join("frames");
    if input.join(data::native::DATASET_TOML).is_file() && frames.is_dir() {
        frames
    } else {
        input.to_path_buf()
    }
}

/// A frame source and, where it makes thumbnails itself (video), their size.
type Opened = (Box<dyn FrameSource + Send>, Option<(u32, u32)>);

/// Opens `input` as a frame source whose frames are already thumbnails where the source can
/// make them itself (video), with the thumbnail size when known up front.
fn open(input: &Path, cfg: &Config, decoding: Decoding) -> Result<Opened> {
    let path = frames_path(input);
    #[cfg(feature = "video")]
    if path.is_file() && is_video(&path) {
        // Stretches decoded side by side where the file allows it, else one decoder.
        let workers = match decoding.workers {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get().min(8)),
            n => n,
        };
        if let Some(mut video) = data::frames::ParallelVideo::open(&path, decoding.fast, workers)? {
            let (w, h) = video.frame_size();
            let thumb = cfg.thumb_size(w, h);
            video.set_output_size(Some(thumb));
            return Ok((Box::new(video), Some(thumb)));
        }
        let threads = usize::from(workers == 1);
        let mut video = data::frames::VideoFile::open_with(&path, None, decoding.fast, threads)?;
        let (w, h) = video.frame_size();
        let thumb = cfg.thumb_size(w, h);
        video.set_output_size(Some(thumb))?;
        return Ok((Box::new(video), Some(thumb)));
    }
    if path.is_dir() {
        return Ok((Box::new(ImageFolder::open(&path)?), None));
    }
    let _ = (cfg, decoding);
    Ok((data::frames::open(&path)?, None))
}

#[cfg(feature = "video")]
fn is_video(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        data::frames::VIDEO_EXTENSIONS
            .iter()
            .any(|v| v.eq_ignore_ascii_case(e))
    })
}

/// Detects cuts and transitions in `input` (a video, an image folder or a native dataset).
/// `progress(frames done, frames expected)` is called after every frame.
///
/// Frames that cannot be read are skipped and counted; the detector compares the next good frame
/// with the last good one.
///
/// # Errors
/// The input cannot be opened, no frame at all can be read, or a setting is bad.
pub fn detect_input(
    input: &Path,
    cfg: &Config,
    collect: Collect,
    progress: &mut dyn FnMut(u64, Option<u64>),
) -> Result<Detection> {
    detect_input_decoded(input, cfg, Decoding::default(), collect, progress)
}

/// [`detect_input`] with a video decoded as `decoding` says.
///
/// # Errors
/// As [`detect_input`].
pub fn detect_input_decoded(
    input: &Path,
    cfg: &Config,
    decoding: Decoding,
    collect: Collect,
    progress: &mut dyn FnMut(u64, Option<u64>),
) -> Result<Detection> {
    cfg.validate()?;
    // Timed from before opening: for a video that includes the pass over its packets that
    // plans the parallel decoding (PySceneDetect's figure leaves its `open_video` out).
    let start = Instant::now();
    let (source, known_thumb) = open(input, cfg, decoding)?;
    let (video_fps, expected, source_path) =
        (source.fps(), source.len_hint(), source.path().to_path_buf());
    let mut state: Option<(Detector, Option<RhythmImage>, (u32, u32))> = None;
    let mut out = Detection {
        source: source_path,
        cuts: Vec::new(),
        gradual: Vec::new(),
        frames: 0,
        skipped: 0,
        first_error: None,
        video_fps,
        thumb_size: (0, 0),
        seconds: 0.0,
        trace: None,
        rhythm: None,
    };
    let mut thumb = image::RgbImage::new(1, 1);
    for item in source {
        let frame = match item {
            Ok(f) => f,
            Err(e) => {
                out.skipped += 1;
                out.first_error.get_or_insert_with(|| e.to_string());
                continue;
            }
        };
        let (w, h) = frame.image.dimensions();
        let (det, rhythm, size) = match &mut state {
            Some(s) => s,
            None => {
                let size = known_thumb.unwrap_or_else(|| cfg.thumb_size(w, h));
                let det = Detector::new(*cfg, size.0, size.1)?;
                let det = if collect.trace { det.with_trace() } else { det };
                let rhythm = if collect.rhythm {
                    Some(RhythmImage::new(size.0, size.1)?)
                } else {
                    None
                };
                state.insert((det, rhythm, size))
            }
        };
        let pixels: &[u8] = if (w, h) == *size {
            frame.image.as_raw()
        } else {
            if thumb.dimensions() != *size {
                thumb = image::RgbImage::new(size.0, size.1);
            }
            imgproc::view::resize_rgb(&frame.image, &mut thumb)?;
            thumb.as_raw()
        };
        let events = det.push(frame.index, pixels)?;
        if let Some(r) = rhythm {
            r.push(pixels);
        }
        sort_events(events, &mut out.cuts, &mut out.gradual);
        out.frames += 1;
        progress(out.frames, expected);
    }
    let Some((mut det, rhythm, size)) = state else {
        return Err(CutError::Data(data::DataError::Frames {
            path: out.source.clone(),
            msg: match &out.first_error {
                Some(e) => format!("no frame could be read (first error: {e})"),
                None => "no frames".into(),
            },
        }));
    };
    sort_events(det.finish(), &mut out.cuts, &mut out.gradual);
    out.thumb_size = size;
    out.trace = det.trace().cloned();
    out.rhythm = rhythm;
    out.seconds = start.elapsed().as_secs_f64();
    Ok(out)
}

/// Files events into hard cuts and gradual transitions.
fn sort_events(events: Vec<Event>, cuts: &mut Vec<Cut>, gradual: &mut Vec<Gradual>) {
    for e in events {
        match e {
            Event::Cut(c) => cuts.push(c),
            Event::Gradual(g) => gradual.push(g),
        }
    }
}

/// Runs the detector over thumbnails already in memory (`(frame index, RGB bytes)` in order),
/// all of size `size`: the detector alone, as the benchmark times it and tests on rendered
/// frames use it.
///
/// # Errors
/// A bad setting or a thumbnail of the wrong size.
pub fn detect_thumbnails<'a>(
    cfg: &Config,
    size: (u32, u32),
    thumbs: impl IntoIterator<Item = (u64, &'a [u8])>,
) -> Result<(Vec<Cut>, Vec<Gradual>)> {
    let mut det = Detector::new(*cfg, size.0, size.1)?;
    let (mut cuts, mut gradual) = (Vec::new(), Vec::new());
    for (index, rgb) in thumbs {
        sort_events(det.push(index, rgb)?, &mut cuts, &mut gradual);
    }
    sort_events(det.finish(), &mut cuts, &mut gradual);
    Ok((cuts, gradual))
}
