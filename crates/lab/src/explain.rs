//! `indoorloc explain`: Grad-CAM maps of what a pose network looks at, drawn over each frame
//! (`learn::explain` computes them, `report::saliency_overlay` draws them).

use crate::output::{print_json, print_text};
use crate::{Context, Result, bail};
use clap::Args;
use data::frames;
use learn::{CamLayer, Estimate, Explainer, Localizer, Saliency};
use report::Table;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `indoorloc explain`.
#[derive(Args, Debug)]
pub struct ExplainConfig {
    /// Model folder (from `train` or `demo`).
    #[arg(long, value_name = "MODEL")]
    model: PathBuf,
    /// An image, an image folder or a video.
    input: PathBuf,
    /// Folder for the pictures (`<frame>.cam.png`), created.
    #[arg(long, value_name = "DIR", default_value = "indoorloc-explain")]
    out: PathBuf,
    /// Explain every N-th frame.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    every: u64,
    /// Stop after this many pictures.
    #[arg(long, default_value_t = 32)]
    max: usize,
    /// The feature map weighed: `mid` (the backbone's stride-8 map, finer) or `last` (its last
    /// map, Grad-CAM's usual choice).
    #[arg(long, default_value = "mid", value_parser = ["mid", "last"])]
    layer: String,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One explained frame.
#[derive(Debug, Serialize)]
struct Row {
    /// Frame name (file stem, or index in a video).
    frame: String,
    /// The picture written.
    picture: PathBuf,
    /// Estimated position, metres.
    position: [f64; 3],
    /// The explained score (½‖x̂‖² of the standardised position outputs).
    score: f64,
    /// Where the map peaks, as fractions of the image's width and height.
    peak: (f64, f64),
    /// Share of the map's cells above half its peak: how spread the evidence is.
    hot_share: f64,
}

/// A model loaded to localize and to explain.
pub(crate) struct Explained {
    loc: Localizer,
    explainer: Explainer,
    layer: CamLayer,
}

impl Explained {
    /// Loads the model folder `dir` twice over: for inference and on an autodiff device.
    pub(crate) fn load(dir: &Path, layer: CamLayer) -> Result<Explained> {
        Ok(Explained {
            loc: Localizer::load(dir)?,
            explainer: Explainer::load(dir)?,
            layer,
        })
    }
}

/// A frame's estimate and Grad-CAM map, and the map drawn over the frame.
pub(crate) fn explain_image(
    model: &Explained,
    img: &image::DynamicImage,
) -> Result<(Estimate, Saliency, image::RgbImage)> {
    let view = model.loc.view(img)?;
    let est = model.loc.predict_view(&view, 0)?;
    let cam = model.explainer.grad_cam(&view, model.layer)?;
    let overlay = report::saliency_overlay(&img.to_rgb8(), cam.width, cam.height, &cam.values)?;
    Ok((est, cam, overlay))
}

/// Writes `img` as a PNG at `path`, atomically.
pub(crate) fn write_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .context("cannot encode a PNG")?;
    data::io::write_atomic(path, |w| w.write_all(&png))
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Runs `indoorloc explain`.
pub fn run(args: &ExplainConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let model = Explained::load(&args.model, args.layer.parse()?)?;
    let source = frames::open(&args.input)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut rows = Vec::new();
    for (i, frame) in source.enumerate() {
        if rows.len() >= args.max {
            break;
        }
        if !(i as u64).is_multiple_of(args.every) {
            continue;
        }
        let frame = frame?;
        let img = image::DynamicImage::ImageRgb8(frame.image);
        let (est, cam, overlay) = explain_image(&model, &img)
            .with_context(|| format!("{}: frame {}", args.input.display(), frame.name))?;
        let picture = args.out.join(format!("{}.cam.png", frame.name));
        write_png(&picture, &overlay)?;
        let hot = cam.values.iter().filter(|&&v| v > 0.5).count();
        rows.push(Row {
            frame: frame.name,
            picture,
            position: est.pose.position(),
            score: cam.score,
            peak: cam.peak(),
            hot_share: hot as f64 / cam.values.len().max(1) as f64,
        });
    }
    if rows.is_empty() {
        bail!("{}: no frame to explain", args.input.display());
    }
    if args.json {
        return print_json(sink, &rows);
    }
    let mut t = Table::new(
        "Grad-CAM: what the network looks at for the position",
        [
            "frame",
            "x (m)",
            "y (m)",
            "z (m)",
            "peak (x, y)",
            "hot cells",
            "picture",
        ],
    );
    for r in &rows {
        t.push_row([
            r.frame.clone(),
            format!("{:.2}", r.position[0]),
            format!("{:.2}", r.position[1]),
            format!("{:.2}", r.position[2]),
            format!("{:.2}, {:.2}", r.peak.0, r.peak.1),
            format!("{:.0} %", 100.0 * r.hot_share),
            r.picture.display().to_string(),
        ]);
    }
    print_text(sink, &t.to_text())
}
