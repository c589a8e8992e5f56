//! Helpers shared by the unit tests of this crate: temporary folders, small text files, geometry
//! errors as data errors, and paths into the repository's shared test data.

use crate::native::{CameraInfo, DatasetInfo, Generator};
use crate::{DataError, Result};
use geom::Mount;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The repository's `shared` folder, seen from this crate.
const SHARED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/");

/// A fresh temporary folder, removed when dropped.
pub(crate) fn tmp() -> Result<tempfile::TempDir> {
    tempfile::tempdir().map_err(|e| DataError::io("tempdir", e))
}

/// Writes `text` to `dir/name`, creating the folders between (so `name` may be a relative path
/// such as `seq-01/frame-000000.pose.txt`), and returns the file's path.
pub(crate) fn put(dir: &Path, name: &str, text: &str) -> Result<PathBuf> {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).map_err(|e| DataError::io(parent, e))?;
    }
    std::fs::write(&p, text).map_err(|e| DataError::io(&p, e))?;
    Ok(p)
}

/// Geometry errors as data errors, for `?` in tests.
pub(crate) fn geo<T>(r: geom::Result<T>) -> Result<T> {
    r.map_err(|e| DataError::invalid("test", e.to_string()))
}

/// `rel` inside the repository's `shared` folder, e.g. `tools/peers/testdata/traj/gt.tum`.
pub(crate) fn shared(rel: &str) -> PathBuf {
    Path::new(SHARED).join(rel)
}

/// `rel` inside the repository's shared test data, `shared/data`, e.g. `fox_posed/images`.
pub(crate) fn shared_data(rel: &str) -> PathBuf {
    shared("data").join(rel)
}

/// A 640x480 forward-camera `dataset.toml` of a 6-DoF dataset in metres.
pub(crate) fn dataset_info() -> DatasetInfo {
    DatasetInfo {
        name: "test".into(),
        dof: 6,
        units: "m".into(),
        frame_rate: 29.97,
        mount: Mount::Forward,
        camera: CameraInfo {
            width: 640,
            height: 480,
            fx: 500.0,
            fy: 501.5,
            cx: 319.5,
            cy: 239.5,
            distortion: [0.1, -0.01, 0.001, -0.002, 0.0003],
        },
        generator: Some(Generator {
            name: "indoorloc synth".into(),
            seed: Some(7),
            source: None,
            settings: BTreeMap::from([("world".to_string(), "default".to_string())]),
        }),
    }
}
