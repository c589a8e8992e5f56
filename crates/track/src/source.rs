//! Frame sources of the live pipeline: image folders and video files (through `data::frames`),
//! a camera device (FFmpeg's v4l2 input), raw frames on stdin, and the recordings of a native
//! dataset, which carry ground truth so a live run can be scored.
//!
//! [`open`] reads a source specification as the command line gives it.

use crate::error::{Result, TrackError};
use data::frames::{self, Frame, FrameSource};
use data::native::SplitName;
use data::posed::{self, PosedDataset, SplitPlan};
use geom::Pose;
use std::io::Read;
use std::path::{Path, PathBuf};

/// One frame from a source, with the ground-truth pose where the source knows it.
#[derive(Clone, Debug)]
pub struct SourceFrame {
    /// The decoded frame. `t` is always set: sources without a clock number frames at
    /// [`Source::fps`].
    pub frame: Frame,
    /// Ground truth (dataset sources).
    pub truth: Option<Pose>,
}

/// A stream of frames for the pipeline.
pub trait Source: Send {
    /// The next frame; `None` at the end; `Some(Err)` for a frame that could not be read (the
    /// pipeline ends the stream with an error event).
    fn next_frame(&mut self) -> Option<Result<SourceFrame>>;
    /// Frames per second the source is recorded at, where known.
    fn fps(&self) -> Option<f64>;
    /// Whether frames arrive at their own pace (a camera, a pipe): then a busy pipeline drops
    /// stale frames instead of making the source wait.
    fn is_live(&self) -> bool;
    /// The source as a person reads it, for messages.
    fn name(&self) -> String;
}

/// Frame rate assumed for sources with no clock (image folders) unless one is given.
pub const DEFAULT_FPS: f64 = 10.0;

/// Opens `spec`:
/// - `-` or `stdin:WxH[:rgb|gray]`: raw 8-bit frames on stdin (`-` needs `raw_size`);
/// - `/dev/video*`: a camera through FFmpeg's v4l2 input;
/// - a posed dataset in any layout `data::posed` opens (native, 7-Scenes, TUM, COLMAP,
///   Cambridge, NeRF): its `split` frames (all when `None`; the dataset's own split, else
///   blocks of consecutive frames), with ground truth;
/// - an image folder, an image or a video file.
///
/// `fps` overrides the frame rate used to time frames that carry no timestamp.
pub fn open(spec: &str, split: Option<SplitName>, fps: Option<f64>) -> Result<Box<dyn Source>> {
    if spec == "-" || spec.starts_with("stdin:") {
        let (w, h, channels) = parse_raw(spec)?;
        return Ok(Box::new(RawFrames::new(
            Box::new(std::io::stdin()),
            "stdin",
            w,
            h,
            channels,
            fps.unwrap_or(DEFAULT_FPS),
        )));
    }
    let path = Path::new(spec);
    if spec.starts_with("/dev/video") {
        return open_device(path, fps);
    }
    if posed::is_dataset(path) {
        return Ok(Box::new(DatasetFrames::open(path, split, fps)?));
    }
    let inner = frames::open(path)?;
    Ok(Box::new(FileFrames::new(inner, fps)))
}

fn parse_raw(spec: &str) -> Result<(u32, u32, u8)> {
    let bad = |msg: &str| TrackError::source(spec, msg);
    let rest = spec
        .strip_prefix("stdin:")
        .ok_or_else(|| bad("raw frames on stdin need their size: stdin:WIDTHxHEIGHT[:rgb|gray]"))?;
    let mut parts = rest.split(':');
    let size = parts.next().unwrap_or_default();
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0 && w <= 8192 && h <= 8192)
        .ok_or_else(|| bad("size must be WIDTHxHEIGHT, each 1 to 8192"))?;
    let channels = match parts.next() {
        None | Some("rgb") => 3,
        Some("gray") => 1,
        Some(_) => return Err(bad("pixel format must be rgb or gray")),
    };
    if parts.next().is_some() {
        return Err(bad("expected stdin:WIDTHxHEIGHT[:rgb|gray]"));
    }
    Ok((w, h, channels))
}

fn open_device(path: &Path, fps: Option<f64>) -> Result<Box<dyn Source>> {
    let inner = frames::VideoFile::open_device(path)?;
    Ok(Box::new(FileFrames::live(Box::new(inner), fps)))
}

/// An image folder, image or video file (or device) from `data::frames`.
pub struct FileFrames {
    inner: Box<dyn FrameSource + Send>,
    fps: f64,
    live: bool,
    /// Time of the first frame with a timestamp, so that video times start at 0.
    t0: Option<f64>,
}

impl FileFrames {
    /// Frames of a file source; `fps` overrides the rate used for frames without timestamps.
    pub fn new(inner: Box<dyn FrameSource + Send>, fps: Option<f64>) -> FileFrames {
        let fps = fps.or(inner.fps()).unwrap_or(DEFAULT_FPS);
        FileFrames {
            inner,
            fps,
            live: false,
            t0: None,
        }
    }

    /// Frames of a live device.
    pub fn live(inner: Box<dyn FrameSource + Send>, fps: Option<f64>) -> FileFrames {
        FileFrames {
            live: true,
            ..FileFrames::new(inner, fps)
        }
    }
}

impl Source for FileFrames {
    fn next_frame(&mut self) -> Option<Result<SourceFrame>> {
        let mut frame = match self.inner.next()? {
            Ok(f) => f,
            Err(e) => return Some(Err(e.into())),
        };
        frame.t = Some(match frame.t {
            Some(t) => t - *self.t0.get_or_insert(t),
            None => frame.index as f64 / self.fps,
        });
        Some(Ok(SourceFrame { frame, truth: None }))
    }

    fn fps(&self) -> Option<f64> {
        Some(self.fps)
    }

    fn is_live(&self) -> bool {
        self.live
    }

    fn name(&self) -> String {
        self.inner.path().display().to_string()
    }
}

/// Raw 8-bit frames of a fixed size from a byte stream (stdin of a camera pipeline such as
/// `ffmpeg -f rawvideo -pix_fmt rgb24 -`).
pub struct RawFrames {
    reader: Box<dyn Read + Send>,
    name: String,
    width: u32,
    height: u32,
    channels: u8,
    fps: f64,
    index: u64,
    buf: Vec<u8>,
}

impl RawFrames {
    /// Frames of `width x height` with `channels` (1 gray, 3 RGB) bytes per pixel from `reader`.
    pub fn new(
        reader: Box<dyn Read + Send>,
        name: &str,
        width: u32,
        height: u32,
        channels: u8,
        fps: f64,
    ) -> RawFrames {
        RawFrames {
            reader,
            name: name.to_string(),
            width,
            height,
            channels,
            fps,
            index: 0,
            buf: vec![0; width as usize * height as usize * channels as usize],
        }
    }

    /// Fills the buffer; `Ok(false)` at a clean end of stream (no byte of a new frame).
    fn fill(&mut self) -> std::io::Result<usize> {
        let mut got = 0;
        while got < self.buf.len() {
            match self.reader.read(&mut self.buf[got..]) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(got)
    }
}

impl Source for RawFrames {
    fn next_frame(&mut self) -> Option<Result<SourceFrame>> {
        let got = match self.fill() {
            Ok(n) => n,
            Err(e) => return Some(Err(TrackError::source(&self.name, e.to_string()))),
        };
        if got == 0 {
            return None;
        }
        if got < self.buf.len() {
            return Some(Err(TrackError::source(
                &self.name,
                format!(
                    "stream ended inside frame {} ({got} of {} bytes)",
                    self.index,
                    self.buf.len()
                ),
            )));
        }
        let (w, h) = (self.width, self.height);
        let image = if self.channels == 3 {
            image::RgbImage::from_raw(w, h, self.buf.clone())
        } else {
            image::GrayImage::from_raw(w, h, self.buf.clone())
                .map(|g| image::DynamicImage::ImageLuma8(g).to_rgb8())
        };
        let Some(image) = image else {
            return Some(Err(TrackError::source(&self.name, "frame buffer size")));
        };
        let index = self.index;
        self.index += 1;
        Some(Ok(SourceFrame {
            frame: Frame {
                index,
                name: format!("{index:06}"),
                t: Some(index as f64 / self.fps),
                image,
            },
            truth: None,
        }))
    }

    fn fps(&self) -> Option<f64> {
        Some(self.fps)
    }

    fn is_live(&self) -> bool {
        true
    }

    fn name(&self) -> String {
        self.name.clone()
    }
}

/// The frames of one split of a posed dataset, recording after recording, with their poses.
pub struct DatasetFrames {
    ds: PosedDataset,
    index: Vec<usize>,
    next: usize,
    fps: f64,
    root: PathBuf,
}

impl DatasetFrames {
    /// The `split` frames of the dataset at `root` (every frame for `None`).
    pub fn open(root: &Path, split: Option<SplitName>, fps: Option<f64>) -> Result<DatasetFrames> {
        let ds = posed::open(root)?;
        let parts = ds.parts(SplitPlan::Auto);
        let index: Vec<usize> = (0..ds.images.len())
            .filter(|&i| split.is_none() || parts[i] == split)
            .collect();
        if index.is_empty() {
            return Err(TrackError::source(
                root.display().to_string(),
                match split {
                    Some(s) => format!("the dataset's {s:?} split has no frames").to_lowercase(),
                    None => "the dataset has no frames".to_string(),
                },
            ));
        }
        let fps = fps
            .or_else(|| recorded_fps(&ds, &index))
            .unwrap_or(DEFAULT_FPS);
        Ok(DatasetFrames {
            ds,
            index,
            next: 0,
            fps,
            root: root.to_path_buf(),
        })
    }

    /// Frames the source will give.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether the source has no frames (never: [`open`](Self::open) refuses that).
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }
}

/// The frame rate of a dataset's recording from its timestamps.
fn recorded_fps(ds: &PosedDataset, index: &[usize]) -> Option<f64> {
    let times: Vec<f64> = index.iter().filter_map(|&i| ds.images[i].frame.t).collect();
    let steps: Vec<f64> = times
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    let mut steps = steps;
    steps.sort_by(f64::total_cmp);
    let median = *steps.get(steps.len() / 2)?;
    Some(1.0 / median)
}

impl Source for DatasetFrames {
    fn next_frame(&mut self) -> Option<Result<SourceFrame>> {
        let n = self.next;
        let &i = self.index.get(n)?;
        self.next += 1;
        let posed = &self.ds.images[i];
        let image = match frames::decode_image(&posed.image) {
            Ok(img) => img.to_rgb8(),
            Err(e) => return Some(Err(e.into())),
        };
        let pf = &posed.frame;
        Some(Ok(SourceFrame {
            frame: Frame {
                index: n as u64,
                name: pf.name.clone(),
                t: Some(n as f64 / self.fps),
                image,
            },
            truth: Some(pf.pose),
        }))
    }

    fn fps(&self) -> Option<f64> {
        Some(self.fps)
    }

    fn is_live(&self) -> bool {
        false
    }

    fn name(&self) -> String {
        self.root.display().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_specs_are_parsed_or_refused() {
        assert_eq!(parse_raw("stdin:160x120").ok(), Some((160, 120, 3)));
        assert_eq!(parse_raw("stdin:64x48:gray").ok(), Some((64, 48, 1)));
        for bad in [
            "-",
            "stdin:",
            "stdin:0x5",
            "stdin:64x48:yuv",
            "stdin:64x48:rgb:x",
        ] {
            assert!(parse_raw(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn raw_frames_end_cleanly_or_name_a_cut_off_frame() {
        let bytes: Vec<u8> = vec![7; 4 * 3 * 2 + 5];
        let mut src = RawFrames::new(Box::new(std::io::Cursor::new(bytes)), "pipe", 4, 3, 1, 10.0);
        for n in 0..2 {
            let f = src.next_frame().and_then(|r| r.ok()).expect("frame");
            assert_eq!(f.frame.index, n);
            assert_eq!(f.frame.image.dimensions(), (4, 3));
            assert_eq!(f.frame.t, Some(n as f64 / 10.0));
        }
        let err = src.next_frame().and_then(|r| r.err()).expect("error");
        assert!(err.to_string().contains("inside frame 2"), "{err}");
    }

    #[test]
    fn a_7scenes_scene_streams_its_test_split_with_ground_truth() {
        let scene = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data/7scenes_stairs_sample/7scenes_layout");
        if !scene.is_dir() {
            return;
        }
        let spec = scene.to_str().expect("path");
        let mut src = open(spec, Some(SplitName::Test), Some(5.0)).expect("opens");
        let mut names = Vec::new();
        while let Some(f) = src.next_frame() {
            let f = f.expect("frame");
            assert!(f.truth.is_some());
            assert_eq!(f.frame.image.dimensions(), (640, 480));
            names.push(f.frame.name);
        }
        // TestSplit.txt lists sequences 1 and 4, three frames each.
        assert_eq!(names.len(), 6);
        assert_eq!(names[0], "frame-000000");
    }
}
