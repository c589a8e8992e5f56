//! Texture images for imported materials: decoding (PNG, JPEG, BMP, told apart by content, not
//! by name), a cache so a texture shared by many materials is decoded once, and the small URI
//! decoders glTF needs (`data:` URIs in base64, percent-encoded file names).

use image::RgbImage;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Decoded textures by file, `Err` remembering why one failed.
#[derive(Debug, Default)]
pub(super) struct Cache {
    /// The decoded images.
    files: HashMap<PathBuf, Result<Arc<RgbImage>, String>>,
}

impl Cache {
    /// The image in `path`, decoded once; `Err` says why it cannot be used.
    pub fn file(&mut self, path: &Path) -> Result<Arc<RgbImage>, String> {
        self.files
            .entry(path.to_path_buf())
            .or_insert_with(|| {
                let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
                decode(&bytes).map(Arc::new)
            })
            .clone()
    }
}

/// Decodes an encoded image (PNG, JPEG or BMP, recognised by its first bytes) to 8-bit RGB;
/// alpha is dropped (the renderer has no transparency).
pub(super) fn decode(bytes: &[u8]) -> Result<RgbImage, String> {
    let img = image::load_from_memory(bytes).map_err(|e| match e {
        image::ImageError::Unsupported(_) => {
            format!("{e} (indoorloc reads PNG, JPEG and BMP textures)")
        }
        _ => e.to_string(),
    })?;
    if img.width() == 0 || img.height() == 0 {
        return Err("the image is empty".into());
    }
    Ok(img.to_rgb8())
}

/// Decodes standard base64 (RFC 4648, `=` padding optional, whitespace skipped); `None` on any
/// other character or a dangling bit group.
pub(super) fn base64(text: &str) -> Option<Vec<u8>> {
    fn value(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some(u32::from(c - b'A')),
            b'a'..=b'z' => Some(u32::from(c - b'a') + 26),
            b'0'..=b'9' => Some(u32::from(c - b'0') + 52),
            b'+' | b'-' => Some(62),
            b'/' | b'_' => Some(63),
            _ => None,
        }
    }
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let mut acc = 0u32;
    let mut bits = 0u32;
    for &c in text.as_bytes() {
        if c == b'=' || c.is_ascii_whitespace() {
            continue;
        }
        acc = (acc << 6) | value(c)?;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    (bits < 6).then_some(out)
}

/// Undoes `%XX` escapes in a URI (file names with spaces); malformed escapes stay as written.
pub(super) fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn import_base64_and_percent_decoding() -> Result<(), String> {
        let cases = [
            ("", ""),
            ("TQ==", "M"),
            ("TWE=", "Ma"),
            ("TWFu", "Man"),
            ("TWFuIGlz", "Man is"),
        ];
        for (b64, plain) in cases {
            if base64(b64).as_deref() != Some(plain.as_bytes()) {
                return Err(format!("base64 {b64}"));
            }
        }
        if base64("TWF*").is_some() || base64("T").is_some() {
            return Err("accepted bad base64".into());
        }
        if percent_decode("my%20room%2Fa.png") != "my room/a.png" || percent_decode("50%") != "50%"
        {
            return Err("percent decoding".into());
        }
        Ok(())
    }
}
