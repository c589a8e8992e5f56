//! Decoding one image file, refusing truncated JPEGs.
//!
//! The `image` crate's JPEG decoder (zune-jpeg) is lenient: a JPEG cut off mid-scan decodes
//! without an error, the missing part filled in grey. A truncated upload would then become a
//! training image or a pose query with half its content made up. So before decoding, a JPEG
//! must have an end-of-image marker (`FF D9`) after its last start-of-scan marker (`FF DA`); the
//! entropy-coded data cannot contain either (a data byte `FF` is stuffed as `FF 00`), and an
//! embedded EXIF thumbnail comes before the main image's scans. PNG's decoder already checks
//! chunk lengths and CRCs.

use crate::error::{DataError, Result};
use std::path::Path;

/// Decodes the image at `path`, its format recognised from the content (a PNG named `.jpg` still
/// reads). Errors name the file: unreadable, not an image, corrupt, or a truncated JPEG.
pub fn decode_image(path: &Path) -> Result<image::DynamicImage> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    let err = |msg: String| DataError::frames(path, msg);
    let format = image::guess_format(&bytes)
        .map_err(|_| err("not an image (unknown file signature)".into()))?;
    if format == image::ImageFormat::Jpeg && !jpeg_is_complete(&bytes) {
        return Err(err(
            "truncated JPEG (no end-of-image marker after the last scan)".into(),
        ));
    }
    image::load_from_memory_with_format(&bytes, format)
        .map_err(|e| err(format!("cannot decode image: {e}")))
}

/// True when an end-of-image marker follows the last start-of-scan marker.
fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let mut last_sos = None;
    let mut eoi_after_sos = false;
    for (i, pair) in bytes.windows(2).enumerate() {
        if pair[0] != 0xFF {
            continue;
        }
        match pair[1] {
            0xDA => {
                last_sos = Some(i);
                eoi_after_sos = false;
            }
            0xD9 if last_sos.is_some() => eoi_after_sos = true,
            _ => {}
        }
    }
    eoi_after_sos
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jpeg() -> Vec<u8> {
        let img =
            image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([x as u8 * 4, y as u8 * 5, 90]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Jpeg)
            .unwrap_or_default();
        out.into_inner()
    }

    #[test]
    fn whole_jpegs_decode_and_cut_ones_are_refused() -> Result<()> {
        let dir = tempfile::tempdir().map_err(|e| DataError::io(Path::new("tmp"), e))?;
        let bytes = jpeg();
        assert!(jpeg_is_complete(&bytes));
        let whole = dir.path().join("whole.jpg");
        std::fs::write(&whole, &bytes).map_err(|e| DataError::io(&whole, e))?;
        assert_eq!(decode_image(&whole)?.width(), 64);
        for keep in [bytes.len() - 2, bytes.len() / 2, 700] {
            let cut = dir.path().join(format!("cut{keep}.jpg"));
            std::fs::write(&cut, &bytes[..keep]).map_err(|e| DataError::io(&cut, e))?;
            let e = decode_image(&cut).map(|_| ()).unwrap_err().to_string();
            assert!(
                e.contains(&format!("cut{keep}.jpg")) && e.contains("truncated"),
                "{e}"
            );
        }
        // Trailing bytes after the end marker (some cameras append data) are fine.
        let mut padded = bytes.clone();
        padded.extend_from_slice(&[0, 0, 0]);
        assert!(jpeg_is_complete(&padded));
        let text = dir.path().join("notes.png");
        std::fs::write(&text, b"hello").map_err(|e| DataError::io(&text, e))?;
        let e = decode_image(&text).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("notes.png") && e.contains("not an image"), "{e}");
        Ok(())
    }
}
