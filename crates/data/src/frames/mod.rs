//! Frame sources: the images of an image folder or the frames of a video file, one at a time.
//!
//! Scene-cut detection, localization and live tracking read long inputs, so every source streams:
//! it holds one decoded frame at a time (plus the decoder's own small look-ahead for video), never
//! the whole input. A source is an [`Iterator`] of `Result<Frame>`; an error for one frame (a
//! corrupt image, a damaged packet) does not end the iteration, so the caller decides whether to
//! stop or skip. [`open`] picks the source from the path.
//!
//! Video needs the `video` cargo feature (default on; FFmpeg's libraries through `ffmpeg-next`).

mod decode;
mod folder;
#[cfg(feature = "video")]
mod parallel;
#[cfg(feature = "video")]
mod video;

pub use decode::decode_image;
pub use folder::{ImageFolder, natural_cmp};
#[cfg(feature = "video")]
pub use parallel::ParallelVideo;
#[cfg(feature = "video")]
pub use video::VideoFile;

use crate::error::{DataError, Result};
use std::path::Path;

/// File extensions (lower case) read as images by [`ImageFolder`]; matching ignores case.
///
/// `bmp` is listed because users bring such folders, but decoding it needs the `image` crate's
/// `bmp` feature; without it a `.bmp` file gives a decode error naming the file.
pub const IMAGE_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg", "bmp"];

/// File extensions (lower case) that [`open`] reads as video; matching ignores case.
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "avi", "mkv", "mov", "webm", "m4v", "mpg"];

/// One decoded frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Position in the source, from 0: for an image folder the file's place in the sorted listing
    /// (also for files that failed to decode, so indices stay tied to files); for a video the
    /// count of frames decoded before this one.
    pub index: u64,
    /// The image file's stem, or the index as `{index:06}` for video frames.
    pub name: String,
    /// Presentation time in seconds (the stream's pts times its time base), or `None` where the
    /// source has no clock (image folders) or the frame carries no timestamp.
    pub t: Option<f64>,
    /// The pixels, 8-bit RGB.
    pub image: image::RgbImage,
}

/// A stream of frames. Iteration yields `Err` for a frame that could not be read and goes on with
/// the next one; it ends with `None`.
pub trait FrameSource: Iterator<Item = Result<Frame>> {
    /// How many frames the source expects to give: exact for an image folder, the container's
    /// figure (or duration × frame rate) for a video, `None` when unknown. A hint for progress
    /// bars and buffer sizes, not a promise.
    fn len_hint(&self) -> Option<u64>;

    /// Frames per second where the source knows it (a video's average frame rate), else `None`.
    fn fps(&self) -> Option<f64>;

    /// The folder or file the frames come from, for messages.
    fn path(&self) -> &Path;
}

// Lets generic code (`fn run<S: FrameSource>(s: S)`) take the boxed source that `open` returns.
impl<S: FrameSource + ?Sized> FrameSource for Box<S> {
    fn len_hint(&self) -> Option<u64> {
        (**self).len_hint()
    }

    fn fps(&self) -> Option<f64> {
        (**self).fps()
    }

    fn path(&self) -> &Path {
        (**self).path()
    }
}

/// Whether `path`'s extension is one of `exts` (which are lower case), ignoring case.
pub(crate) fn has_extension(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Opens the frame source that `path` names: a folder is an [`ImageFolder`], a file with a video
/// extension ([`VIDEO_EXTENSIONS`]) a `VideoFile` at its own size, and a single
/// image file a one-frame [`ImageFolder`].
///
/// The source is `Send` so a server can move it into a worker thread.
///
/// # Errors
/// A missing path, an empty folder, a file that is neither video nor image, a video that FFmpeg
/// cannot open, or a video when the crate was built without the `video` feature; every message
/// names the path.
pub fn open(path: &Path) -> Result<Box<dyn FrameSource + Send>> {
    let meta = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
    if meta.is_dir() {
        return Ok(Box::new(ImageFolder::open(path)?));
    }
    if has_extension(path, VIDEO_EXTENSIONS) {
        return open_video(path);
    }
    if has_extension(path, IMAGE_EXTENSIONS) {
        return Ok(Box::new(ImageFolder::from_files(
            path,
            vec![path.to_path_buf()],
        )?));
    }
    Err(DataError::Frames {
        path: path.to_path_buf(),
        msg: format!(
            "not a frame source: expected a folder of images, an image ({}) or a video ({})",
            IMAGE_EXTENSIONS.join(", "),
            VIDEO_EXTENSIONS.join(", ")
        ),
    })
}

#[cfg(feature = "video")]
fn open_video(path: &Path) -> Result<Box<dyn FrameSource + Send>> {
    Ok(Box::new(VideoFile::open(path)?))
}

#[cfg(not(feature = "video"))]
fn open_video(path: &Path) -> Result<Box<dyn FrameSource + Send>> {
    Err(DataError::Frames {
        path: path.to_path_buf(),
        msg:
            "this binary was built without video support (cargo feature `video` of crate `data`); \
              extract the frames to an image folder, or rebuild with the feature"
                .into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_open_dispatches_and_names_the_path() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let missing = dir.path().join("nothing-here.mp4");
        let e = open(&missing)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("nothing-here.mp4"), "{e}");

        let txt = dir.path().join("notes.txt");
        std::fs::write(&txt, "hello").map_err(|e| DataError::io(&txt, e))?;
        let e = open(&txt).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains("notes.txt") && e.contains("not a frame source"),
            "{e}"
        );

        let png = dir.path().join("one.PNG");
        image::RgbImage::new(4, 3)
            .save_with_format(&png, image::ImageFormat::Png)
            .map_err(|e| DataError::invalid(&png, e.to_string()))?;
        let mut src = open(&png)?;
        assert_eq!(src.len_hint(), Some(1));
        let f = src
            .next()
            .ok_or_else(|| DataError::invalid(&png, "no frame"))??;
        assert_eq!((f.name.as_str(), f.image.dimensions()), ("one", (4, 3)));
        assert!(src.next().is_none());

        let mut src = open(dir.path())?;
        assert_eq!(src.fps(), None);
        assert!(src.next().is_some_and(|f| f.is_ok()));
        Ok(())
    }

    #[test]
    fn frames_extensions_ignore_case() {
        assert!(has_extension(Path::new("a/B.MP4"), VIDEO_EXTENSIONS));
        assert!(has_extension(Path::new("x.JpEg"), IMAGE_EXTENSIONS));
        assert!(!has_extension(Path::new("mp4"), VIDEO_EXTENSIONS));
        assert!(!has_extension(Path::new("x.txt"), IMAGE_EXTENSIONS));
    }

    #[cfg(not(feature = "video"))]
    #[test]
    fn frames_video_without_feature_says_so() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("clip.mp4");
        std::fs::write(&p, b"x").map_err(|e| DataError::io(&p, e))?;
        let e = open(&p).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains("clip.mp4") && e.contains("without video support"),
            "{e}"
        );
        Ok(())
    }
}
