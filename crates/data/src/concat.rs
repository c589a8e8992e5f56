//! Joining native datasets recorded with the same camera into one: several recording days, or
//! the same building rendered under several appearances, trained on as one dataset whose splits
//! still keep each recording session whole.
//!
//! Frames are renumbered in order (part by part), sequence names get the part's prefix
//! (`<prefix>-<seq>`) so that sessions of different parts never merge, labels and cuts follow
//! their frames, and each part's split lists are kept. Images (`frames/`, and `depth/` and
//! `planes/` where every part has them) are hard-linked where the file system allows, else
//! copied; the metadata is written last and atomically, so a dataset that opens is complete.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use crate::native::{self, DatasetInfo, Label, NativeDataset, Splits};
use crate::trajectory::{PoseFrame, Trajectory};
use crate::{DataError, Result};

/// One dataset to join and the prefix of its sequence names.
#[derive(Clone, Debug)]
pub struct Part {
    /// Prefix of the part's sequence names in the joined dataset (not empty).
    pub prefix: String,
    /// The native dataset folder.
    pub root: PathBuf,
}

/// Joins `parts` into the native dataset `out` (see the module docs); `name` names it. Every
/// part must have the camera, degrees of freedom and units of the first; labels are kept only
/// when every part has them.
pub fn concat(out: &Path, name: &str, parts: &[Part]) -> Result<NativeDataset> {
    let opened = parts
        .iter()
        .map(|p| NativeDataset::open(&p.root))
        .collect::<Result<Vec<_>>>()?;
    let first = opened
        .first()
        .ok_or_else(|| DataError::invalid(out, "no datasets to join"))?;
    let mut prefixes = HashSet::new();
    for (part, ds) in parts.iter().zip(&opened) {
        if part.prefix.is_empty() || !prefixes.insert(&part.prefix) {
            return Err(DataError::invalid(
                &part.root,
                format!("prefix '{}' is empty or used twice", part.prefix),
            ));
        }
        let same = ds.info.camera == first.info.camera
            && ds.info.dof == first.info.dof
            && ds.info.units == first.info.units;
        if !same {
            return Err(DataError::invalid(
                part.root.join(native::DATASET_TOML),
                format!(
                    "camera, dof or units differ from {}",
                    first.root.join(native::DATASET_TOML).display()
                ),
            ));
        }
    }
    let with_labels = opened.iter().all(|ds| ds.labels.is_some());
    let numbers = opened
        .iter()
        .map(|ds| {
            (0..ds.trajectory.len())
                .map(|i| frame_number(ds, i))
                .collect::<Result<Vec<u64>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    let images: Vec<&str> = ["frames", "depth", "planes"]
        .into_iter()
        .filter(|sub| {
            opened.iter().zip(&numbers).all(|(ds, frames)| {
                frames
                    .iter()
                    .all(|&f| native::image_path(&ds.root, sub, f).is_file())
            })
        })
        .collect();
    if !images.contains(&"frames") {
        return Err(DataError::invalid(
            out,
            "a part lacks some of its frames/ images",
        ));
    }
    for sub in &images {
        let dir = out.join(sub);
        std::fs::create_dir_all(&dir).map_err(|e| DataError::io(&dir, e))?;
    }

    let mut frames = Vec::new();
    let mut labels = Vec::new();
    let mut cuts = Vec::new();
    let mut splits = Splits::default();
    for ((part, ds), numbers) in parts.iter().zip(&opened).zip(&numbers) {
        let by_frame: HashMap<u64, &Label> =
            ds.labels.iter().flatten().map(|l| (l.frame, l)).collect();
        let base = frames.len() as u64;
        let mut index = HashMap::new();
        for (f, &old) in ds.trajectory.frames.iter().zip(numbers) {
            let new = frames.len() as u64;
            index.insert(old, new);
            for sub in &images {
                link_or_copy(
                    &native::image_path(&ds.root, sub, old),
                    &native::image_path(out, sub, new),
                )?;
            }
            if let Some(label) = by_frame.get(&old) {
                labels.push(Label {
                    frame: new,
                    ..(*label).clone()
                });
            }
            frames.push(PoseFrame {
                name: native::frame_name(new),
                seq: format!("{}-{}", part.prefix, f.seq),
                ..f.clone()
            });
        }
        // A new part starts somewhere else: a cut, as between sequences of one recording.
        if base > 0 {
            cuts.push(base);
        }
        cuts.extend(ds.cuts.iter().flatten().filter_map(|c| index.get(c)));
        let named = |list: &[String]| -> Vec<String> {
            list.iter()
                .map(|s| format!("{}-{s}", part.prefix))
                .collect()
        };
        splits.train.extend(named(&ds.splits.train));
        splits.val.extend(named(&ds.splits.val));
        splits.test.extend(named(&ds.splits.test));
    }
    cuts.sort_unstable();
    cuts.dedup();
    let info = DatasetInfo {
        name: name.to_string(),
        ..first.info.clone()
    };
    native::write_metadata(
        out,
        &info,
        &Trajectory::new(frames),
        with_labels.then_some(labels.as_slice()),
        Some(&cuts),
        &splits,
    )?;
    NativeDataset::open(out)
}

fn frame_number(ds: &NativeDataset, index: usize) -> Result<u64> {
    ds.frame_number(index).ok_or_else(|| {
        DataError::invalid(
            ds.root.join(native::POSES_CSV),
            format!("frame {index} has no frame number"),
        )
    })
}

/// Hard-links `from` to `to` (replacing `to`), or copies it where links are not possible.
fn link_or_copy(from: &Path, to: &Path) -> Result<()> {
    if to.exists() {
        std::fs::remove_file(to).map_err(|e| DataError::io(to, e))?;
    }
    if std::fs::hard_link(from, to).is_ok() {
        return Ok(());
    }
    std::fs::copy(from, to)
        .map(|_| ())
        .map_err(|e| DataError::io(to, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::native::split_by_sequence;
    use geom::Pose;

    fn write_part(root: &Path, seqs: &[&str], frames_per_seq: usize, label: &str) {
        std::fs::create_dir_all(root.join("frames")).unwrap();
        let mut frames = Vec::new();
        let mut labels = Vec::new();
        for seq in seqs {
            for k in 0..frames_per_seq {
                let n = frames.len() as u64;
                std::fs::write(
                    root.join("frames")
                        .join(format!("{}.png", native::frame_name(n))),
                    format!("{label}{n}"),
                )
                .unwrap();
                frames.push(PoseFrame {
                    name: native::frame_name(n),
                    seq: seq.to_string(),
                    t: Some(k as f64),
                    pose: Pose::identity(),
                });
                labels.push(Label {
                    frame: n,
                    building: label.into(),
                    floor: "F0".into(),
                    corridor: "C0".into(),
                    direction: "fwd".into(),
                });
            }
        }
        let names: Vec<String> = seqs.iter().map(|s| s.to_string()).collect();
        native::write_metadata(
            root,
            &crate::test_util::dataset_info(),
            &Trajectory::new(frames),
            Some(&labels),
            None,
            &split_by_sequence(&names, 0.34, 0.0, 1),
        )
        .unwrap();
    }

    #[test]
    fn parts_join_with_their_sessions_labels_and_images() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, out) = (
            dir.path().join("a"),
            dir.path().join("b"),
            dir.path().join("ab"),
        );
        write_part(&a, &["walk-0", "walk-1", "walk-2"], 2, "A");
        write_part(&b, &["walk-0", "walk-1"], 3, "B");
        let parts = [
            Part {
                prefix: "normal".into(),
                root: a,
            },
            Part {
                prefix: "dim".into(),
                root: b,
            },
        ];
        let ds = concat(&out, "joined", &parts).unwrap();
        assert_eq!(ds.trajectory.len(), 12);
        assert_eq!(ds.info.name, "joined");
        assert_eq!(ds.trajectory.frames[6].seq, "dim-walk-0");
        assert_eq!(ds.trajectory.frames[6].name, "000006");
        let labels = ds.labels.as_ref().unwrap();
        assert_eq!(labels[5].building, "A");
        assert_eq!(labels[6].building, "B");
        let image = std::fs::read_to_string(out.join("frames/000006.png")).unwrap();
        assert_eq!(image, "B0", "frame 0 of part b");
        assert_eq!(ds.cuts.as_deref(), Some(&[6][..]));
        let all: Vec<&String> = [&ds.splits.train, &ds.splits.val, &ds.splits.test]
            .into_iter()
            .flatten()
            .collect();
        assert_eq!(all.len(), 5, "every session keeps one split: {all:?}");
        assert!(ds.splits.val.iter().any(|s| s.starts_with("normal-")));
        assert!(ds.splits.val.iter().any(|s| s.starts_with("dim-")));
    }

    #[test]
    fn a_part_with_another_camera_or_a_reused_prefix_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        write_part(&a, &["s0", "s1"], 1, "A");
        write_part(&b, &["s0", "s1"], 1, "B");
        let part = |prefix: &str, root: &Path| Part {
            prefix: prefix.into(),
            root: root.to_path_buf(),
        };
        let twice = concat(&dir.path().join("x"), "x", &[part("p", &a), part("p", &b)]);
        assert!(twice.unwrap_err().to_string().contains("used twice"));
        let toml = b.join(native::DATASET_TOML);
        let mut info = DatasetInfo::read(&toml).unwrap();
        info.camera.fx *= 2.0;
        info.write(&toml).unwrap();
        let err = concat(&dir.path().join("y"), "y", &[part("a", &a), part("b", &b)])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("camera") && err.contains("b/dataset.toml"),
            "{err}"
        );
    }
}
