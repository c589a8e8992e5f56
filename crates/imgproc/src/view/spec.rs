//! The view spec: a list of [`Op`]s, serialisable (stored in every checkpoint so inference sees
//! what training saw) and writable as one line of text.
//!
//! # Text grammar
//!
//! ```text
//! spec  := op ("," op)*                 whitespace around ops is ignored
//! op    := "gray"                        RGB -> grey (OpenCV 5 fixed-point BT.601)
//!        | "resize=" W "x" H             INTER_AREA down (bit-exact), bilinear up
//!        | "center-crop=" W "x" H        centred crop (offset rounded down)
//!        | "random-crop=" W "x" H        crop at a position drawn from the apply seed
//!        | "clahe=" CLIP "/" TILES       OpenCV createCLAHE(CLIP, (TILES, TILES)); grey only
//!        | "equalize"                    OpenCV equalizeHist; grey only
//!        | "gradmag=" ("sobel"|"scharr") gradient magnitude, scaled to 8 bits; grey only
//!        | "canny=" LOW "/" HIGH         Canny edges (L1 Sobel thresholds); grey only
//!        | "norm=pm1"                    x / 127.5 - 1, into [-1, 1]
//!        | "norm=imagenet"               ImageNet mean/std
//!        | "norm=" M[":"M]* "/" S[":"S]* per-channel mean and std in [0, 1] units
//! ```
//!
//! Example: `gray,resize=160x120,clahe=2.0/8`. Rules checked by [`ViewSpec::validate`]: at least
//! one op, sizes `1..=32768`, grey-only ops after `gray`, `norm` only as the last op. Without
//! `norm` a view holds `x / 255`. [`std::fmt::Display`] prints the canonical form, which parses
//! back to an equal spec.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::{ImgprocError, Result};

use super::gradient::Kernel;
use super::normalize::{IMAGENET_MEAN, IMAGENET_STD, Norm};

/// Largest width or height a spec may ask for.
pub const MAX_SIZE: u32 = 32768;

/// One step of a view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Op {
    /// Resize to `width x height`: OpenCV `INTER_AREA` when no axis grows, bilinear otherwise.
    Resize {
        /// Output width.
        width: u32,
        /// Output height.
        height: u32,
    },
    /// Crop the centre `width x height` (offset `(W - width) / 2`, rounded down).
    CenterCrop {
        /// Crop width.
        width: u32,
        /// Crop height.
        height: u32,
    },
    /// Crop `width x height` at a position drawn uniformly from the seed given to
    /// [`ViewSpec::apply`] (training-time augmentation).
    RandomCrop {
        /// Crop width.
        width: u32,
        /// Crop height.
        height: u32,
    },
    /// RGB to grey, bit-identical to OpenCV 5's `cvtColor(RGB2GRAY)`.
    Gray,
    /// CLAHE, bit-identical to OpenCV's `createCLAHE(clip, (tiles, tiles))`. Grey only.
    Clahe {
        /// Clip limit (> 0), in multiples of the mean histogram bin.
        clip: f32,
        /// Tile grid per axis (1..=256).
        tiles: u32,
    },
    /// Global histogram equalisation (OpenCV `equalizeHist`). Grey only.
    Equalize,
    /// Gradient magnitude scaled to 8 bits (see [`super::grad_mag`]). Grey only.
    GradMag {
        /// Derivative kernel.
        kernel: Kernel,
    },
    /// Canny edges (see [`super::canny`]). Grey only.
    Canny {
        /// Lower hysteresis threshold on `|gx| + |gy|`.
        low: f32,
        /// Upper hysteresis threshold.
        high: f32,
    },
    /// Normalisation applied when converting to the tensor; must be the last op.
    Normalize(Norm),
}

impl Op {
    /// True for the ops that need a grey image.
    pub fn needs_gray(&self) -> bool {
        matches!(
            self,
            Op::Clahe { .. } | Op::Equalize | Op::GradMag { .. } | Op::Canny { .. }
        )
    }
}

/// A composable, serialisable description of how an image becomes a network input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewSpec {
    /// The ops, applied in order.
    pub ops: Vec<Op>,
}

/// Names accepted by [`ViewSpec::preset`].
pub const PRESET_NAMES: &[&str] = &[
    "gray160", "rgb256", "rgb224", "rgb320", "place240", "gradmag", "edges",
];

impl ViewSpec {
    /// A spec from ops (validated).
    pub fn new(ops: Vec<Op>) -> Result<Self> {
        let spec = ViewSpec { ops };
        spec.validate()?;
        Ok(spec)
    }

    /// A named preset (see [`PRESET_NAMES`]).
    pub fn preset(name: &str) -> Result<Self> {
        let text = match name {
            // The ceiling-camera view: small grey images with local contrast equalised, so that
            // lamps and dark corners both keep detail; OpenCV-identical for OpenCV-trained models.
            "gray160" => "gray,resize=160x120,clahe=2.0/8",
            // 6-DoF pose regression (PoseNet family): square RGB in [-1, 1].
            "rgb256" => "resize=256x256,norm=pm1",
            // Backbones pretrained at 224: the centre of the rgb256 view (training swaps in
            // random-crop=224x224 for augmentation).
            "rgb224" => "resize=256x256,center-crop=224x224,norm=pm1",
            // Real 640x480 photos on an ImageNet-pretrained backbone (MobileNetV2): the frame at
            // half size, aspect kept, ImageNet statistics.
            "rgb320" => "resize=320x240,norm=imagenet",
            // Place recognition / classification on ImageNet-pretrained backbones, which expect
            // ImageNet statistics.
            "place240" => "resize=240x240,norm=imagenet",
            // BIM-trained networks: gradients keep geometry and drop paint and lighting, so
            // synthetic renders and photos look alike.
            "gradmag" => "gray,resize=160x120,gradmag=sobel",
            // BIM-trained networks on binary edge maps, the closest photos get to line renders.
            "edges" => "gray,resize=160x120,canny=50.0/150.0",
            _ => {
                return Err(ImgprocError::Spec {
                    spec: name.to_string(),
                    msg: format!("unknown preset; known: {}", PRESET_NAMES.join(", ")),
                });
            }
        };
        text.parse()
    }

    /// A preset name or, failing that, spec text (so a command-line `--view` takes either).
    pub fn resolve(text: &str) -> Result<Self> {
        if PRESET_NAMES.contains(&text.trim()) {
            return Self::preset(text.trim());
        }
        text.parse()
    }

    /// Channels of the views this spec makes: 1 after `gray`, else 3.
    pub fn channels(&self) -> u32 {
        if self.ops.contains(&Op::Gray) { 1 } else { 3 }
    }

    /// Size of the view made from a `width x height` image.
    pub fn output_size(&self, width: u32, height: u32) -> (u32, u32) {
        self.ops.iter().fold((width, height), |size, op| match op {
            Op::Resize { width, height }
            | Op::CenterCrop { width, height }
            | Op::RandomCrop { width, height } => (*width, *height),
            _ => size,
        })
    }

    /// The normalisation of the spec, if any (it is the last op).
    pub fn norm(&self) -> Option<&Norm> {
        match self.ops.last() {
            Some(Op::Normalize(n)) => Some(n),
            _ => None,
        }
    }

    /// Checks the rules of the module doc; errors name the offending op.
    pub fn validate(&self) -> Result<()> {
        let err = |msg: String| ImgprocError::Spec {
            spec: self.to_string(),
            msg,
        };
        if self.ops.is_empty() {
            return Err(err("a view needs at least one op".into()));
        }
        let mut gray = false;
        let last = self.ops.len() - 1;
        for (i, op) in self.ops.iter().enumerate() {
            let at = format!("op {} ({})", i + 1, OpText(op));
            match op {
                Op::Resize { width, height }
                | Op::CenterCrop { width, height }
                | Op::RandomCrop { width, height } => {
                    if *width == 0 || *height == 0 || *width > MAX_SIZE || *height > MAX_SIZE {
                        return Err(err(format!("{at}: sizes must be 1..={MAX_SIZE}")));
                    }
                }
                Op::Gray => gray = true,
                Op::Clahe { clip, tiles } => super::clahe::check_params(*clip, *tiles)
                    .map_err(|e| err(format!("{at}: {e}")))?,
                Op::Canny { low, high } => super::canny::check_params(*low, *high)
                    .map_err(|e| err(format!("{at}: {e}")))?,
                Op::Normalize(n) => {
                    if i != last {
                        return Err(err(format!("{at}: norm must be the last op")));
                    }
                    n.check(Some(if gray { 1 } else { 3 }))
                        .map_err(|e| err(format!("{at}: {e}")))?;
                }
                Op::Equalize | Op::GradMag { .. } => {}
            }
            if op.needs_gray() && !gray {
                return Err(err(format!(
                    "{at}: works on grey images; put `gray` before it"
                )));
            }
        }
        Ok(())
    }
}

/// Text form of one op.
struct OpText<'a>(&'a Op);

impl fmt::Display for OpText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Op::Resize { width, height } => write!(f, "resize={width}x{height}"),
            Op::CenterCrop { width, height } => write!(f, "center-crop={width}x{height}"),
            Op::RandomCrop { width, height } => write!(f, "random-crop={width}x{height}"),
            Op::Gray => write!(f, "gray"),
            Op::Clahe { clip, tiles } => write!(f, "clahe={clip:?}/{tiles}"),
            Op::Equalize => write!(f, "equalize"),
            Op::GradMag { kernel } => write!(f, "gradmag={}", kernel.name()),
            Op::Canny { low, high } => write!(f, "canny={low:?}/{high:?}"),
            Op::Normalize(Norm::MinusOneOne) => write!(f, "norm=pm1"),
            Op::Normalize(Norm::MeanStd { mean, std })
                if mean[..] == IMAGENET_MEAN[..] && std[..] == IMAGENET_STD[..] =>
            {
                write!(f, "norm=imagenet")
            }
            Op::Normalize(Norm::MeanStd { mean, std }) => {
                let list = |v: &[f32]| {
                    v.iter()
                        .map(|x| format!("{x:?}"))
                        .collect::<Vec<_>>()
                        .join(":")
                };
                write!(f, "norm={}/{}", list(mean), list(std))
            }
        }
    }
}

impl fmt::Display for ViewSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, op) in self.ops.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            write!(f, "{}", OpText(op))?;
        }
        Ok(())
    }
}

impl FromStr for ViewSpec {
    type Err = ImgprocError;

    /// Parses the text grammar of the module doc and validates the result.
    fn from_str(text: &str) -> Result<Self> {
        let err = |msg: String| ImgprocError::Spec {
            spec: text.to_string(),
            msg,
        };
        let mut ops = Vec::new();
        for item in text.split(',') {
            let item = item.trim();
            let (name, arg) = match item.split_once('=') {
                Some((n, a)) => (n.trim(), Some(a.trim())),
                None => (item, None),
            };
            let need = |what: &str| arg.ok_or_else(|| err(format!("`{name}` needs `={what}`")));
            let op = match name {
                "gray" | "grey" => Op::Gray,
                "equalize" => Op::Equalize,
                "resize" => {
                    let (width, height) = size(need("WxH")?).map_err(err)?;
                    Op::Resize { width, height }
                }
                "center-crop" => {
                    let (width, height) = size(need("WxH")?).map_err(err)?;
                    Op::CenterCrop { width, height }
                }
                "random-crop" => {
                    let (width, height) = size(need("WxH")?).map_err(err)?;
                    Op::RandomCrop { width, height }
                }
                "clahe" => {
                    let (clip, tiles) = pair(need("CLIP/TILES")?, "clahe").map_err(err)?;
                    Op::Clahe {
                        clip: number(clip).map_err(err)?,
                        tiles: tiles.parse().map_err(|_| {
                            err(format!("clahe tiles `{tiles}` is not a whole number"))
                        })?,
                    }
                }
                "gradmag" => Op::GradMag {
                    kernel: match need("sobel|scharr")? {
                        "sobel" => Kernel::Sobel,
                        "scharr" => Kernel::Scharr,
                        k => {
                            return Err(err(format!(
                                "unknown gradmag kernel `{k}` (sobel, scharr)"
                            )));
                        }
                    },
                },
                "canny" => {
                    let (low, high) = pair(need("LOW/HIGH")?, "canny").map_err(err)?;
                    Op::Canny {
                        low: number(low).map_err(err)?,
                        high: number(high).map_err(err)?,
                    }
                }
                "norm" => Op::Normalize(match need("pm1|imagenet|MEAN/STD")? {
                    "pm1" => Norm::MinusOneOne,
                    "imagenet" => Norm::imagenet(),
                    a => {
                        let (mean, std) = pair(a, "norm").map_err(err)?;
                        let list =
                            |s: &str| s.split(':').map(number).collect::<Result<Vec<_>, _>>();
                        Norm::MeanStd {
                            mean: list(mean).map_err(err)?,
                            std: list(std).map_err(err)?,
                        }
                    }
                }),
                "" => return Err(err("empty op (stray comma?)".into())),
                other => return Err(err(format!("unknown op `{other}`"))),
            };
            if arg.is_some() && matches!(op, Op::Gray | Op::Equalize) {
                return Err(err(format!("`{name}` takes no argument")));
            }
            ops.push(op);
        }
        let spec = ViewSpec { ops };
        spec.validate().map_err(|e| match e {
            ImgprocError::Spec { msg, .. } => err(msg),
            other => other,
        })?;
        Ok(spec)
    }
}

/// `"160x120"` -> (160, 120).
fn size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| format!("size `{text}` is not WxH"))?;
    let num = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| format!("size `{text}` is not WxH with whole numbers"))
    };
    Ok((num(w)?, num(h)?))
}

/// `"a/b"` -> ("a", "b").
fn pair<'a>(text: &'a str, op: &str) -> Result<(&'a str, &'a str), String> {
    text.split_once('/')
        .map(|(a, b)| (a.trim(), b.trim()))
        .ok_or_else(|| format!("{op} argument `{text}` is not A/B"))
}

/// A finite `f32`.
fn number(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{text}` is not a finite number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_example() -> Result<()> {
        let spec: ViewSpec = "gray, resize=160x120 ,clahe=2.0/8".parse()?;
        assert_eq!(
            spec.ops,
            vec![
                Op::Gray,
                Op::Resize {
                    width: 160,
                    height: 120
                },
                Op::Clahe {
                    clip: 2.0,
                    tiles: 8
                }
            ]
        );
        assert_eq!(spec.to_string(), "gray,resize=160x120,clahe=2.0/8");
        Ok(())
    }

    #[test]
    fn text_round_trips_for_every_op() -> Result<()> {
        let texts = [
            "gray,resize=160x120,clahe=2.0/8",
            "resize=256x256,center-crop=224x224,norm=pm1",
            "resize=300x200,random-crop=224x180,norm=imagenet",
            "resize=64x64,norm=0.5:0.25:0.125/0.2:0.3:0.4",
            "gray,equalize,gradmag=scharr,norm=0.5/0.25",
            "gray,canny=12.5/40.0",
            "gray,resize=80x60,gradmag=sobel",
        ];
        for text in texts {
            let spec: ViewSpec = text.parse()?;
            assert_eq!(spec.to_string(), text);
            let again: ViewSpec = spec.to_string().parse()?;
            assert_eq!(again, spec);
        }
        Ok(())
    }

    /// Checkpoints store the spec in `model.toml`; tools read it as JSON.
    #[test]
    fn serde_round_trips_through_toml_and_json()
    -> std::result::Result<(), Box<dyn std::error::Error>> {
        for text in [
            "gray,resize=160x120,clahe=2.0/8",
            "resize=300x200,random-crop=224x180,norm=imagenet",
            "resize=64x64,norm=0.5:0.25:0.125/0.2:0.3:0.4",
            "gray,equalize,gradmag=scharr,norm=pm1",
            "gray,canny=12.5/40.0",
        ] {
            let spec: ViewSpec = text.parse()?;
            let stored = toml::to_string(&spec)?;
            assert_eq!(toml::from_str::<ViewSpec>(&stored)?, spec, "{stored}");
            let json = serde_json::to_string(&spec)?;
            assert_eq!(serde_json::from_str::<ViewSpec>(&json)?, spec, "{json}");
        }
        let json = serde_json::to_value(ViewSpec::preset("gray160")?)?;
        assert_eq!(json["ops"][2]["op"], "clahe");
        assert_eq!(json["ops"][2]["tiles"], 8);
        Ok(())
    }

    #[test]
    fn presets_parse_and_say_what_they_are() -> Result<()> {
        for name in PRESET_NAMES {
            let spec = ViewSpec::preset(name)?;
            assert_eq!(ViewSpec::resolve(name)?, spec);
            assert_eq!(spec.to_string().parse::<ViewSpec>()?, spec);
        }
        assert_eq!(ViewSpec::preset("gray160")?.channels(), 1);
        assert_eq!(
            ViewSpec::preset("rgb224")?.output_size(640, 480),
            (224, 224)
        );
        assert_eq!(
            ViewSpec::preset("place240")?.norm(),
            Some(&Norm::imagenet())
        );
        assert!(ViewSpec::preset("nope").is_err());
        Ok(())
    }

    #[test]
    fn invalid_specs_are_errors() {
        let bad = [
            "",
            "gray,,resize=1x1",
            "resize=0x120",
            "resize=160",
            "resize=160x-1",
            "clahe=2.0/8",
            "gray,clahe=0/8",
            "gray,clahe=-1/8",
            "gray,clahe=2.0/0",
            "gray,clahe=2.0",
            "gray,clahe=nan/8",
            "gray,canny=100/50",
            "gradmag=sobel",
            "gray,gradmag=prewitt",
            "norm=pm1,gray",
            "norm=0.5:0.5/0.2",
            "gray,norm=0.5:0.5:0.5/0.2:0.2:0.2",
            "norm=0.5/0",
            "blur=3",
            "gray=1",
        ];
        for text in bad {
            assert!(text.parse::<ViewSpec>().is_err(), "accepted `{text}`");
        }
        assert!(ViewSpec::new(vec![]).is_err());
    }
}
