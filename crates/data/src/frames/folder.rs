//! Image folders as frame sources: the folder is listed once, in natural order, and each image is
//! decoded only when the iterator reaches it, so memory stays at one image however long the
//! folder is.

use super::{Frame, FrameSource, IMAGE_EXTENSIONS, has_extension};
use crate::error::{DataError, Result};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// The images of a folder (extensions [`IMAGE_EXTENSIONS`], any case), in natural order of their
/// file names (`frame2` before `frame10`, see [`natural_cmp`]), decoded lazily one at a time.
///
/// Sub-folders, other files and hidden files (names starting with `.`, such as macOS's `._x.jpg`
/// resource forks, which look like images but are not) are skipped. An image that fails to decode
/// yields an `Err` naming the file and the iteration goes on with the next file.
#[derive(Debug, Clone)]
pub struct ImageFolder {
    root: PathBuf,
    files: Vec<PathBuf>,
    next: usize,
}

impl ImageFolder {
    /// Lists the images of `dir`.
    ///
    /// # Errors
    /// `dir` cannot be read (missing, not a folder) or holds no image file; the message names it.
    pub fn open(dir: &Path) -> Result<Self> {
        let entries = std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))?;
        let mut files = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| DataError::io(dir, e))?;
            let path = entry.path();
            let hidden = entry.file_name().to_string_lossy().starts_with('.');
            // `is_file` follows symbolic links, so linked images count like plain ones.
            if !hidden && has_extension(&path, IMAGE_EXTENSIONS) && path.is_file() {
                files.push(path);
            }
        }
        // Sort by file name only: all entries share the folder, and the names are what a user
        // numbered.
        files.sort_by(|a, b| natural_cmp(&file_name(a), &file_name(b)));
        Self::from_files(dir, files)
    }

    /// A source over the given image files, in the given order; `label` names the source in
    /// messages and [`FrameSource::path`] (the folder, or the file for a single image).
    ///
    /// # Errors
    /// `files` is empty; the message names `label`.
    pub fn from_files(label: &Path, files: Vec<PathBuf>) -> Result<Self> {
        if files.is_empty() {
            return Err(DataError::Frames {
                path: label.to_path_buf(),
                msg: format!("no images ({}) in this folder", IMAGE_EXTENSIONS.join(", ")),
            });
        }
        Ok(Self {
            root: label.to_path_buf(),
            files,
            next: 0,
        })
    }

    /// All image files of the source, in frame order (including those already read).
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Decodes one image file to RGB (see [`super::decode_image`]).
fn decode(path: &Path) -> Result<image::RgbImage> {
    Ok(super::decode_image(path)?.into_rgb8())
}

impl Iterator for ImageFolder {
    type Item = Result<Frame>;

    fn next(&mut self) -> Option<Self::Item> {
        let path = self.files.get(self.next)?;
        let index = self.next as u64;
        // Advance before decoding so that a failed file is skipped on the next call.
        self.next += 1;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| format!("{index:06}"));
        Some(decode(path).map(|image| Frame {
            index,
            name,
            t: None,
            image,
        }))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.files.len().saturating_sub(self.next);
        (left, Some(left))
    }

    // Skipping must not decode the skipped images (the default `nth` calls `next` n times).
    fn nth(&mut self, n: usize) -> Option<Self::Item> {
        self.next = self.next.saturating_add(n).min(self.files.len());
        self.next()
    }
}

impl ExactSizeIterator for ImageFolder {}

impl FrameSource for ImageFolder {
    fn len_hint(&self) -> Option<u64> {
        Some(self.files.len() as u64)
    }

    fn fps(&self) -> Option<f64> {
        None
    }

    fn path(&self) -> &Path {
        &self.root
    }
}

/// Natural ("human") order of two names: runs of ASCII digits compare as numbers, so `f2` <
/// `f10` and `img_9.png` < `img_010.png`; other text compares case-insensitively. Names that
/// differ only in case or in leading zeros are ordered after that by the plain string order, so
/// the order is total and sorting is deterministic.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a, b);
    loop {
        let (Some(cx), Some(cy)) = (x.chars().next(), y.chars().next()) else {
            // One name is a prefix of the other (shorter first), or they are equal up to case and
            // leading zeros: then the plain order decides.
            return x
                .is_empty()
                .cmp(&y.is_empty())
                .reverse()
                .then_with(|| a.cmp(b));
        };
        if cx.is_ascii_digit() && cy.is_ascii_digit() {
            let (nx, rx) = split_digits(x);
            let (ny, ry) = split_digits(y);
            let ord = cmp_numbers(nx, ny);
            if ord != Ordering::Equal {
                return ord;
            }
            (x, y) = (rx, ry);
        } else {
            // Character by character (not run by run), so `a.png` < `a1.png` as '.' < '1'.
            let ord = cx.to_lowercase().cmp(cy.to_lowercase());
            if ord != Ordering::Equal {
                return ord;
            }
            (x, y) = (&x[cx.len_utf8()..], &y[cy.len_utf8()..]);
        }
    }
}

/// Splits `s` after its leading run of ASCII digits.
fn split_digits(s: &str) -> (&str, &str) {
    s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()))
}

/// Compares two digit runs by value without parsing, so runs longer than `u64` still work.
fn cmp_numbers(a: &str, b: &str) -> Ordering {
    let a = a.trim_start_matches('0');
    let b = b.trim_start_matches('0');
    a.len().cmp(&b.len()).then_with(|| a.cmp(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{shared_data, tmp};

    fn write_png(path: &Path, w: u32, h: u32, shade: u8) -> Result<()> {
        image::RgbImage::from_pixel(w, h, image::Rgb([shade, 0, 255 - shade]))
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| DataError::invalid(path, e.to_string()))
    }

    #[test]
    fn frames_natural_order() {
        let mut names = vec![
            "f10.png",
            "f2.png",
            "f1.png",
            "F3.png",
            "f02.png",
            "a.png",
            "a1.png",
            "img_010.png",
            "img_9.png",
            "x99999999999999999999999.png",
            "x100000000000000000000000.png",
        ];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            [
                "a.png",
                "a1.png",
                "f1.png",
                "f02.png",
                "f2.png",
                "F3.png",
                "f10.png",
                "img_9.png",
                "img_010.png",
                "x99999999999999999999999.png",
                "x100000000000000000000000.png",
            ]
        );
        assert_eq!(natural_cmp("frame2", "frame10"), Ordering::Less);
        assert_eq!(natural_cmp("abc", "abc"), Ordering::Equal);
        assert_ne!(natural_cmp("A1", "a1"), Ordering::Equal);
    }

    #[test]
    fn frames_folder_in_natural_order_skipping_other_files() -> Result<()> {
        let dir = tmp()?;
        for (i, name) in ["f10.png", "f1.png", "f2.png"].iter().enumerate() {
            write_png(&dir.path().join(name), 8 + i as u32, 5, 40 * i as u8)?;
        }
        std::fs::write(dir.path().join("notes.txt"), "not an image")
            .map_err(|e| DataError::io(dir.path(), e))?;
        std::fs::create_dir(dir.path().join("sub.png"))
            .map_err(|e| DataError::io(dir.path(), e))?;

        let mut src = ImageFolder::open(dir.path())?;
        assert_eq!(src.len_hint(), Some(3));
        assert_eq!(src.len(), 3);
        assert_eq!(src.fps(), None);
        assert_eq!(src.path(), dir.path());
        let mut got = Vec::new();
        for frame in src.by_ref() {
            let f = frame?;
            got.push((f.index, f.name, f.t, f.image.dimensions()));
        }
        assert_eq!(
            got,
            [
                (0, "f1".to_string(), None, (9, 5)),
                (1, "f2".to_string(), None, (10, 5)),
                (2, "f10".to_string(), None, (8, 5)),
            ]
        );
        assert_eq!(src.len(), 0);
        Ok(())
    }

    #[test]
    fn frames_folder_nth_skips_without_decoding() -> Result<()> {
        let dir = tmp()?;
        write_png(&dir.path().join("a1.png"), 2, 2, 0)?;
        // Corrupt, but never decoded: `nth` jumps over it.
        std::fs::write(dir.path().join("a2.png"), b"junk")
            .map_err(|e| DataError::io(dir.path(), e))?;
        write_png(&dir.path().join("a3.png"), 2, 2, 0)?;
        let mut src = ImageFolder::open(dir.path())?;
        let f = src
            .nth(2)
            .ok_or_else(|| DataError::invalid(dir.path(), "no frame"))??;
        assert_eq!((f.index, f.name.as_str()), (2, "a3"));
        assert!(src.nth(5).is_none());
        Ok(())
    }

    #[test]
    fn frames_empty_folder_is_an_error_naming_it() -> Result<()> {
        let dir = tmp()?;
        std::fs::write(dir.path().join("readme.md"), "x")
            .map_err(|e| DataError::io(dir.path(), e))?;
        let e = ImageFolder::open(dir.path())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains(&dir.path().display().to_string()) && e.contains("no images"),
            "{e}"
        );
        let e = ImageFolder::open(&dir.path().join("absent"))
            .err()
            .map(|e| e.to_string());
        assert!(e.unwrap_or_default().contains("absent"));
        Ok(())
    }

    #[test]
    fn frames_corrupt_image_names_the_file_and_iteration_goes_on() -> Result<()> {
        let dir = tmp()?;
        std::fs::write(
            dir.path().join("bad.png"),
            b"\x89PNG\r\n\x1a\nthis is not a png",
        )
        .map_err(|e| DataError::io(dir.path(), e))?;
        write_png(&dir.path().join("f1.png"), 3, 2, 7)?;
        let mut src = ImageFolder::open(dir.path())?;
        let first = src
            .next()
            .ok_or_else(|| DataError::invalid(dir.path(), "no item"))?;
        let e = first.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("bad.png") && e.contains("cannot decode"), "{e}");
        let f = src
            .next()
            .ok_or_else(|| DataError::invalid(dir.path(), "no item"))??;
        assert_eq!(
            (f.index, f.name.as_str(), f.image.dimensions()),
            (1, "f1", (3, 2))
        );
        assert!(src.next().is_none());
        Ok(())
    }

    #[test]
    fn frames_real_jpeg_folder_first_frames() -> Result<()> {
        let dir = &shared_data("fox_posed/images");
        let mut src = ImageFolder::open(dir)?;
        assert_eq!(src.len_hint(), Some(50));
        // Two frames only: a 1080x1920 JPEG takes a while to decode in a debug build.
        for (i, name) in [(0, "0001"), (1, "0002")] {
            let f = src
                .next()
                .ok_or_else(|| DataError::invalid(dir, "too few frames"))??;
            assert_eq!((f.index, f.name.as_str()), (i, name));
            assert_eq!(f.image.dimensions(), (1080, 1920));
            // A real photo, not a blank: its pixels vary.
            let (lo, hi) = f
                .image
                .pixels()
                .fold((255u8, 0u8), |(lo, hi), p| (lo.min(p[1]), hi.max(p[1])));
            assert!(hi - lo > 100, "green channel spans only {lo}..{hi}");
        }
        Ok(())
    }
}
