//! From 8-bit images to `f32` CHW tensors ([`View`]) and back.
//!
//! Why by hand: this is the boundary to the networks; `image` has no planar float layout or
//! per-channel normalisation. Each channel's 256 possible values are mapped once into a table,
//! so the conversion is a table look-up per value and bit-identical between the two directions'
//! definitions below.

use image::{DynamicImage, GrayImage, ImageBuffer, Luma, Rgb, RgbImage};
use serde::{Deserialize, Serialize};

use crate::{ImgprocError, Result};

/// ImageNet channel means (RGB, in [0, 1] units), used by `norm=imagenet`.
pub const IMAGENET_MEAN: [f32; 3] = [0.485, 0.456, 0.406];
/// ImageNet channel standard deviations (RGB, in [0, 1] units).
pub const IMAGENET_STD: [f32; 3] = [0.229, 0.224, 0.225];

/// How 8-bit values become tensor values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "norm", rename_all = "snake_case")]
pub enum Norm {
    /// `x / 127.5 - 1`: 0 maps to -1, 255 to 1 (PoseNet-style regression networks).
    MinusOneOne,
    /// `(x / 255 - mean[c]) / std[c]` per channel (ImageNet-pretrained backbones). One value
    /// applies to every channel; otherwise there is one per channel.
    MeanStd {
        /// Channel means in [0, 1] units.
        mean: Vec<f32>,
        /// Channel standard deviations in [0, 1] units (each > 0).
        std: Vec<f32>,
    },
}

impl Norm {
    /// The ImageNet mean/std normalisation.
    pub fn imagenet() -> Self {
        Norm::MeanStd {
            mean: IMAGENET_MEAN.to_vec(),
            std: IMAGENET_STD.to_vec(),
        }
    }

    /// Checks the parameters for a tensor with `channels` channels (`None`: channel count not
    /// known yet, so only the values are checked).
    pub(crate) fn check(&self, channels: Option<usize>) -> Result<()> {
        let Norm::MeanStd { mean, std } = self else {
            return Ok(());
        };
        if mean.is_empty() || mean.len() != std.len() {
            return Err(ImgprocError::Param(format!(
                "normalisation needs as many means as standard deviations (>= 1), got {} and {}",
                mean.len(),
                std.len()
            )));
        }
        if let Some(c) = channels
            && mean.len() != 1
            && mean.len() != c
        {
            return Err(ImgprocError::Param(format!(
                "normalisation has {} values for a {c}-channel view",
                mean.len()
            )));
        }
        if mean.iter().any(|m| !m.is_finite()) || std.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(ImgprocError::Param(
                "normalisation means must be finite and standard deviations finite and > 0".into(),
            ));
        }
        Ok(())
    }

    /// Tensor value of 8-bit value `v` in channel `c`.
    fn forward(&self, v: u8, c: usize) -> f32 {
        match self {
            Norm::MinusOneOne => v as f32 / 127.5 - 1.0,
            Norm::MeanStd { mean, std } => {
                let (m, s) = (pick(mean, c), pick(std, c));
                (v as f32 / 255.0 - m) / s
            }
        }
    }

    /// 8-bit value of tensor value `x` in channel `c` (inverse of [`Norm::forward`], rounded).
    fn inverse(&self, x: f32, c: usize) -> u8 {
        let v = match self {
            Norm::MinusOneOne => (x + 1.0) * 127.5,
            Norm::MeanStd { mean, std } => (x * pick(std, c) + pick(mean, c)) * 255.0,
        };
        v.round().clamp(0.0, 255.0) as u8
    }
}

/// Value for channel `c` of a per-channel list (one value applies to all).
fn pick(v: &[f32], c: usize) -> f32 {
    v.get(c).or(v.first()).copied().unwrap_or(0.0)
}

/// A view as the networks see it: `channels x height x width` `f32` values, channel-major (CHW).
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Number of channels: 1 (grey) or 3 (RGB, in that order).
    pub channels: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `data[(c * height + y) * width + x]`.
    pub data: Vec<f32>,
    /// The normalisation applied; `None` means `x / 255` in [0, 1]. Kept so that
    /// [`View::to_image`] can undo it.
    pub norm: Option<Norm>,
}

impl View {
    /// Builds a view from interleaved 8-bit pixels.
    pub(crate) fn from_u8(
        raw: &[u8],
        channels: usize,
        (width, height): (u32, u32),
        norm: Option<&Norm>,
    ) -> Result<View> {
        if let Some(n) = norm {
            n.check(Some(channels))?;
        }
        let plane = width as usize * height as usize;
        if raw.len() != plane * channels {
            return Err(ImgprocError::Size(format!(
                "tensor: {} bytes for {width}x{height}x{channels}",
                raw.len()
            )));
        }
        let mut data = vec![0.0f32; plane * channels];
        for (c, out) in data
            .chunks_exact_mut(plane.max(1))
            .enumerate()
            .take(channels)
        {
            let table: Vec<f32> = (0..=255u8)
                .map(|v| match norm {
                    None => v as f32 / 255.0,
                    Some(n) => n.forward(v, c),
                })
                .collect();
            for (o, px) in out.iter_mut().zip(raw.chunks_exact(channels)) {
                *o = table[px[c] as usize];
            }
        }
        Ok(View {
            channels: channels as u32,
            width,
            height,
            data,
            norm: norm.cloned(),
        })
    }

    /// Index of value `(c, y, x)` in [`View::data`].
    pub fn index(&self, c: u32, y: u32, x: u32) -> usize {
        ((c as usize * self.height as usize) + y as usize) * self.width as usize + x as usize
    }

    /// Back to an 8-bit image (grey for 1 channel, RGB for 3), undoing the normalisation and
    /// rounding: for writing PNGs of views.
    pub fn to_image(&self) -> Result<DynamicImage> {
        let plane = self.width as usize * self.height as usize;
        let c = self.channels as usize;
        if self.data.len() != plane * c {
            return Err(ImgprocError::Size(format!(
                "view: {} values for {}x{}x{c}",
                self.data.len(),
                self.width,
                self.height
            )));
        }
        let to_u8 = |x: f32, ch: usize| match &self.norm {
            None => (x * 255.0).round().clamp(0.0, 255.0) as u8,
            Some(n) => n.inverse(x, ch),
        };
        let mut raw = vec![0u8; plane * c];
        for (ch, values) in self.data.chunks_exact(plane.max(1)).enumerate().take(c) {
            for (px, &x) in raw.chunks_exact_mut(c).zip(values) {
                px[ch] = to_u8(x, ch);
            }
        }
        let size_err = || ImgprocError::Size(format!("view {}x{}", self.width, self.height));
        match c {
            1 => {
                let img: GrayImage =
                    ImageBuffer::<Luma<u8>, _>::from_raw(self.width, self.height, raw)
                        .ok_or_else(size_err)?;
                Ok(DynamicImage::ImageLuma8(img))
            }
            3 => {
                let img: RgbImage =
                    ImageBuffer::<Rgb<u8>, _>::from_raw(self.width, self.height, raw)
                        .ok_or_else(size_err)?;
                Ok(DynamicImage::ImageRgb8(img))
            }
            _ => Err(ImgprocError::Param(format!(
                "only 1- and 3-channel views become images, not {c}"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chw_order_and_minus_one_one() -> Result<()> {
        // 2x1 RGB: pixel 0 = (0, 255, 51), pixel 1 = (255, 0, 102).
        let raw = [0u8, 255, 51, 255, 0, 102];
        let v = View::from_u8(&raw, 3, (2, 1), Some(&Norm::MinusOneOne))?;
        assert_eq!(v.data.len(), 6);
        assert_eq!(v.data[v.index(0, 0, 0)], -1.0);
        assert_eq!(v.data[v.index(0, 0, 1)], 1.0);
        assert_eq!(v.data[v.index(1, 0, 0)], 1.0);
        assert_eq!(v.data[v.index(1, 0, 1)], -1.0);
        assert!((v.data[v.index(2, 0, 0)] - (51.0 / 127.5 - 1.0)).abs() < 1e-7);
        assert_eq!(v.index(2, 0, 1), 5);
        Ok(())
    }

    #[test]
    fn mean_std_and_plain_scaling() -> Result<()> {
        let raw = [255u8, 0, 128];
        let v = View::from_u8(&raw, 3, (1, 1), Some(&Norm::imagenet()))?;
        assert!((v.data[0] - (1.0 - 0.485) / 0.229).abs() < 1e-6);
        assert!((v.data[1] - (0.0 - 0.456) / 0.224).abs() < 1e-6);
        assert!((v.data[2] - (128.0 / 255.0 - 0.406) / 0.225).abs() < 1e-6);
        let v = View::from_u8(&raw, 3, (1, 1), None)?;
        assert_eq!(v.data, vec![1.0, 0.0, 128.0 / 255.0]);
        Ok(())
    }

    #[test]
    fn to_image_round_trips_every_value() -> Result<()> {
        let raw: Vec<u8> = (0..=255).collect();
        for norm in [None, Some(Norm::MinusOneOne), Some(Norm::imagenet())] {
            let rgb: Vec<u8> = raw.iter().flat_map(|&v| [v, 255 - v, v / 2]).collect();
            let v = View::from_u8(&rgb, 3, (16, 16), norm.as_ref())?;
            assert_eq!(v.to_image()?.to_rgb8().into_raw(), rgb, "{norm:?}");
            let v = View::from_u8(
                &raw,
                1,
                (256, 1),
                norm.as_ref().filter(|n| **n == Norm::MinusOneOne),
            )?;
            assert_eq!(v.to_image()?.to_luma8().into_raw(), raw);
        }
        Ok(())
    }

    #[test]
    fn bad_normalisations_are_errors() {
        let bad = Norm::MeanStd {
            mean: vec![0.5, 0.5],
            std: vec![0.2, 0.2],
        };
        assert!(View::from_u8(&[1, 2, 3], 3, (1, 1), Some(&bad)).is_err());
        let zero = Norm::MeanStd {
            mean: vec![0.5],
            std: vec![0.0],
        };
        assert!(View::from_u8(&[1], 1, (1, 1), Some(&zero)).is_err());
        assert!(View::from_u8(&[1, 2], 1, (1, 1), None).is_err());
    }
}
