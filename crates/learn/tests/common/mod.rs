//! A tiny procedural native dataset for the tests: each image's mean colour encodes the pose
//! (red: x, green: y, blue: heading) under a fixed texture, so a small network learns it in a
//! few steps.

use std::path::Path;

use data::native::{CameraInfo, DatasetInfo, Splits, write_metadata};
use data::{PoseFrame, Trajectory};
use geom::{Mount, Pose, Pose3};
use image::{Rgb, RgbImage};

/// Image size of the test frames.
pub const W: u32 = 32;
/// Image size of the test frames.
pub const H: u32 = 24;

/// 3-DoF pose of frame `i` of sequence `s`: sequences interleave along one walk, so the
/// validation sequence lies between training poses.
fn pose3(s: usize, i: usize, n_seq: usize) -> (f64, f64, f64) {
    let t = (i * n_seq + s) as f64 / 10.0;
    (t, 0.8 * (t * 1.3).sin(), 0.4 * t - 1.0)
}

fn image(x: f64, y: f64, heading: f64) -> RgbImage {
    textured([
        (30.0 + 40.0 * x).clamp(0.0, 255.0),
        (128.0 + 100.0 * y).clamp(0.0, 255.0),
        (128.0 + 100.0 * heading.sin()).clamp(0.0, 255.0),
    ])
}

/// A test frame of mean colour `[r, g, b]` under the fixed texture.
fn textured([r, g, b]: [f64; 3]) -> RgbImage {
    RgbImage::from_fn(W, H, |u, v| {
        let tex = (((u * 7 + v * 13) % 11) as f64 - 5.0) * 2.0;
        let c = |m: f64| (m + tex).clamp(0.0, 255.0) as u8;
        Rgb([c(r), c(g), c(b)])
    })
}

/// `dataset.toml` of the test datasets: `W`x`H` frames at 10 Hz of a pinhole camera.
fn info(name: String, dof: u8, mount: Mount) -> DatasetInfo {
    DatasetInfo {
        name,
        dof,
        units: "m".into(),
        frame_rate: 10.0,
        mount,
        camera: CameraInfo {
            width: W,
            height: H,
            fx: 20.0,
            fy: 20.0,
            cx: W as f64 / 2.0,
            cy: H as f64 / 2.0,
            distortion: [0.0; 5],
        },
        generator: None,
    }
}

/// Writes a dataset of `per_seq` frames in each of three sequences (`s0`, `s1` train, `s2`
/// val) into `root`; `dof` 6 (forward camera) or 3 (ceiling camera).
pub fn make_dataset(root: &Path, dof: u8, per_seq: usize) {
    let mount = if dof == 3 {
        Mount::Ceiling
    } else {
        Mount::Forward
    };
    let mut frames = Vec::new();
    let n_seq = 3;
    std::fs::create_dir_all(root.join("frames")).unwrap();
    let mut number = 0u64;
    for s in 0..n_seq {
        for i in 0..per_seq {
            let (x, y, h) = pose3(s, i, n_seq);
            let pose: Pose = if dof == 3 {
                Pose3::new(x, y, h).unwrap().to_pose(mount, 2.5)
            } else {
                Pose::from_euler_ypr(h, 0.1 * y, 0.0, [x, y, 1.5]).unwrap()
            };
            image(x, y, h)
                .save(root.join("frames").join(format!("{number:06}.png")))
                .unwrap();
            frames.push(PoseFrame {
                name: format!("{number:06}"),
                seq: format!("s{s}"),
                t: Some(i as f64 / 10.0),
                pose,
            });
            number += 1;
        }
    }
    let info = info(format!("tiny{dof}"), dof, mount);
    let splits = Splits {
        train: vec!["s0".into(), "s1".into()],
        val: vec!["s2".into()],
        test: vec![],
    };
    write_metadata(root, &info, &Trajectory::new(frames), None, None, &splits).unwrap();
}

/// Gives every frame of a [`make_dataset`] dataset a depth image (16-bit mm) of a level camera
/// 0.5 m above a floor facing a wall `3 + x / 10` m ahead, and with `ids` the plane ids (floor
/// 1, wall 2) as the renderer writes them; the floor is drawn darker in the frame.
pub fn add_depth_and_planes(root: &Path, ids: bool) {
    let ds = data::native::NativeDataset::open(root).unwrap();
    std::fs::create_dir_all(root.join("depth")).unwrap();
    std::fs::create_dir_all(root.join("planes")).unwrap();
    for (number, frame) in ds.trajectory.frames.iter().enumerate() {
        let wall = 3.0 + frame.pose.position()[0] / 10.0;
        let mut depth = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(W, H);
        let mut plane = image::GrayImage::new(W, H);
        let name = format!("{number:06}.png");
        let frame_path = root.join("frames").join(&name);
        let mut rgb = image::open(&frame_path).unwrap().into_rgb8();
        for (u, v, p) in depth.enumerate_pixels_mut() {
            let ry = (f64::from(v) - f64::from(H) / 2.0) / 20.0;
            let (z, id) = if ry > 0.5 / wall {
                let px = rgb.get_pixel_mut(u, v);
                px.0 = px.0.map(|c| c / 2);
                (0.5 / ry, 1)
            } else {
                (wall, 2)
            };
            p.0[0] = (z * 1000.0).round() as u16;
            plane.put_pixel(u, v, image::Luma([id]));
        }
        rgb.save(&frame_path).unwrap();
        depth.save(root.join("depth").join(&name)).unwrap();
        if ids {
            plane.save(root.join("planes").join(&name)).unwrap();
        }
    }
}

/// Writes six recordings along one path into `root` (`s0`-`s3` train, `s4` val, `s5` test,
/// `per_seq` frames each at 10 Hz, interleaved so that every sequence lies between the others'
/// poses), each image's mean colour encoding the pose as [`make_dataset`]'s does, plus a
/// per-frame colour offset of up to `flicker` levels (a camera's exposure flicker): no single
/// frame can tell it from a move, a window of frames averages it out. `seed` draws the flicker.
pub fn make_flickering_walks(root: &Path, per_seq: usize, flicker: f64, seed: u64) {
    let n_seq = 6;
    let mut frames = Vec::new();
    std::fs::create_dir_all(root.join("frames")).unwrap();
    // a fixed pseudo-random offset per frame and channel, in [-flicker, flicker]
    let offset = |k: u64| {
        let k = k ^ seed.wrapping_mul(0xA24B_AED4_963E_E407);
        let h = k.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29) ^ 0xD6E8_FEB8_6659_FD93;
        let h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        flicker * (2.0 * (h >> 11) as f64 / (1u64 << 53) as f64 - 1.0)
    };
    let mut number = 0u64;
    for s in 0..n_seq {
        for i in 0..per_seq {
            let u = (i * n_seq + s) as f64 / (n_seq * per_seq) as f64;
            let (x, y, h) = (4.0 * u, 0.8 * (3.0 * u).sin(), 1.5 * u - 0.5);
            let pose = Pose::from_euler_ypr(h, 0.0, 0.0, [x, y, 1.5]).unwrap();
            textured([
                30.0 + 50.0 * x + offset(3 * number),
                128.0 + 100.0 * y + offset(3 * number + 1),
                128.0 + 100.0 * h.sin() + offset(3 * number + 2),
            ])
            .save(root.join("frames").join(format!("{number:06}.png")))
            .unwrap();
            frames.push(PoseFrame {
                name: format!("{number:06}"),
                seq: format!("s{s}"),
                t: Some(i as f64 / 10.0),
                pose,
            });
            number += 1;
        }
    }
    let info = info("flickering walks".into(), 6, Mount::Forward);
    let splits = Splits {
        train: (0..4).map(|s| format!("s{s}")).collect(),
        val: vec!["s4".into()],
        test: vec!["s5".into()],
    };
    write_metadata(root, &info, &Trajectory::new(frames), None, None, &splits).unwrap();
}
