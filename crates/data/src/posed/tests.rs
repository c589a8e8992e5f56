//! Each layout on a small hand-written example in its real layout, with a pose checked by hand,
//! and the never-panics property over damaged files.

use super::*;
use crate::test_util::{dataset_info, put, shared_data, tmp};
use proptest::prelude::*;

/// A tiny image file (the opener checks that images exist, not what they hold).
fn image(dir: &Path, name: &str) -> Result<PathBuf> {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).map_err(|e| DataError::io(&p, e))?;
    image::RgbImage::new(4, 3)
        .save(&p)
        .map_err(|e| DataError::invalid(&p, e.to_string()))?;
    Ok(p)
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9)
}

/// A quarter turn about z, then the camera centre (1, 2, 3): space-separated, as in
/// `7scenes_redkitchen_seq01`.
const QUARTER_TURN_POSE: &str = "0 -1 0 1\n1 0 0 2\n0 0 1 3\n0 0 0 1\n";

#[test]
fn a_7scenes_sequence_with_jpeg_colour_and_depth() -> Result<()> {
    let dir = tmp()?;
    let seq = dir.path().join("seq-01");
    for i in 0..3 {
        put(&seq, &format!("frame-00000{i}.pose.txt"), QUARTER_TURN_POSE)?;
        image(&seq, &format!("frame-00000{i}.color.jpg"))?;
        image(&seq, &format!("frame-00000{i}.depth.png"))?;
    }
    for path in [seq.clone(), dir.path().to_path_buf()] {
        let ds = open(&path)?;
        assert_eq!(ds.layout, Layout::SevenScenes);
        assert_eq!(ds.images.len(), 3);
        let first = &ds.images[0];
        assert_eq!(first.image, seq.join("frame-000000.color.jpg"));
        assert_eq!(first.depth, Some(seq.join("frame-000000.depth.png")));
        assert!(close(first.frame.pose.position(), [1.0, 2.0, 3.0]));
        let q = first.frame.pose.quat_wxyz();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (q[0].abs() - h).abs() < 1e-9 && (q[3].abs() - h).abs() < 1e-9,
            "{q:?}"
        );
        assert_eq!(ds.camera.unwrap().fx, 525.0);
        assert!(ds.own_split.is_none());
    }
    Ok(())
}

#[test]
fn a_7scenes_scene_keeps_its_own_split_with_validation_blocks_from_training() -> Result<()> {
    let dir = tmp()?;
    for (s, n) in [("seq-01", 10), ("seq-02", 4)] {
        for i in 0..n {
            put(
                &dir.path().join(s),
                &format!("frame-{i:06}.pose.txt"),
                QUARTER_TURN_POSE,
            )?;
            image(&dir.path().join(s), &format!("frame-{i:06}.color.png"))?;
        }
    }
    put(dir.path(), "TrainSplit.txt", "sequence1\n")?;
    put(dir.path(), "TestSplit.txt", "sequence2\n")?;
    let ds = open(dir.path())?;
    let test = ds.split(SplitPlan::Auto, SplitName::Test);
    assert!(test.len() == 4 && test.iter().all(|i| i.frame.seq == "seq-02"));
    // Blocks of 100 frames, the fifth held out: ten frames of training make one block, so
    // all train (no validation): the caller has to say how to cut so few frames.
    assert_eq!(ds.split(SplitPlan::Auto, SplitName::Train).len(), 10);
    let blocks = SplitPlan::Blocks("2:5".parse().unwrap());
    let parts = ds.parts(blocks);
    // seq-01: blocks 0..5, the fifth (frames 8, 9) test; seq-02 starts its own blocks.
    assert_eq!(parts[8], Some(SplitName::Test));
    assert_eq!(parts[10], Some(SplitName::Train));
    Ok(())
}

#[test]
fn a_native_dataset_takes_jpeg_frames_and_depth() -> Result<()> {
    let dir = tmp()?;
    let info = dataset_info();
    info.write(&dir.path().join(native::DATASET_TOML))?;
    put(
        dir.path(),
        native::POSES_CSV,
        "frame,seq,t,x,y,z,qw,qx,qy,qz\n0,a,0.0,1,2,3,1,0,0,0\n1,a,0.1,4,5,6,1,0,0,0\n",
    )?;
    image(dir.path(), "frames/000000.jpg")?;
    image(dir.path(), "frames/000001.png")?;
    image(dir.path(), "depth/000001.png")?;
    let ds = open(dir.path())?;
    assert_eq!(ds.layout, Layout::Native);
    assert_eq!(ds.images[0].image, dir.path().join("frames/000000.jpg"));
    assert_eq!(ds.images[1].image, dir.path().join("frames/000001.png"));
    assert_eq!(ds.images[0].depth, None);
    assert!(ds.images[1].depth.is_some());
    assert!(close(ds.images[1].frame.pose.position(), [4.0, 5.0, 6.0]));
    assert_eq!(ds.name(), "test");
    std::fs::remove_file(dir.path().join("frames/000000.jpg")).unwrap();
    let e = open(dir.path()).unwrap_err().to_string();
    assert!(e.contains("000000.png") && e.contains("missing"), "{e}");
    Ok(())
}

#[test]
fn a_tum_folder_pairs_images_and_depth_with_the_nearest_pose() -> Result<()> {
    let dir = tmp()?;
    put(
        dir.path(),
        "rgb.txt",
        "# color images\n1.000 rgb/1.000.png\n1.033 rgb/1.033.png\n1.500 rgb/1.500.png\n",
    )?;
    put(
        dir.path(),
        "depth.txt",
        "# depth\n1.001 depth/1.001.png\n1.034 depth/1.034.png\n1.499 depth/1.499.png\n",
    )?;
    // The image at 1.5 s has no pose within 0.02 s: it is left out.
    put(
        dir.path(),
        "groundtruth.txt",
        "# timestamp tx ty tz qx qy qz qw\n1.005 1 2 3 0 0 0 1\n1.040 4 5 6 0 0 0 1\n",
    )?;
    for f in ["rgb/1.000.png", "rgb/1.033.png", "rgb/1.500.png"] {
        image(dir.path(), f)?;
    }
    let ds = open(dir.path())?;
    assert_eq!(ds.layout, Layout::Tum);
    assert_eq!(ds.images.len(), 2);
    assert!(close(ds.images[0].frame.pose.position(), [1.0, 2.0, 3.0]));
    assert!(close(ds.images[1].frame.pose.position(), [4.0, 5.0, 6.0]));
    assert_eq!(ds.images[1].frame.name, "1.033");
    assert_eq!(ds.images[1].frame.t, Some(1.033));
    assert_eq!(ds.images[1].depth, Some(dir.path().join("depth/1.034.png")));
    assert_eq!(ds.camera, Some(tum_default_camera()));
    Ok(())
}

#[test]
fn a_colmap_model_finds_its_images_two_folders_up() -> Result<()> {
    let dir = tmp()?;
    let model = dir.path().join("sparse/0");
    put(
        &model,
        "cameras.txt",
        "1 PINHOLE 640 480 500 500 320.5 240.5\n",
    )?;
    // World-to-camera: identity rotation, t = (1, 2, 3), so the camera centre is (-1, -2, -3).
    put(
        &model,
        "images.txt",
        "1 1 0 0 0 1 2 3 1 a.jpg\n\n2 1 0 0 0 0 0 0 1 b.jpg\n\n",
    )?;
    put(&model, "points3D.txt", "")?;
    image(&dir.path().join("images"), "a.jpg")?;
    image(&dir.path().join("images"), "b.jpg")?;
    let ds = open(&model)?;
    assert_eq!(ds.layout, Layout::Colmap);
    assert_eq!(ds.images[0].image, model.join("../../images/a.jpg"));
    assert!(close(
        ds.images[0].frame.pose.position(),
        [-1.0, -2.0, -3.0]
    ));
    assert_eq!(ds.camera.unwrap().cx, 320.0);
    std::fs::remove_file(dir.path().join("images/a.jpg")).unwrap();
    let e = open(&model).unwrap_err().to_string();
    assert!(e.contains("a.jpg") && e.contains("images/"), "{e}");
    Ok(())
}

#[test]
fn a_cambridge_scene_keeps_its_train_and_test_lists() -> Result<()> {
    let dir = tmp()?;
    let header = "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n";
    put(
        dir.path(),
        "dataset_train.txt",
        &format!("{header}seq1/frame00001.png 1 2 3 1 0 0 0\nseq1/frame00002.png 1 2 4 1 0 0 0\n"),
    )?;
    put(
        dir.path(),
        "dataset_test.txt",
        &format!("{header}seq2/frame00001.png 7 8 9 1 0 0 0\n"),
    )?;
    for f in [
        "seq1/frame00001.png",
        "seq1/frame00002.png",
        "seq2/frame00001.png",
    ] {
        image(dir.path(), f)?;
    }
    let ds = open(dir.path())?;
    assert_eq!(ds.layout, Layout::Cambridge);
    let test = ds.split(SplitPlan::Auto, SplitName::Test);
    assert_eq!(test.len(), 1);
    assert!(close(test[0].frame.pose.position(), [7.0, 8.0, 9.0]));
    assert!(ds.require_camera().is_err());
    Ok(())
}

#[test]
fn the_real_kitchen_opens_with_the_readme_split() -> Result<()> {
    let root = shared_data("7scenes_redkitchen_seq01");
    if !root.is_dir() {
        return Ok(());
    }
    let ds = open(&root)?;
    assert_eq!(ds.images.len(), 1000);
    assert!(ds.images.iter().all(|i| i.depth.is_some()));
    let test = ds.split(SplitPlan::Auto, SplitName::Test);
    assert_eq!(test.len(), 200);
    assert_eq!(test[0].frame.name, "frame-000400");
    assert_eq!(ds.name(), "7scenes_redkitchen_seq01");
    Ok(())
}

#[test]
fn unknown_layouts_and_missing_files_name_the_path() -> Result<()> {
    let dir = tmp()?;
    put(dir.path(), "notes.txt", "hello\n")?;
    let e = open(dir.path()).unwrap_err().to_string();
    assert!(e.contains("not a posed image dataset"), "{e}");
    put(dir.path(), "rgb.txt", "1.0 a.png\n")?;
    let e = open(dir.path()).unwrap_err().to_string();
    assert!(e.contains("groundtruth.txt"), "{e}");
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn damaged_files_give_errors_not_panics(
        file in prop::sample::select(vec!["rgb.txt", "depth.txt", "groundtruth.txt",
            "seq-01/frame-000000.pose.txt", "images.txt", "dataset_train.txt",
            "transforms.json", "poses.csv", "dataset.toml"]),
        bytes in prop::collection::vec(any::<u8>(), 0..200),
    ) {
        let dir = tmp().unwrap();
        put(dir.path(), "rgb.txt", "1.0 a.png\n").unwrap();
        put(dir.path(), "groundtruth.txt", "1.0 0 0 0 0 0 0 1\n").unwrap();
        let p = dir.path().join(file);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, &bytes).unwrap();
        let _ = open(dir.path());
        let _ = open(&p);
    }
}
