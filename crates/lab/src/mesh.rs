//! `indoorloc mesh`: a posed RGB-D dataset fused into a textured mesh (`recon`), written as GLB
//! (for `synth --world`) and PLY.

use crate::output::{print_json, print_text};
use crate::{Result, bail, progress};
use clap::Args;
use data::blocks::BlockSplit;
use data::posed::{self, SplitPlan};
use recon::{FuseConfig, FuseReport, ScanConfig};
use serde::Serialize;
use std::ops::Range;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `indoorloc mesh`.
#[derive(Args, Debug)]
pub struct MeshConfig {
    /// A posed RGB-D dataset: 7-Scenes, TUM RGB-D, or native with `depth/`.
    #[arg(long, value_name = "DATASET")]
    data: PathBuf,
    /// The GLB file to write; the PLY goes beside it.
    #[arg(long, value_name = "FILE.glb")]
    out: PathBuf,
    /// Voxel edge, metres.
    #[arg(long, default_value_t = 0.01)]
    voxel: f64,
    /// Truncation distance, voxels.
    #[arg(long, default_value_t = FuseConfig::default().truncation_voxels)]
    truncation: f64,
    /// Frames to fuse, START..END (0-based, END excluded; either may be left out), counted in
    /// the dataset's order (after --blocks).
    #[arg(long, value_name = "RANGE", value_parser = parse_range)]
    frames: Option<Range<usize>>,
    /// Fuse every n-th frame.
    #[arg(long, default_value_t = 1)]
    stride: usize,
    /// Only the training and validation blocks of this split, BLOCK:EVERY[:OFFSET] (a mesh to
    /// evaluate on the held-out frames with).
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
    /// Most triangles after simplification.
    #[arg(long, default_value_t = ScanConfig::default().max_triangles)]
    max_triangles: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// `--frames START..END`.
fn parse_range(s: &str) -> std::result::Result<Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("'{s}': expected START..END, e.g. 0..400"))?;
    let num = |t: &str, empty: usize| -> std::result::Result<usize, String> {
        if t.is_empty() {
            Ok(empty)
        } else {
            t.parse()
                .map_err(|_| format!("'{t}' in '{s}' is not a frame number"))
        }
    };
    let range = num(a, 0)?..num(b, usize::MAX)?;
    if range.is_empty() {
        return Err(format!("'{s}' selects no frames"));
    }
    Ok(range)
}

/// What `mesh` prints.
#[derive(Debug, Serialize)]
struct MeshOutput {
    glb: PathBuf,
    ply: PathBuf,
    dataset: String,
    voxel_m: f64,
    extracted_triangles: usize,
    triangles: usize,
    atlas: [u32; 2],
    texel_m: f64,
    glb_bytes: u64,
    fuse: FuseReport,
    fuse_s: f64,
    extract_s: f64,
    simplify_s: f64,
    bake_s: f64,
    seconds: f64,
}

/// Runs `indoorloc mesh`.
pub fn run(args: &MeshConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let t = Instant::now();
    if args.stride == 0 || args.max_triangles == 0 {
        bail!("--stride and --max-triangles must be at least 1");
    }
    let ds = posed::open(&args.data)?;
    let images = match args.blocks {
        Some(b) => ds.mapped(SplitPlan::Blocks(b)),
        None => ds.images.iter().collect(),
    };
    let cfg = ScanConfig {
        fuse: FuseConfig {
            voxel_m: args.voxel,
            truncation_voxels: args.truncation,
            frames: args.frames.clone(),
            stride: args.stride,
            ..FuseConfig::default()
        },
        max_triangles: args.max_triangles,
        ..ScanConfig::default()
    };
    let count = recon::volume::selected(&images, &cfg.fuse).len();
    let pb = progress::bar(count as u64, "frames fused");
    if args.json {
        pb.hide();
    }
    let scan = recon::scan(&ds, &images, &cfg, &|| pb.inc(1))?;
    pb.finish_and_clear();
    let ply = scan.write(&args.out, &args.data.display().to_string())?;
    if !args.json {
        for w in &scan.report.warnings {
            progress::note(&format!("warning: {w}"));
        }
    }
    let out = MeshOutput {
        glb: args.out.clone(),
        ply,
        dataset: ds.name(),
        voxel_m: args.voxel,
        extracted_triangles: scan.extracted_triangles,
        triangles: scan.textured.triangle_count(),
        atlas: [scan.textured.atlas.width(), scan.textured.atlas.height()],
        texel_m: scan.textured.texel_m,
        glb_bytes: std::fs::metadata(&args.out)?.len(),
        fuse: scan.report.clone(),
        fuse_s: scan.seconds[0],
        extract_s: scan.seconds[1],
        simplify_s: scan.seconds[2],
        bake_s: scan.seconds[3],
        seconds: t.elapsed().as_secs_f64(),
    };
    if args.json {
        return print_json(sink, &out);
    }
    print_text(
        sink,
        &format!(
            "mesh {} ({:.1} MB) and {}: {} frames of {} at {} cm voxels, {} blocks\n\
             {} triangles extracted, {} kept; atlas {}x{} at {:.1} mm per texel\n\
             median depth {:.2} m, valid depth {:.0} %, median TSDF residual {:.1} mm\n\
             {:.1} s (fuse {:.1}, extract {:.1}, simplify {:.1}, atlas {:.1})\n",
            out.glb.display(),
            out.glb_bytes as f64 / 1e6,
            out.ply.display(),
            out.fuse.frames,
            out.dataset,
            100.0 * out.voxel_m,
            out.fuse.blocks,
            out.extracted_triangles,
            out.triangles,
            out.atlas[0],
            out.atlas[1],
            1e3 * out.texel_m,
            out.fuse.median_depth_m,
            100.0 * out.fuse.valid_depth_share,
            1e3 * out.fuse.median_residual_m,
            out.seconds,
            out.fuse_s,
            out.extract_s,
            out.simplify_s,
            out.bake_s
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::parse_range;

    #[test]
    fn frame_ranges_parse_with_open_ends() {
        assert_eq!(parse_range("0..400"), Ok(0..400));
        assert_eq!(parse_range("500.."), Ok(500..usize::MAX));
        assert_eq!(parse_range("..10"), Ok(0..10));
        assert!(parse_range("10..10").is_err());
        assert!(parse_range("10-20").is_err());
        assert!(parse_range("a..3").is_err());
    }
}
