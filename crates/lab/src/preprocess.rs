//! `indoorloc preprocess`: writes the network's view of images (grey, resized, CLAHE, ...) as
//! PNGs, one per input, in parallel over images.
//!
//! A bad image (unreadable, truncated, not an image) does not stop the others: every good image
//! is written, the bad ones are listed (table and `--json` key `bad`), and the exit code is 2 with
//! a one-line error naming the first bad file.

use crate::output::{print_json, print_text};
use crate::progress::bar;
use crate::{Context, Result, bail};
use clap::Args;
use data::frames::{IMAGE_EXTENSIONS, ImageFolder};
use image::ImageFormat;
use imgproc::view::{Op, Scratch, View, ViewSpec};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `indoorloc preprocess`.
#[derive(Args, Debug)]
pub struct PreprocessConfig {
    /// Image files, or folders whose images (png, jpg, jpeg, bmp) are all taken.
    #[arg(required = true, value_name = "INPUT")]
    inputs: Vec<PathBuf>,
    /// Output folder: one `<stem>.png` per input image.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Resize to WIDTHxHEIGHT (OpenCV INTER_AREA down, bilinear up).
    #[arg(long, value_parser = crate::parse::size, value_name = "WxH")]
    size: Option<(u32, u32)>,
    /// Convert to grey (OpenCV 5's fixed-point BT.601, bit-identical).
    #[arg(long)]
    gray: bool,
    /// CLAHE after the resize, as OpenCV's createCLAHE(CLIP, (TILES, TILES)); implies --gray.
    #[arg(long, value_parser = parse_clahe, value_name = "CLIP,TILES")]
    clahe: Option<(f32, u32)>,
    /// A whole view instead of the three options above: a preset (gray160, rgb256, rgb224,
    /// place240, gradmag, edges) or spec text such as "gray,resize=160x120,clahe=2.0/8".
    /// Without any of these options the ceiling-camera view gray160 is made.
    #[arg(long, conflicts_with_all = ["size", "gray", "clahe"])]
    view: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// `CLIP,TILES`, e.g. `2.0,8`.
fn parse_clahe(s: &str) -> std::result::Result<(f32, u32), String> {
    let err = || format!("'{s}': expected CLIP,TILES with CLIP > 0 and TILES >= 1, e.g. 2.0,8");
    let (clip, tiles) = s.split_once(',').ok_or_else(err)?;
    let clip: f32 = clip.trim().parse().map_err(|_| err())?;
    let tiles: u32 = tiles.trim().parse().map_err(|_| err())?;
    if !(clip.is_finite() && clip > 0.0) || tiles == 0 {
        return Err(err());
    }
    Ok((clip, tiles))
}

impl PreprocessConfig {
    /// The view the options describe.
    fn spec(&self) -> Result<ViewSpec> {
        if let Some(text) = &self.view {
            return ViewSpec::resolve(text).with_context(|| format!("--view {text}"));
        }
        if self.size.is_none() && !self.gray && self.clahe.is_none() {
            return Ok(ViewSpec::preset("gray160")?);
        }
        let mut ops = Vec::new();
        if self.gray || self.clahe.is_some() {
            ops.push(Op::Gray);
        }
        if let Some((width, height)) = self.size {
            ops.push(Op::Resize { width, height });
        }
        if let Some((clip, tiles)) = self.clahe {
            ops.push(Op::Clahe { clip, tiles });
        }
        Ok(ViewSpec::new(ops)?)
    }
}

/// One image written.
#[derive(Debug, Serialize)]
struct Written {
    image: PathBuf,
    out: PathBuf,
    width: u32,
    height: u32,
    /// Time of the view alone (decoding and PNG writing excluded), milliseconds.
    view_ms: f64,
}

/// One image that could not be processed.
#[derive(Debug, Serialize)]
struct Bad {
    image: PathBuf,
    error: String,
}

/// The `--json` document.
#[derive(Debug, Serialize)]
struct PreprocessOutput {
    view: String,
    images: Vec<Written>,
    bad: Vec<Bad>,
    /// Median time of the view per image, milliseconds (on one worker thread).
    ms_per_image: f64,
    /// Median decoding time per image, milliseconds.
    decode_ms_per_image: f64,
    threads: usize,
    seconds: f64,
}

/// Runs `indoorloc preprocess`.
pub fn run(args: &PreprocessConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let spec = args.spec()?;
    let files = expand_inputs(&args.inputs)?;
    let outputs = output_paths(&files, &args.out)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("building the thread pool")?;
    let threads = pool.current_num_threads();

    let start = Instant::now();
    let pb = bar(files.len() as u64, "images");
    let results: Vec<std::result::Result<(Written, f64), Bad>> = pool.install(|| {
        files
            .par_iter()
            .zip(&outputs)
            .map_init(Scratch::new, |scratch, (file, out)| {
                let r = process(&spec, file, out, scratch).map_err(|e| Bad {
                    image: file.clone(),
                    error: format!("{e:#}"),
                });
                pb.inc(1);
                r
            })
            .collect()
    });
    pb.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();

    let (mut images, mut bad, mut decode_ms) = (Vec::new(), Vec::new(), Vec::new());
    for r in results {
        match r {
            Ok((w, d)) => {
                decode_ms.push(d);
                images.push(w);
            }
            Err(b) => bad.push(b),
        }
    }
    let output = PreprocessOutput {
        view: spec.to_string(),
        ms_per_image: crate::output::median(&images.iter().map(|w| w.view_ms).collect::<Vec<_>>()),
        decode_ms_per_image: crate::output::median(&decode_ms),
        images,
        bad,
        threads,
        seconds,
    };
    if args.json {
        print_json(sink, &output)?;
    } else {
        print_text(sink, &summary_text(&output, &args.out))?;
    }
    if let Some(first) = output.bad.first() {
        bail!(
            "{}: {} ({} of {} images could not be processed; the others were written)",
            first.image.display(),
            first.error,
            output.bad.len(),
            files.len()
        );
    }
    Ok(())
}

/// Decodes `file`, makes its view and writes it to `out` atomically; returns what was written
/// and the decoding time in milliseconds.
fn process(
    spec: &ViewSpec,
    file: &Path,
    out: &Path,
    scratch: &mut Scratch,
) -> Result<(Written, f64)> {
    let t0 = Instant::now();
    let img = data::frames::decode_image(file)?;
    let decode_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let view: View = spec.apply_with(&img, 0, scratch)?;
    let view_ms = t1.elapsed().as_secs_f64() * 1e3;
    let pixels = view.to_image()?;
    let mut png = Vec::new();
    pixels
        .write_to(&mut Cursor::new(&mut png), ImageFormat::Png)
        .context("encoding PNG")?;
    data::io::write_atomic(out, |w| w.write_all(&png))?;
    Ok((
        Written {
            image: file.to_path_buf(),
            out: out.to_path_buf(),
            width: view.width,
            height: view.height,
            view_ms,
        },
        decode_ms,
    ))
}

/// The image files of the inputs, in order: files as given, folders in natural order.
fn expand_inputs(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if input.is_dir() {
            files.extend(ImageFolder::open(input)?.files().iter().cloned());
        } else if input.is_file() {
            files.push(input.clone());
        } else {
            bail!("{}: no such file or folder", input.display());
        }
    }
    Ok(files)
}

/// `DIR/<stem>.png` for each file; two inputs with the same stem would overwrite each other, so
/// that is an error naming both.
fn output_paths(files: &[PathBuf], dir: &Path) -> Result<Vec<PathBuf>> {
    let mut seen: HashMap<String, &Path> = HashMap::new();
    let mut out = Vec::with_capacity(files.len());
    for file in files {
        let stem = file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty())
            .with_context(|| format!("{}: no file name", file.display()))?;
        if let Some(other) = seen.insert(stem.clone(), file) {
            bail!(
                "{}: has the same name as {} (outputs are named by stem: {stem}.png); \
                 preprocess them into different folders",
                file.display(),
                other.display()
            );
        }
        out.push(dir.join(format!("{stem}.png")));
    }
    Ok(out)
}

fn summary_text(o: &PreprocessOutput, dir: &Path) -> String {
    let mut t = format!(
        "view      {}\nwritten   {} images to {}\nbad       {}\nms/image  {:.3} (view) + {:.3} (decode), {} threads, {:.2} s in all\n",
        o.view,
        o.images.len(),
        dir.display(),
        o.bad.len(),
        o.ms_per_image,
        o.decode_ms_per_image,
        o.threads,
        o.seconds
    );
    for b in &o.bad {
        t.push_str(&format!("  bad: {}: {}\n", b.image.display(), b.error));
    }
    if o.images.is_empty() && o.bad.is_empty() {
        t.push_str(&format!(
            "no images ({}) among the inputs\n",
            IMAGE_EXTENSIONS.join(", ")
        ));
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clahe_values_parse() {
        assert_eq!(parse_clahe("2.0,8"), Ok((2.0, 8)));
        assert_eq!(parse_clahe(" 3 , 4 "), Ok((3.0, 4)));
        for bad in ["2.0", "0,8", "-1,8", "2,0", "nan,8", "a,b"] {
            assert!(parse_clahe(bad).is_err(), "{bad}");
        }
    }

    fn args(extra: &[&str]) -> PreprocessConfig {
        use clap::Parser;
        #[derive(Parser)]
        struct Wrap {
            #[command(flatten)]
            a: PreprocessConfig,
        }
        let mut argv = vec!["x", "in.png", "--out", "o"];
        argv.extend_from_slice(extra);
        Wrap::parse_from(argv).a
    }

    #[test]
    fn options_make_the_contract_views() -> Result<()> {
        assert_eq!(args(&[]).spec()?, ViewSpec::preset("gray160")?);
        assert_eq!(
            args(&["--size", "160x120", "--clahe", "2.0,8"]).spec()?,
            ViewSpec::preset("gray160")?
        );
        assert_eq!(
            args(&["--size", "64x48"]).spec()?.to_string(),
            "resize=64x48"
        );
        assert_eq!(args(&["--gray"]).spec()?.to_string(), "gray");
        assert_eq!(
            args(&["--view", "rgb256"]).spec()?,
            ViewSpec::preset("rgb256")?
        );
        assert!(args(&["--view", "nonsense"]).spec().is_err());
        Ok(())
    }

    #[test]
    fn same_stems_are_refused() {
        let files = [PathBuf::from("a/x.png"), PathBuf::from("b/x.jpg")];
        let err = output_paths(&files, Path::new("o")).unwrap_err();
        assert!(format!("{err}").contains("b/x.jpg"), "{err}");
    }
}
