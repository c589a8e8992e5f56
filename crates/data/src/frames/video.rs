//! Video files as frame sources, through FFmpeg's libraries (`ffmpeg-next`): demux the best video
//! stream, decode packet by packet, convert each frame to RGB24 (and optionally to a smaller size)
//! with swscale. Only the decoder's own look-ahead is buffered, so memory does not grow with the
//! length of the video.

use super::{Frame, FrameSource};
use crate::error::{DataError, Result};
use ffmpeg_next as ff;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Gives up on a video after this many errors in a row without a decoded frame. Every error
/// consumes input, so a damaged file ends anyway; this guards against a decoder that keeps failing
/// without making progress, and spares the caller a flood of errors from a file that is garbage
/// past some point.
const MAX_CONSECUTIVE_ERRORS: u32 = 1000;

/// Most decoder threads per video (see [`VideoFile::open_scaled`]).
const MAX_DECODE_THREADS: usize = 4;

/// Initialises FFmpeg once per process. Also silences FFmpeg's own log below fatal errors: its
/// warnings and error lines (`moov atom not found`, ...) would otherwise flood stderr, which
/// carries the command line's progress and its promised one-line errors; what went wrong reaches
/// the user through our error, which names the file.
fn init() -> std::result::Result<(), String> {
    static INIT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    INIT.get_or_init(|| {
        ff::init().map_err(|e| format!("cannot initialise FFmpeg: {e}"))?;
        ff::util::log::set_level(ff::util::log::Level::Fatal);
        Ok(())
    })
    .clone()
}

/// A rational as `f64`, or `None` where it is zero, negative or undefined (FFmpeg uses 0/0 for
/// "unknown").
fn positive(r: ff::Rational) -> Option<f64> {
    (r.numerator() > 0 && r.denominator() > 0)
        .then(|| f64::from(r.numerator()) / f64::from(r.denominator()))
}

/// The swscale context and the input it was made for.
struct Scaler {
    ctx: ff::software::scaling::Context,
    input: (ff::format::Pixel, u32, u32),
}

// SAFETY: an `SwsContext` has no thread affinity (no thread-local state, no back-pointer to its
// creating thread); it only must not be used from two threads at once, which `&mut` access through
// the owning `VideoFile` already rules out. ffmpeg-next leaves it `!Send` only because it holds a
// raw pointer. Moving it is what lets a server hand a video source to a worker thread.
unsafe impl Send for Scaler {}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Reading packets from the file.
    Reading,
    /// The file is exhausted; the decoder gives its last buffered frames.
    Draining,
    /// Nothing more to give.
    Done,
}

/// The frames of a video file, decoded one at a time with FFmpeg and converted to RGB.
///
/// Frames come in decoding-output (presentation) order; [`Frame::index`] counts them from 0 and
/// [`Frame::t`] is the frame's presentation timestamp in seconds (the stream's time base, not
/// shifted to start at 0). A damaged packet yields an `Err` naming the file, and the iteration
/// goes on with the next packet.
pub struct VideoFile {
    path: PathBuf,
    input: ff::format::context::Input,
    stream_index: usize,
    decoder: ff::decoder::Video,
    time_base: Option<f64>,
    fps: Option<f64>,
    len_hint: Option<u64>,
    target: Option<(u32, u32)>,
    scaler: Option<Scaler>,
    packet: ff::Packet,
    decoded: ff::frame::Video,
    rgb: ff::frame::Video,
    state: State,
    next_index: u64,
    /// Timestamp (stream time base) of the frame returned last.
    last_pts: Option<i64>,
    errors_in_a_row: u32,
}

impl std::fmt::Debug for VideoFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoFile")
            .field("path", &self.path)
            .field("frame_size", &self.frame_size())
            .field("fps", &self.fps)
            .field("len_hint", &self.len_hint)
            .field("next_index", &self.next_index)
            .finish_non_exhaustive()
    }
}

impl VideoFile {
    /// Opens `path` and its best video stream; frames keep the video's own size.
    ///
    /// # Errors
    /// The file is missing or unreadable, is not a media file FFmpeg can read, has no video
    /// stream, or its codec has no decoder; the message names the file.
    pub fn open(path: &Path) -> Result<Self> {
        Self::open_scaled(path, None)
    }

    /// Like [`open`](Self::open), but with `size = Some((width, height))` every frame is scaled to
    /// that size while converting to RGB (area averaging when shrinking). Scene-cut detection
    /// works on small frames, and scaling inside swscale costs little next to resizing the full
    /// RGB frame afterwards. The aspect ratio is the caller's choice.
    ///
    /// # Errors
    /// As [`open`](Self::open), and a zero width or height.
    pub fn open_scaled(path: &Path, size: Option<(u32, u32)>) -> Result<Self> {
        Self::open_with(path, size, false, 0)
    }

    /// Like [`open`](Self::open), for analysis rather than display: the decoder skips its
    /// loop (deblocking) filter. Pixels differ slightly from a normal decode (the block edges
    /// of H.264 / HEVC are not smoothed), which thumbnails for scene-cut detection do not
    /// notice, and decoding is about a fifth faster.
    ///
    /// # Errors
    /// As [`open`](Self::open).
    pub fn open_fast(path: &Path) -> Result<Self> {
        Self::open_with(path, None, true, 0)
    }

    /// Like [`open_scaled`](Self::open_scaled) with the decoder's settings chosen: `fast` as
    /// [`open_fast`](Self::open_fast), `decode_threads` FFmpeg threads (0: from the cores).
    /// Benchmarks use it to decode as a peer does (one thread, the loop filter on).
    ///
    /// # Errors
    /// As [`open_scaled`](Self::open_scaled).
    pub fn open_with(
        path: &Path,
        size: Option<(u32, u32)>,
        fast: bool,
        decode_threads: usize,
    ) -> Result<Self> {
        let err = |msg: String| DataError::frames(path, msg);
        if let Some((w, h)) = size
            && (w == 0 || h == 0 || w > 16384 || h > 16384)
        {
            return Err(err(format!("cannot scale video frames to {w}x{h}")));
        }
        // A clean "No such file or directory" from the OS rather than FFmpeg's wording.
        let meta = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
        if meta.is_dir() {
            return Err(err("is a folder, not a video file".into()));
        }
        init().map_err(err)?;

        // ffmpeg-next panics on paths that are not UTF-8 or hold a NUL, so refuse them here.
        let utf8 = path
            .to_str()
            .filter(|s| !s.contains('\0'))
            .ok_or_else(|| err("FFmpeg needs a UTF-8 file name; rename the file".into()))?;
        // The `file:` protocol prefix stops FFmpeg from reading a colon in a local file name
        // (`cam:1.mp4`) as a protocol.
        let input = ff::format::input(&format!("file:{utf8}"))
            .map_err(|e| err(format!("cannot open as a video: {e}")))?;
        Self::from_input(path, input, size, fast, decode_threads)
    }

    /// Opens a camera device (`/dev/video0`) through FFmpeg's `v4l2` input. Frames come as the
    /// camera delivers them; one decoding thread, since a frame in flight per thread is latency
    /// a live camera cannot afford.
    ///
    /// # Errors
    /// No such device, a device FFmpeg cannot open, or an FFmpeg built without `v4l2`; the
    /// message names the device.
    pub fn open_device(path: &Path) -> Result<Self> {
        let err = |msg: String| DataError::frames(path, msg);
        std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
        init().map_err(err)?;
        ff::device::register_all();
        let utf8 = path
            .to_str()
            .filter(|s| !s.contains('\0'))
            .ok_or_else(|| err("FFmpeg needs a UTF-8 device name".into()))?;
        let v4l2 = ff::device::input::video()
            .find(|f| f.name() == "video4linux2,v4l2" || f.name() == "v4l2")
            .ok_or_else(|| err("this FFmpeg has no v4l2 input".into()))?;
        let input = match ff::format::open(utf8, &v4l2) {
            Ok(ff::format::context::Context::Input(input)) => input,
            Ok(_) => return Err(err("not an input device".into())),
            Err(e) => return Err(err(format!("cannot open the camera: {e}"))),
        };
        Self::from_input(path, input, None, false, 1)
    }

    /// The decoder side of every opener: the best video stream of `input` and its decoder.
    fn from_input(
        path: &Path,
        input: ff::format::context::Input,
        size: Option<(u32, u32)>,
        fast: bool,
        decode_threads: usize,
    ) -> Result<Self> {
        let err = |msg: String| DataError::frames(path, msg);
        let stream = input
            .streams()
            .best(ff::media::Type::Video)
            .ok_or_else(|| err("no video stream in this file".into()))?;
        let stream_index = stream.index();
        let time_base = positive(stream.time_base());
        let fps = positive(stream.avg_frame_rate()).or_else(|| positive(stream.rate()));
        let len_hint = len_hint(&input, &stream, time_base, fps);

        let mut ctx = ff::codec::context::Context::from_parameters(stream.parameters())
            .map_err(|e| err(format!("cannot read the video stream's parameters: {e}")))?;
        // Frame threading: decoding is the costly part of reading a video, and it only adds a few
        // frames of latency, which a file source does not mind. Each thread holds a frame in
        // flight, so the count is capped (FFmpeg's automatic count goes up to 16) to keep memory
        // small and leave cores to the stages that consume the frames.
        let threads = match decode_threads {
            0 => {
                std::thread::available_parallelism().map_or(1, |n| n.get().min(MAX_DECODE_THREADS))
            }
            n => n,
        };
        ctx.set_threading(ff::codec::threading::Config {
            kind: ff::codec::threading::Type::Frame,
            count: threads,
            ..Default::default()
        });
        let mut decoder = ctx.decoder();
        if fast {
            decoder.skip_loop_filter(ff::codec::discard::Discard::All);
        }
        // Timestamps of decoded frames are then in the stream's time base, as the packets'.
        decoder.set_packet_time_base(stream.time_base());
        let decoder = decoder.video().map_err(|e| {
            err(format!(
                "cannot decode the video stream ({:?}): {e}",
                stream.parameters().id()
            ))
        })?;

        Ok(Self {
            path: path.to_path_buf(),
            input,
            stream_index,
            decoder,
            time_base,
            fps,
            len_hint,
            target: size,
            scaler: None,
            packet: ff::Packet::empty(),
            decoded: ff::frame::Video::empty(),
            rgb: ff::frame::Video::empty(),
            state: State::Reading,
            next_index: 0,
            last_pts: None,
            errors_in_a_row: 0,
        })
    }

    /// Changes the size frames are scaled to from the next frame on (`None`: the video's own
    /// size). Lets a caller pick a size from [`frame_size`](Self::frame_size) after opening,
    /// as scene-cut detection does for its aspect-preserving thumbnails.
    ///
    /// # Errors
    /// A zero or absurd width or height.
    pub fn set_output_size(&mut self, size: Option<(u32, u32)>) -> Result<()> {
        if let Some((w, h)) = size
            && (w == 0 || h == 0 || w > 16384 || h > 16384)
        {
            return Err(self.error(format!("cannot scale video frames to {w}x{h}")));
        }
        self.target = size;
        self.scaler = None;
        Ok(())
    }

    /// The size of the frames this source gives: the requested size of
    /// [`open_scaled`](Self::open_scaled), else the video's coded size from its header.
    pub fn frame_size(&self) -> (u32, u32) {
        self.target
            .unwrap_or((self.decoder.width(), self.decoder.height()))
    }

    /// Timestamp (the stream's time base) of the frame returned last.
    pub(crate) fn last_pts(&self) -> Option<i64> {
        self.last_pts
    }

    /// Jumps to the keyframe at `pts` (stream time base) or the one before it, and empties the
    /// decoder: the next frames come from there.
    pub(crate) fn seek_keyframe(&mut self, pts: i64) -> Result<()> {
        let tb = self
            .time_base
            .ok_or_else(|| self.error("cannot seek: the stream has no time base".into()))?;
        // avformat_seek_file on all streams counts in AV_TIME_BASE (microseconds); rounding up
        // keeps the wanted keyframe at or before the target.
        let us = (pts as f64 * tb * f64::from(ff::ffi::AV_TIME_BASE)).ceil() as i64;
        self.input
            .seek(us, ..us)
            .map_err(|e| self.error(format!("cannot seek to {pts}: {e}")))?;
        self.decoder.flush();
        self.state = State::Reading;
        self.errors_in_a_row = 0;
        Ok(())
    }

    fn error(&self, msg: String) -> DataError {
        DataError::Frames {
            path: self.path.clone(),
            msg,
        }
    }

    /// Counts an error; past [`MAX_CONSECUTIVE_ERRORS`] the source stops.
    fn failed(&mut self, msg: String) -> Option<Result<Frame>> {
        self.errors_in_a_row += 1;
        if self.errors_in_a_row >= MAX_CONSECUTIVE_ERRORS {
            self.state = State::Done;
            return Some(Err(self.error(format!(
                "{msg}; giving up after {MAX_CONSECUTIVE_ERRORS} errors in a row"
            ))));
        }
        Some(Err(self.error(msg)))
    }

    /// The next frame, `Some(Err)` for a failure that the iteration can go past, `None` at the
    /// end.
    pub fn next_frame(&mut self) -> Option<Result<Frame>> {
        let again = ff::Error::Other {
            errno: ff::util::error::EAGAIN,
        };
        loop {
            if self.state == State::Done {
                return None;
            }
            // Take what the decoder has ready before feeding it more, so it never holds more than
            // its own look-ahead.
            match self.decoder.receive_frame(&mut self.decoded) {
                Ok(()) => {
                    self.errors_in_a_row = 0;
                    return Some(self.convert());
                }
                Err(ff::Error::Eof) => {
                    self.state = State::Done;
                    return None;
                }
                Err(e) if e == again => {}
                Err(e) => {
                    let index = self.next_index;
                    return self.failed(format!(
                        "cannot decode a frame (next frame index {index}): {e}"
                    ));
                }
            }
            if self.state == State::Draining {
                // A drained decoder answers EOF, not EAGAIN; stop rather than wait for nothing.
                self.state = State::Done;
                return None;
            }
            match self.packet.read(&mut self.input) {
                Ok(()) => {
                    if self.packet.stream() != self.stream_index {
                        continue;
                    }
                    if let Err(e) = self.decoder.send_packet(&self.packet) {
                        let pos = self.packet.position();
                        return self.failed(format!("damaged video packet at byte {pos}: {e}"));
                    }
                }
                Err(e) => {
                    // InvalidData is a corrupt packet the demuxer can resync past. Other errors
                    // (I/O) stick in FFmpeg and repeat on every later read, so the file ends here.
                    let resync = matches!(e, ff::Error::InvalidData);
                    if !resync {
                        self.start_draining();
                    }
                    if matches!(e, ff::Error::Eof) {
                        continue;
                    }
                    return self.failed(format!("cannot read the video file: {e}"));
                }
            }
        }
    }

    fn start_draining(&mut self) {
        self.state = match self.decoder.send_eof() {
            Ok(()) => State::Draining,
            Err(_) => State::Done,
        };
    }

    /// Converts the frame in `self.decoded` to an RGB [`Frame`].
    fn convert(&mut self) -> Result<Frame> {
        let index = self.next_index;
        self.next_index += 1;
        self.last_pts = self.decoded.timestamp().or_else(|| self.decoded.pts());
        let t = self
            .last_pts
            .zip(self.time_base)
            .map(|(ts, tb)| ts as f64 * tb);

        let (format, w, h) = (
            self.decoded.format(),
            self.decoded.width(),
            self.decoded.height(),
        );
        if self
            .scaler
            .as_ref()
            .is_none_or(|s| s.input != (format, w, h))
        {
            // First frame, or the stream changed size or pixel format mid-way (legal in MPEG-TS,
            // WebM): build a converter for what actually arrives rather than what the header said.
            let (ow, oh) = self.target.unwrap_or((w, h));
            let flags = if ow < w && oh < h {
                ff::software::scaling::Flags::AREA
            } else {
                ff::software::scaling::Flags::BILINEAR
            };
            let ctx = ff::software::scaling::Context::get(
                format,
                w,
                h,
                ff::format::Pixel::RGB24,
                ow,
                oh,
                flags,
            )
            .map_err(|e| {
                self.error(format!(
                    "frame {index}: cannot convert {format:?} {w}x{h} to RGB: {e}"
                ))
            })?;
            self.scaler = Some(Scaler {
                ctx,
                input: (format, w, h),
            });
            // The output buffer is reallocated by the scaler for the new size.
            self.rgb = ff::frame::Video::empty();
        }
        let scaler = self.scaler.as_mut().ok_or_else(|| DataError::Frames {
            path: self.path.clone(),
            msg: format!("frame {index}: no RGB converter"),
        })?;
        if let Err(e) = scaler.ctx.run(&self.decoded, &mut self.rgb) {
            return Err(self.error(format!("frame {index}: cannot convert to RGB: {e}")));
        }
        let image = rgb_image(&self.rgb)
            .ok_or_else(|| self.error(format!("frame {index}: RGB frame smaller than its size")))?;
        Ok(Frame {
            index,
            name: format!("{index:06}"),
            t,
            image,
        })
    }
}

/// Copies an RGB24 frame into an image row by row: FFmpeg pads each row to its stride (alignment
/// for SIMD), which can exceed `3 * width`.
fn rgb_image(frame: &ff::frame::Video) -> Option<image::RgbImage> {
    let (w, h) = (frame.width(), frame.height());
    let row = 3 * w as usize;
    let stride = frame.stride(0);
    let data = frame.data(0);
    let mut buf = Vec::with_capacity(row * h as usize);
    for y in 0..h as usize {
        buf.extend_from_slice(data.get(y * stride..y * stride + row)?);
    }
    image::RgbImage::from_raw(w, h, buf)
}

/// The frame count the container states, else one estimated from the duration and frame rate.
fn len_hint(
    input: &ff::format::context::Input,
    stream: &ff::format::stream::Stream<'_>,
    time_base: Option<f64>,
    fps: Option<f64>,
) -> Option<u64> {
    if let Ok(n @ 1..) = u64::try_from(stream.frames()) {
        return Some(n);
    }
    let fps = fps?;
    let seconds = match (stream.duration(), time_base) {
        (d, Some(tb)) if d > 0 => d as f64 * tb,
        // The container's duration, in AV_TIME_BASE (microsecond) units.
        _ if input.duration() > 0 => input.duration() as f64 / f64::from(ff::ffi::AV_TIME_BASE),
        _ => return None,
    };
    Some((seconds * fps).round() as u64)
}

impl Iterator for VideoFile {
    type Item = Result<Frame>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}

impl FrameSource for VideoFile {
    fn len_hint(&self) -> Option<u64> {
        self.len_hint
    }

    fn fps(&self) -> Option<f64> {
        self.fps
    }

    fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{shared, tmp};

    /// Mean absolute difference of the green channels of two equal-size images.
    fn mean_diff(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
        let sum: u64 = a
            .pixels()
            .zip(b.pixels())
            .map(|(p, q)| u64::from(p[1].abs_diff(q[1])))
            .sum();
        sum as f64 / f64::from(a.width() * a.height())
    }

    #[test]
    fn frames_video_real_cuts_decodes_every_frame() -> Result<()> {
        // README: H.264 320x240, 25 fps CFR, 475 frames; hard cuts at 97, 217, 337, 405.
        let path = shared("data/scenecut_real/opencv_samples_cuts.mp4");
        let mut src = VideoFile::open(&path)?;
        assert_eq!(src.len_hint(), Some(475));
        assert!(
            (src.fps().unwrap_or(0.0) - 25.0).abs() < 1e-9,
            "{:?}",
            src.fps()
        );
        assert_eq!(src.frame_size(), (320, 240));
        assert_eq!(src.path(), path.as_path());

        let mut count = 0u64;
        let mut last_t = f64::NEG_INFINITY;
        let mut prev: Option<image::RgbImage> = None;
        let mut diffs = Vec::new();
        for frame in src.by_ref() {
            let f = frame?;
            assert_eq!(f.index, count);
            assert_eq!(f.name, format!("{count:06}"));
            assert_eq!(f.image.dimensions(), (320, 240));
            let t =
                f.t.ok_or_else(|| DataError::invalid(&path, "frame without timestamp"))?;
            assert!(t > last_t, "frame {count}: t {t} after {last_t}");
            assert!(
                (t - count as f64 / 25.0).abs() < 1e-6,
                "frame {count}: t {t}"
            );
            last_t = t;
            if let Some(p) = &prev {
                diffs.push(mean_diff(p, &f.image));
            }
            prev = Some(f.image);
            count += 1;
        }
        assert_eq!(count, 475);
        assert!(src.next().is_none(), "an ended source stays ended");
        // Frames come in order: the change into frame 97 (a film cut) dwarfs the ones around it.
        // diffs[i] is the change from frame i to frame i + 1.
        assert!(
            diffs[96] > 30.0 && diffs[95] < 10.0 && diffs[97] < 10.0,
            "{:?}",
            &diffs[94..99]
        );
        Ok(())
    }

    #[test]
    fn frames_video_peer_testdata_and_open() -> Result<()> {
        let path = shared("tools/peers/testdata/video/cuts.mp4");
        let mut src = super::super::open(&path)?;
        assert_eq!(src.len_hint(), Some(200));
        let mut n = 0;
        for f in src.by_ref() {
            assert_eq!(f?.image.dimensions(), (320, 240));
            n += 1;
        }
        assert_eq!(n, 200);
        Ok(())
    }

    #[test]
    fn frames_video_variable_frame_rate_timestamps() -> Result<()> {
        // Every third frame of a 23.976 fps clip dropped: 160 frames, 1280x544, gaps of one and
        // two frame periods. Scaled on decode to keep the test fast.
        let path = shared("data/scenecut_pyscenedetect/goldeneye-vfr-drop3.mp4");
        let src = VideoFile::open_scaled(&path, Some((320, 136)))?;
        let fps = src.fps().unwrap_or(0.0);
        assert!((15.0..17.0).contains(&fps), "average rate {fps}");
        let mut ts = Vec::new();
        for f in src {
            let f = f?;
            assert_eq!(f.image.dimensions(), (320, 136));
            ts.push(f.t.ok_or_else(|| DataError::invalid(&path, "no timestamp"))?);
        }
        assert_eq!(ts.len(), 160);
        let period = 1001.0 / 24000.0;
        let gaps: Vec<f64> = ts.windows(2).map(|w| (w[1] - w[0]) / period).collect();
        assert!(gaps.iter().all(|g| *g > 0.5), "timestamps must increase");
        assert!(gaps.iter().any(|g| (g - 1.0).abs() < 0.05));
        assert!(gaps.iter().any(|g| (g - 2.0).abs() < 0.05));
        Ok(())
    }

    #[test]
    fn frames_video_scaled_on_decode() -> Result<()> {
        // 1280x720 at 29.97 fps, 720 frames; only the first frames are decoded.
        let path = shared("data/scenecut_pyscenedetect/testvideo.mp4");
        let full = VideoFile::open(&path)?;
        assert_eq!(full.frame_size(), (1280, 720));
        assert_eq!(full.len_hint(), Some(720));
        assert!((full.fps().unwrap_or(0.0) - 30000.0 / 1001.0).abs() < 1e-9);
        let mut small = VideoFile::open_scaled(&path, Some((160, 90)))?;
        assert_eq!(small.frame_size(), (160, 90));
        for i in 0..5 {
            let f = small
                .next()
                .ok_or_else(|| DataError::invalid(&path, "too few frames"))??;
            assert_eq!((f.index, f.image.dimensions()), (i, (160, 90)));
        }
        let e = VideoFile::open_scaled(&path, Some((0, 90)))
            .err()
            .map(|e| e.to_string());
        assert!(e.unwrap_or_default().contains("0x90"));
        Ok(())
    }

    #[test]
    fn frames_video_errors_name_the_file() -> Result<()> {
        let dir = tmp()?;
        let missing = dir.path().join("missing.mp4");
        let e = VideoFile::open(&missing)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("missing.mp4") && e.contains("No such file"),
            "{e}"
        );

        let text = dir.path().join("notes.mp4");
        std::fs::write(&text, "this is a text file, not a video\n".repeat(20))
            .map_err(|e| DataError::io(&text, e))?;
        let e = VideoFile::open(&text)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("notes.mp4") && e.contains("cannot open as a video"),
            "{e}"
        );
        let e = super::super::open(&text)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("notes.mp4"), "{e}");

        // A valid audio file (WAV, 0.1 s of silence) named .mp4: FFmpeg opens it by content and
        // finds no picture.
        let wav = dir.path().join("sound.mp4");
        let samples = 800u32;
        let mut bytes = Vec::new();
        bytes.extend_from_slice(b"RIFF");
        bytes.extend_from_slice(&(36 + 2 * samples).to_le_bytes());
        bytes.extend_from_slice(b"WAVEfmt ");
        bytes.extend_from_slice(&16u32.to_le_bytes());
        bytes.extend_from_slice(&1u16.to_le_bytes()); // PCM
        bytes.extend_from_slice(&1u16.to_le_bytes()); // mono
        bytes.extend_from_slice(&8000u32.to_le_bytes()); // sample rate
        bytes.extend_from_slice(&16000u32.to_le_bytes()); // byte rate
        bytes.extend_from_slice(&2u16.to_le_bytes()); // block align
        bytes.extend_from_slice(&16u16.to_le_bytes()); // bits per sample
        bytes.extend_from_slice(b"data");
        bytes.extend_from_slice(&(2 * samples).to_le_bytes());
        bytes.resize(bytes.len() + 2 * samples as usize, 0);
        std::fs::write(&wav, bytes).map_err(|e| DataError::io(&wav, e))?;
        let e = VideoFile::open(&wav)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("sound.mp4") && e.contains("no video stream"),
            "{e}"
        );

        let e = VideoFile::open(dir.path())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("folder"), "{e}");
        Ok(())
    }

    #[test]
    fn frames_video_rows_are_copied_without_stride_padding() -> Result<()> {
        // 5 pixels = 15 bytes a row; FFmpeg pads rows to its alignment, so stride > 15.
        let mut frame = ff::frame::Video::new(ff::format::Pixel::RGB24, 5, 3);
        let stride = frame.stride(0);
        assert!(stride > 15, "stride {stride}: the test needs a padded row");
        let data = frame.data_mut(0);
        for y in 0..3 {
            for i in 0..stride {
                // Pixel bytes carry their position; padding carries 255, which must not leak.
                data[y * stride + i] = if i < 15 { (10 * y + i) as u8 } else { 255 };
            }
        }
        let img = rgb_image(&frame).ok_or_else(|| DataError::invalid("frame", "short data"))?;
        assert_eq!(img.dimensions(), (5, 3));
        for (x, y, p) in img.enumerate_pixels() {
            let first = (10 * y + 3 * x) as u8;
            assert_eq!(p.0, [first, first + 1, first + 2], "pixel {x},{y}");
        }
        Ok(())
    }

    #[test]
    fn frames_video_source_is_send() {
        fn is_send<T: Send>() {}
        is_send::<VideoFile>();
        is_send::<Box<dyn FrameSource + Send>>();
    }

    /// Decode speed in frames per second; run with
    /// `cargo test --release -p data -- --ignored frames_video_decode_speed --nocapture`.
    #[test]
    #[ignore = "timing, run by hand in release mode"]
    fn frames_video_decode_speed() -> Result<()> {
        let cases = [
            ("data/scenecut_real/opencv_samples_cuts.mp4", None),
            ("data/scenecut_pyscenedetect/testvideo.mp4", None),
            (
                "data/scenecut_pyscenedetect/testvideo.mp4",
                Some((320, 180)),
            ),
        ];
        for (rel, size) in cases {
            let mut best = 0.0f64;
            let mut frames = 0;
            for _ in 0..3 {
                let start = std::time::Instant::now();
                frames = 0;
                for f in VideoFile::open_scaled(&shared(rel), size)? {
                    std::hint::black_box(f?);
                    frames += 1;
                }
                best = best.max(frames as f64 / start.elapsed().as_secs_f64());
            }
            println!(
                "decode speed {rel} scaled {size:?}: {frames} frames, {best:.0} frames/s (best of 3)"
            );
        }
        Ok(())
    }
}
