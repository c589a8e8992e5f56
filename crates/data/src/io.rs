//! File helpers shared by every format: reading text with the path in the error, and atomic
//! writes (temporary file in the same folder, then rename) so a crash never leaves half a file.

use crate::error::{DataError, Result};
use crate::trajectory::PoseFrame;
use std::io::Write;
use std::path::Path;

/// Reads a whole text file; binary garbage (invalid UTF-8) is an error naming the file.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        DataError::invalid(
            path,
            format!(
                "not a text file (invalid UTF-8 at byte {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Writes `path` atomically: the content goes to a temporary file beside it, which is renamed
/// over `path` only when complete. Parent folders are created.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
    let name = path
        .file_name()
        .ok_or_else(|| DataError::invalid(path, "not a file path"))?
        .to_string_lossy();
    // Process id and a counter keep concurrent writers (threads, processes) off each other's
    // temporary files.
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}.{}-{n}.tmp", std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        DataError::io(path, e)
    })
}

/// Writes a string atomically (see [`write_atomic`]).
pub fn write_text_atomic(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Parses whitespace- (or comma-) separated numbers of one line, naming the line on failure.
pub fn parse_numbers(path: &Path, line_no: usize, fields: &[&str]) -> Result<Vec<f64>> {
    fields
        .iter()
        .map(|f| {
            let v: f64 = f
                .parse()
                .map_err(|_| DataError::parse(path, line_no, format!("'{f}' is not a number")))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(DataError::parse(
                    path,
                    line_no,
                    format!("non-finite value '{f}'"),
                ))
            }
        })
        .collect()
}

/// The shortest text that parses back to the same `f64` (Rust's `{}`, or `{:e}` for very large
/// and very small magnitudes, where `{}` would print hundreds of digits).
pub fn fmt_f64(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-5..1e16).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Refuses to write a frame holding NaN or infinity: the file could not be read back.
pub fn require_finite(path: &Path, frame: &PoseFrame) -> Result<()> {
    let q = frame.pose.rotation.coords;
    let finite = frame.pose.translation.iter().all(|v| v.is_finite())
        && q.iter().all(|v| v.is_finite())
        && frame.t.is_none_or(f64::is_finite);
    if finite {
        Ok(())
    } else {
        Err(DataError::invalid(
            path,
            format!("frame '{}' holds a non-finite value", frame.name),
        ))
    }
}

/// Parses exactly `N` numeric fields of a line; `count_msg` describes a wrong field count.
pub fn fixed_numbers<const N: usize>(
    path: &Path,
    line_no: usize,
    fields: &[&str],
    count_msg: impl FnOnce() -> String,
) -> Result<[f64; N]> {
    if fields.len() != N {
        return Err(DataError::parse(path, line_no, count_msg()));
    }
    let v = parse_numbers(path, line_no, fields)?;
    <[f64; N]>::try_from(v).map_err(|_| DataError::parse(path, line_no, count_msg()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_whole_file() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("sub/a.txt");
        write_text_atomic(&p, "one")?;
        write_text_atomic(&p, "two")?;
        assert_eq!(read_text(&p)?, "two");
        // a failing writer leaves the old content and no temporary file
        let err = write_atomic(&p, |_| Err(std::io::Error::other("boom")));
        assert!(err.is_err());
        assert_eq!(read_text(&p)?, "two");
        assert_eq!(
            std::fs::read_dir(p.parent().unwrap_or(dir.path()))
                .map_err(|e| DataError::io("d", e))?
                .count(),
            1
        );
        Ok(())
    }

    #[test]
    fn numbers_name_the_line() {
        let e = parse_numbers(Path::new("f.txt"), 7, &["1", "x"]).unwrap_err();
        assert_eq!(e.to_string(), "f.txt:7: 'x' is not a number");
        assert!(parse_numbers(Path::new("f.txt"), 1, &["NaN"]).is_err());
    }

    #[test]
    fn binary_is_not_text() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("b");
        std::fs::write(&p, [0xff, 0xfe, 0x00]).map_err(|e| DataError::io(&p, e))?;
        assert!(
            read_text(&p)
                .unwrap_err()
                .to_string()
                .contains("not a text file")
        );
        Ok(())
    }
}
