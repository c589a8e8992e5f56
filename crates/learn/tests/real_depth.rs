//! Dominant planes found by RANSAC in real RGB-D depth: 7-Scenes "stairs" frames from
//! `../shared/data/7scenes_stairs_sample` (read in place).

use std::path::{Path, PathBuf};

use learn::planes::{DepthImage, Intrinsics, PlaneClass, frame_planes, ransac_planes};

fn depth_png(seq: u32, frame: u32) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!(
        "../../../shared/data/7scenes_stairs_sample/7scenes_layout/seq-{seq:02}/frame-{frame:06}.depth.png"
    ))
}

/// The depth camera's intrinsics as the dataset's authors give them.
const KINECT_DEPTH: Intrinsics = Intrinsics {
    fx: 585.0,
    fy: 585.0,
    cx: 320.0,
    cy: 240.0,
};

#[test]
fn ransac_finds_flat_dominant_planes_in_kinect_depth() {
    for (seq, frame) in [(1, 0), (4, 2)] {
        let img = image::open(depth_png(seq, frame)).unwrap().into_luma16();
        let depth = DepthImage {
            width: img.width() as usize,
            height: img.height() as usize,
            depth: img.pixels().map(|p| f32::from(p.0[0]) / 1000.0).collect(),
        };
        let valid = depth.depth.iter().filter(|&&z| z > 0.0).count();
        let ids = ransac_planes(&depth, &KINECT_DEPTH, 4, 7);
        let planes = frame_planes(&depth, &ids, &KINECT_DEPTH);
        let found: Vec<_> = planes.iter().flatten().collect();
        let covered = ids.iter().filter(|&&i| i != 0).count() as f64 / valid as f64;
        // Stairs are steps and walls: at least two planes, flat to a few centimetres, holding
        // most of the pixels with depth, in front of the camera, and not all facing one way.
        assert!(found.len() >= 2, "{found:?}");
        assert!(covered > 0.5, "{covered}");
        for p in &found {
            assert!(
                p.rms < 0.05 && p.distance > 0.2 && p.distance < 8.0,
                "{p:?}"
            );
            assert!((p.normal.norm() - 1.0).abs() < 1e-9);
        }
        let classes: std::collections::BTreeSet<u8> = found
            .iter()
            .map(|p| PlaneClass::of_normal(p.normal) as u8)
            .collect();
        assert!(classes.len() >= 2, "{classes:?}");
    }
}
