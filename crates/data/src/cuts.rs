//! Scene-cut lists: the first frame of each new scene. Read from a native dataset's `cuts.csv`
//! (header `frame`, one number per line), a plain list of numbers (one per line, `#` comments),
//! or the JSON document `indoorloc scenecut --json` prints (`{"cuts": [..], ...}`).

use crate::error::{DataError, Result};
use crate::io::{read_text, write_text_atomic};
use std::path::Path;

/// Reads cut frame indices, sorted and without duplicates.
pub fn read(path: &Path) -> Result<Vec<u64>> {
    let text = read_text(path)?;
    let mut cuts = if text.trim_start().starts_with('{') {
        from_json(path, &text)?
    } else {
        from_lines(path, &text)?
    };
    cuts.sort_unstable();
    cuts.dedup();
    Ok(cuts)
}

fn from_json(path: &Path, text: &str) -> Result<Vec<u64>> {
    #[derive(serde::Deserialize)]
    struct Doc {
        cuts: Vec<u64>,
    }
    serde_json::from_str::<Doc>(text)
        .map(|d| d.cuts)
        .map_err(|e| DataError::invalid(path, format!("expected {{\"cuts\": [frame, ...]}}: {e}")))
}

fn from_lines(path: &Path, text: &str) -> Result<Vec<u64>> {
    let mut cuts = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let s = line.trim();
        if s.is_empty()
            || s.starts_with('#')
            || (cuts.is_empty() && s.eq_ignore_ascii_case("frame"))
        {
            continue;
        }
        let v = s
            .parse::<u64>()
            .map_err(|_| DataError::parse(path, i + 1, format!("'{s}' is not a frame number")))?;
        cuts.push(v);
    }
    Ok(cuts)
}

/// Writes `cuts.csv` (header `frame`), atomically.
pub fn write(cuts: &[u64], path: &Path) -> Result<()> {
    let mut text = String::from("frame\n");
    for c in cuts {
        text.push_str(&format!("{c}\n"));
    }
    write_text_atomic(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_all_three_forms() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("cuts.csv");
        write(&[30, 10, 20], &p)?;
        assert_eq!(read(&p)?, vec![10, 20, 30]);
        std::fs::write(&p, "# cuts\n5\n\n7\n").map_err(|e| DataError::io(&p, e))?;
        assert_eq!(read(&p)?, vec![5, 7]);
        std::fs::write(&p, "{\"cuts\": [9, 3], \"frames\": 100}")
            .map_err(|e| DataError::io(&p, e))?;
        assert_eq!(read(&p)?, vec![3, 9]);
        std::fs::write(&p, "frame\n4\nx\n").map_err(|e| DataError::io(&p, e))?;
        assert!(read(&p).unwrap_err().to_string().contains("cuts.csv:3:"));
        Ok(())
    }
}
