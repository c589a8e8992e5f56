//! Property test: every parser, fed random bytes or random lines built from the tokens real
//! files hold, returns `Ok` or an error naming the file; it never panics.

use data::formats::{self, FORMATS};
use proptest::prelude::*;
use std::path::Path;

/// Writes `content` under the file name each format expects and runs every reader on it,
/// plus detection and the cut-list reader.
fn run_all_parsers(dir: &Path, content: &[u8]) {
    for (format, name) in FORMATS {
        let file = match name {
            "native" => "poses.csv",
            "colmap" => "images.txt",
            "nerf" => "transforms.json",
            _ => "poses.txt",
        };
        let sub = dir.join(name);
        std::fs::create_dir_all(&sub).ok();
        let path = sub.join(file);
        if std::fs::write(&path, content).is_err() {
            continue;
        }
        for target in [path.as_path(), sub.as_path()] {
            if let Err(e) = formats::read(target, Some(format)) {
                let msg = e.to_string();
                assert!(
                    msg.contains(&*sub.to_string_lossy()),
                    "{format}: error does not name the file: {msg}"
                );
                assert!(!msg.contains('\n'), "{format}: multi-line error: {msg}");
            }
        }
        let _ = formats::detect(&path);
        let _ = formats::read(&path, None);
        let _ = data::cuts::read(&path);
    }
}

/// Tokens seen in real pose files, mixed into random lines.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0".to_string()),
        Just("1".to_string()),
        Just("-1".to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("1e308".to_string()),
        Just("1e-320".to_string()),
        Just("#".to_string()),
        Just(",".to_string()),
        Just("{".to_string()),
        Just("}".to_string()),
        Just("[".to_string()),
        Just("]".to_string()),
        Just("\"frames\":".to_string()),
        Just("\"transform_matrix\":".to_string()),
        Just("PINHOLE".to_string()),
        Just("frame,seq,t,x,y,z,qw,qx,qy,qz".to_string()),
        Just("t,x,y,theta,sxx,syy,stt".to_string()),
        Just("Visual Landmark Dataset V1".to_string()),
        Just("seq1/frame00001.png".to_string()),
        any::<f64>().prop_map(|v| v.to_string()),
        any::<i64>().prop_map(|v| v.to_string()),
        "[a-z/._-]{0,12}",
    ]
}

fn line() -> impl Strategy<Value = String> {
    prop::collection::vec(token(), 0..12).prop_map(|t| t.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes(content in prop::collection::vec(any::<u8>(), 0..512)) {
        let dir = tempfile::tempdir().map_err(|e| TestCaseError::fail(e.to_string()))?;
        run_all_parsers(dir.path(), &content);
    }

    #[test]
    fn random_lines(lines in prop::collection::vec(line(), 0..12)) {
        let dir = tempfile::tempdir().map_err(|e| TestCaseError::fail(e.to_string()))?;
        run_all_parsers(dir.path(), lines.join("\n").as_bytes());
    }
}
