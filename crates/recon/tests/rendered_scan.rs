//! Scans of rendered RGB-D walks through the default building, whose walls are known exactly:
//! the fused surface lies on them, faces the cameras, and bad scans (no depth, depth in other
//! units, poses that do not fit) are named.

use data::posed::{self, PosedImage};
use geom::Pose;
use nalgebra::Vector3;
use recon::volume::{FuseConfig, fuse};
use recon::{ScanConfig, extract::extract};
use synth::dataset::{SynthConfig, build_world};
use synth::world::World;

type TestResult = Result<(), Box<dyn std::error::Error>>;

const VOXEL: f64 = 0.02;

/// A rendered walk with depth, and the building it walked through.
fn rendered_walk(
    dir: &std::path::Path,
) -> Result<(SynthConfig, World), Box<dyn std::error::Error>> {
    let cfg = SynthConfig {
        frames: 60,
        sequences: 1,
        width: 320,
        height: 240,
        seed: 4,
        planes: false,
        ..SynthConfig::default()
    };
    synth::dataset::run(&cfg, dir, &|_| {})?;
    let (world, _) = build_world(&cfg)?;
    Ok((cfg, world))
}

fn fuse_config() -> FuseConfig {
    FuseConfig {
        voxel_m: VOXEL,
        ..FuseConfig::default()
    }
}

/// Distance from `p` to the nearest dominant plane (walls, floors, ceilings) of `world`.
fn plane_distance(world: &World, p: [f32; 3]) -> f32 {
    world
        .planes
        .iter()
        .map(|pl| (pl.normal.dot(&Vector3::from(p)) - pl.offset).abs())
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn the_fused_surface_lies_on_the_known_walls_and_faces_the_cameras() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (_, world) = rendered_walk(dir.path())?;
    let ds = posed::open(dir.path())?;
    let frames: Vec<&PosedImage> = ds.images.iter().collect();
    let (volume, report) = fuse(&ds, &frames, &fuse_config(), &|| {})?;
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    // Rendered depth is exact to the millimetre: the residual is the voxels' nearest-pixel
    // lookup on slanted surfaces.
    assert!(report.median_residual_m < 0.4 * VOXEL, "{report:?}");
    let mesh = extract(&volume);
    assert!(mesh.triangle_count() > 2000, "{}", mesh.triangle_count());

    // Vertices within 5 voxels of a wall, floor or ceiling belong to it (the rest is furniture
    // and clutter): they must lie within 1.5 voxels of it.
    let near: Vec<f32> = mesh
        .positions
        .iter()
        .map(|&p| plane_distance(&world, p))
        .filter(|&d| d < 5.0 * VOXEL as f32)
        .collect();
    let share_on_planes = near.len() as f64 / mesh.positions.len() as f64;
    assert!(share_on_planes > 0.4, "only {share_on_planes:.2} on planes");
    let within = near.iter().filter(|&&d| d <= 1.5 * VOXEL as f32).count();
    let share = within as f64 / near.len() as f64;
    let mut sorted = near.clone();
    sorted.sort_by(f32::total_cmp);
    let median = sorted[sorted.len() / 2];
    println!(
        "{} vertices, {:.0} % on planes, {:.1} % of those within 1.5 voxels, median {:.2} mm",
        mesh.positions.len(),
        100.0 * share_on_planes,
        100.0 * share,
        1e3 * median
    );
    assert!(share >= 0.97, "{share}");
    assert!(median <= 0.25 * VOXEL as f32, "{median}");

    // Every triangle faces the free space it was seen from: its normal points towards the
    // nearest camera.
    let cameras: Vec<Vector3<f32>> = ds
        .images
        .iter()
        .map(|i| i.frame.pose.translation.map(|v| v as f32))
        .collect();
    let facing = (0..mesh.triangle_count())
        .filter(|&t| {
            let [a, b, c] = mesh.triangle(t).map(Vector3::from);
            let n = (b - a).cross(&(c - a));
            let centre = (a + b + c) / 3.0;
            let cam = cameras
                .iter()
                .min_by(|x, y| (*x - centre).norm().total_cmp(&(*y - centre).norm()))
                .expect("cameras");
            n.dot(&(cam - centre)) > 0.0
        })
        .count();
    let facing = facing as f64 / mesh.triangle_count() as f64;
    assert!(facing > 0.9, "{facing}");
    Ok(())
}

#[test]
fn a_scan_becomes_a_glb_that_synth_imports_upright() -> TestResult {
    let dir = tempfile::tempdir()?;
    rendered_walk(dir.path())?;
    let ds = posed::open(dir.path())?;
    let frames: Vec<&PosedImage> = ds.images.iter().collect();
    let cfg = ScanConfig {
        fuse: fuse_config(),
        max_triangles: 20_000,
        ..ScanConfig::default()
    };
    let scan = recon::scan(&ds, &frames, &cfg, &|| {})?;
    assert!(scan.textured.triangle_count() <= 20_000);
    // The building is z up already: levelling finds its floor.
    assert!(
        scan.dataset_to_world.rotation.angle() < 0.2f64.to_radians(),
        "{}",
        scan.dataset_to_world.rotation.angle().to_degrees()
    );
    let out = tempfile::tempdir()?;
    let glb = out.path().join("scan.glb");
    let ply = scan.write(&glb, "rendered walk")?;
    assert!(ply.is_file());
    let (world, _) = synth::import::load(&glb, &synth::import::ImportOptions::default())?;
    assert_eq!(world.triangles.len(), scan.textured.triangle_count());
    // Its texture is known for an atlas of cells, so that renders stop its mips at a cell.
    let cell = recon::atlas::MIN_CELL as u32;
    assert!(
        world.materials.iter().all(
            |m| matches!(m.pattern, synth::world::Pattern::Atlas { cell: c, .. } if c == cell)
        ),
        "{:?}",
        world.materials.iter().map(|m| &m.name).collect::<Vec<_>>()
    );
    let (lo, hi) = world.bounds().ok_or("empty")?;
    let (slo, shi) = scan.colored.bounds().ok_or("empty")?;
    for k in 0..3 {
        assert!((lo[k] - slo[k]).abs() < 1e-3 && (hi[k] - shi[k]).abs() < 1e-3);
    }
    // The transform back to the dataset's frame is in the file.
    let bytes = std::fs::read(&glb)?;
    let json_len = u32::from_le_bytes(bytes[12..16].try_into()?) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len])?;
    let m: Vec<f64> = serde_json::from_value(
        doc["asset"]["extras"]["indoorloc_scan"]["dataset_to_world"].clone(),
    )?;
    let back = Pose::from_row_major(&m.try_into().map_err(|_| "16 numbers")?)?;
    assert!(back.rotation.angle_to(&scan.dataset_to_world.rotation) < 1e-9);
    Ok(())
}

#[test]
fn a_dataset_without_depth_is_refused_by_name() -> TestResult {
    let dir = tempfile::tempdir()?;
    rendered_walk(dir.path())?;
    std::fs::remove_dir_all(dir.path().join("depth"))?;
    let ds = posed::open(dir.path())?;
    let frames: Vec<&PosedImage> = ds.images.iter().collect();
    let err = fuse(&ds, &frames, &fuse_config(), &|| {})
        .err()
        .ok_or("accepted")?;
    let msg = err.to_string();
    assert!(msg.contains("no depth image"), "{msg}");
    assert!(msg.contains(&dir.path().display().to_string()), "{msg}");
    Ok(())
}

#[test]
fn depth_in_metres_instead_of_millimetres_is_caught() -> TestResult {
    let dir = tempfile::tempdir()?;
    rendered_walk(dir.path())?;
    for entry in std::fs::read_dir(dir.path().join("depth"))? {
        let path = entry?.path();
        let mut d = image::open(&path)?.into_luma16();
        for v in d.iter_mut() {
            *v /= 1000;
        }
        d.save(&path)?;
    }
    let ds = posed::open(dir.path())?;
    let frames: Vec<&PosedImage> = ds.images.iter().collect();
    let err = fuse(&ds, &frames, &fuse_config(), &|| {})
        .err()
        .ok_or("accepted")?;
    let msg = err.to_string();
    assert!(
        msg.contains("units") && msg.contains("median depth"),
        "{msg}"
    );
    Ok(())
}

#[test]
fn poses_that_do_not_fit_the_depth_are_warned_about_with_the_residual() -> TestResult {
    let dir = tempfile::tempdir()?;
    rendered_walk(dir.path())?;
    let mut ds = posed::open(dir.path())?;
    // World-to-camera poses where camera-to-world ones belong (the commonest mix-up): each
    // frame's surfaces land somewhere else.
    for img in ds.images.iter_mut() {
        img.frame.pose = img.frame.pose.inverse();
    }
    let frames: Vec<&PosedImage> = ds.images.iter().collect();
    let (_, report) = fuse(&ds, &frames, &fuse_config(), &|| {})?;
    println!("{report:?}");
    assert!(
        report.warnings.iter().any(|w| w.contains("residual")),
        "{report:?}"
    );
    Ok(())
}
