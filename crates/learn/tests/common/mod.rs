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

/// Saves `img` as the next frame of a dataset being written into `root` and adds its record:
/// frame `i` of sequence `s{seq}`, at 10 Hz.
fn save_frame(
    root: &Path,
    frames: &mut Vec<PoseFrame>,
    seq: usize,
    i: usize,
    img: &RgbImage,
    pose: Pose,
) {
    let name = format!("{:06}", frames.len());
    img.save(root.join("frames").join(format!("{name}.png")))
        .unwrap();
    frames.push(PoseFrame {
        name,
        seq: format!("s{seq}"),
        t: Some(i as f64 / 10.0),
        pose,
    });
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
    for s in 0..n_seq {
        for i in 0..per_seq {
            let (x, y, h) = pose3(s, i, n_seq);
            let pose: Pose = if dof == 3 {
                Pose3::new(x, y, h).unwrap().to_pose(mount, 2.5)
            } else {
                Pose::from_euler_ypr(h, 0.1 * y, 0.0, [x, y, 1.5]).unwrap()
            };
            save_frame(root, &mut frames, s, i, &image(x, y, h), pose);
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
    for s in 0..n_seq {
        for i in 0..per_seq {
            let number = frames.len() as u64;
            let u = (i * n_seq + s) as f64 / (n_seq * per_seq) as f64;
            let (x, y, h) = (4.0 * u, 0.8 * (3.0 * u).sin(), 1.5 * u - 0.5);
            let pose = Pose::from_euler_ypr(h, 0.0, 0.0, [x, y, 1.5]).unwrap();
            let img = textured([
                30.0 + 50.0 * x + offset(3 * number),
                128.0 + 100.0 * y + offset(3 * number + 1),
                128.0 + 100.0 * h.sin() + offset(3 * number + 2),
            ]);
            save_frame(root, &mut frames, s, i, &img, pose);
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

/// Writes five recordings along one path into `root` (`s0`-`s3` train, `s4` val, interleaved,
/// `per_seq` frames each, the colour encoding the pose as [`make_dataset`]'s does) and a test
/// recording `s5` that walks the same path and then `reach` times as far past its end, where
/// no training frame was: the network extrapolates there, more wrongly the further it goes.
pub fn make_walk_past_its_training(root: &Path, per_seq: usize, reach: f64) {
    let n_train = 5;
    let mut frames = Vec::new();
    std::fs::create_dir_all(root.join("frames")).unwrap();
    let mut push = |s: usize, i: usize, u: f64| {
        let (img, pose) = walk_frame(u);
        save_frame(root, &mut frames, s, i, &img, pose);
    };
    for s in 0..n_train {
        for i in 0..per_seq {
            push(s, i, (i * n_train + s) as f64 / (n_train * per_seq) as f64);
        }
    }
    for i in 0..per_seq {
        push(n_train, i, (1.0 + reach) * i as f64 / per_seq as f64);
    }
    let info = info("a walk past its training".into(), 6, Mount::Forward);
    let splits = Splits {
        train: (0..4).map(|s| format!("s{s}")).collect(),
        val: vec!["s4".into()],
        test: vec!["s5".into()],
    };
    write_metadata(root, &info, &Trajectory::new(frames), None, None, &splits).unwrap();
}

/// The frame of [`make_walk_past_its_training`]'s path at `u` (0 to 1 where the training frames
/// are) and its pose.
fn walk_frame(u: f64) -> (RgbImage, Pose) {
    let (x, y, h) = (4.0 * u, 0.8 * (3.0 * u).sin(), 1.5 * u - 0.5);
    let pose = Pose::from_euler_ypr(h, 0.0, 0.0, [x, y, 1.5]).unwrap();
    // 25 levels of red a metre keep the far end of a test walk below 255
    let img = textured([30.0 + 25.0 * x, 128.0 + 100.0 * y, 128.0 + 100.0 * h.sin()]);
    (img, pose)
}

/// Paint of [`bar_frame`]: the bar's colour, then the wall's.
pub type Palette = [[f64; 3]; 2];

/// The paint of [`make_bar_walk`]'s frames: a light red bar on a dark blue wall.
pub const TRAINING_PAINT: Palette = [[200.0, 70.0, 60.0], [50.0, 60.0, 160.0]];

/// A frame of a walk past a bar whose place and height in the image say the pose (x moves it
/// across, y changes its height), painted in `paint` under the fixed texture: the pose is in
/// the shape, the paint is only appearance. Edges are drawn with their pixel coverage.
pub fn bar_frame(u: f64, paint: Palette) -> (RgbImage, Pose) {
    let (x, y) = (4.0 * u, 0.8 * (3.0 * u).sin());
    let pose = Pose::from_euler_ypr(0.0, 0.0, 0.0, [x, y, 1.5]).unwrap();
    let (left, right) = (2.0 + 22.0 * u, 8.0 + 22.0 * u);
    let top = 2.0 + 7.0 * (y + 0.8) / 1.6;
    let bottom = f64::from(H) - 2.0;
    // the share of pixel [p, p + 1) inside [a, b]
    let cover = |p: f64, a: f64, b: f64| (b.min(p + 1.0) - a.max(p)).clamp(0.0, 1.0);
    let [bar, wall] = paint;
    let img = RgbImage::from_fn(W, H, |c, r| {
        let k = cover(f64::from(c), left, right) * cover(f64::from(r), top, bottom);
        let tex = (((c * 7 + r * 13) % 11) as f64 - 5.0) * 2.0;
        Rgb(std::array::from_fn(|i| {
            (wall[i] + k * (bar[i] - wall[i]) + tex).clamp(0.0, 255.0) as u8
        }))
    });
    (img, pose)
}

/// Writes five recordings of [`bar_frame`]s in [`TRAINING_PAINT`] into `root` (`s0`-`s3` train,
/// `s4` val, interleaved along one path, `per_seq` frames each).
pub fn make_bar_walk(root: &Path, per_seq: usize) {
    let n_seq = 5;
    let mut frames = Vec::new();
    std::fs::create_dir_all(root.join("frames")).unwrap();
    for s in 0..n_seq {
        for i in 0..per_seq {
            let u = (i * n_seq + s) as f64 / (n_seq * per_seq) as f64;
            let (img, pose) = bar_frame(u, TRAINING_PAINT);
            save_frame(root, &mut frames, s, i, &img, pose);
        }
    }
    let info = info("a walk past a bar".into(), 6, Mount::Forward);
    let splits = Splits {
        train: (0..4).map(|s| format!("s{s}")).collect(),
        val: vec!["s4".into()],
        test: vec![],
    };
    write_metadata(root, &info, &Trajectory::new(frames), None, None, &splits).unwrap();
}

/// The small network on 32x24 views of these datasets, trained in seconds at a constant rate:
/// the recipe the toy-scale tests share (each sets what it is about on top).
pub fn tiny_config(data: &Path, out: &Path, seed: u64) -> learn::TrainConfig {
    let mut cfg = learn::TrainConfig::new(data, out);
    cfg.arch = learn::Arch::Small;
    cfg.view = Some("resize=32x24".into());
    cfg.epochs = 3;
    cfg.batch_size = 8;
    cfg.lr = 3e-3;
    cfg.schedule = learn::Schedule::Constant;
    cfg.beta = 1.0;
    cfg.hidden = 32;
    cfg.seed = seed;
    cfg
}
