//! Place inference: [`PlaceLocalizer`] turns images into the most likely building, floor and
//! corridor with their probabilities, the three heads decoded together ([`super::joint`]) so
//! that the answer is one consistent place.

use std::path::Path;

use burn::module::Module;
use burn::tensor::activation::softmax;
use burn::tensor::{Device, Tensor, TensorData};
use image::DynamicImage;
use imgproc::view::{View, ViewSpec};

use super::classes::{argmax, decode, joint, place_posterior};
use super::meta::{PLACE_BPK, PLACE_TOML, PlaceMeta};
use super::net::PlaceNet;
use super::walk::PlaceSmoother;
use crate::checkpoint;
use crate::infer::{CHUNK, pack_views};
use crate::{LearnError, Result};

/// The most likely class of each level of one image, with its probability.
#[derive(Clone, Debug, PartialEq)]
pub struct PlacePrediction {
    /// Building name and probability.
    pub building: (String, f64),
    /// Floor (`building/floor`) and probability.
    pub floor: (String, f64),
    /// Place (`building/floor/corridor/direction`) and probability.
    pub corridor: (String, f64),
    /// Class indices per level (into the model's class lists).
    pub indices: [usize; 3],
}

impl PlacePrediction {
    /// Building, floor, corridor and direction names of the predicted place.
    pub fn parts(&self) -> [String; 4] {
        let mut parts = self.corridor.0.rsplitn(3, '/');
        let direction = parts.next().unwrap_or_default().to_string();
        let corridor = parts.next().unwrap_or_default().to_string();
        let floor = self
            .floor
            .0
            .strip_prefix(&format!("{}/", self.building.0))
            .unwrap_or(&self.floor.0)
            .to_string();
        [self.building.0.clone(), floor, corridor, direction]
    }
}

/// A loaded place model.
#[derive(Debug)]
pub struct PlaceLocalizer {
    net: PlaceNet,
    meta: PlaceMeta,
    spec: ViewSpec,
    device: Device,
}

impl PlaceLocalizer {
    /// Loads `dir/place.toml` and `dir/place.bpk` on the process's device (the CPU by default).
    pub fn load(dir: &Path) -> Result<PlaceLocalizer> {
        let meta = PlaceMeta::read(dir)?;
        let device = crate::device::inference();
        let bytes = checkpoint::read_checked(dir, PLACE_BPK, &meta.weights_hash)?;
        let net = checkpoint::load_into(meta.net.init(&device, 0)?, bytes, &dir.join(PLACE_BPK))?;
        let spec = ViewSpec::resolve(&meta.view)
            .map_err(|e| LearnError::corrupt(dir.join(PLACE_TOML), e.to_string()))?;
        Ok(PlaceLocalizer {
            net: net.valid().fold_batchnorm(),
            meta,
            spec,
            device,
        })
    }

    /// The checkpoint's description.
    pub fn meta(&self) -> &PlaceMeta {
        &self.meta
    }

    /// The network's view of an image.
    pub fn view(&self, img: &DynamicImage) -> Result<View> {
        self.spec
            .apply(img, 0)
            .map_err(|e| LearnError::Input(e.to_string()))
    }

    /// The place of one image.
    pub fn predict(&self, img: &DynamicImage) -> Result<PlacePrediction> {
        self.predict_batch(std::slice::from_ref(&self.view(img)?))?
            .pop()
            .ok_or_else(|| LearnError::Input("no prediction for the image".into()))
    }

    /// Places of many views made with this model's view, each frame alone.
    pub fn predict_batch(&self, views: &[View]) -> Result<Vec<PlacePrediction>> {
        let inputs = pack_views(views, self.meta.input, &self.meta.view)?;
        let tree = self.meta.classes.tree();
        Ok(classify(
            &self.net,
            &inputs,
            self.meta.input,
            tree.as_deref(),
            &self.device,
        )?
        .into_iter()
        .map(|p| self.named(p))
        .collect())
    }

    /// A tracker that places the frames of one walk at a time, each given the frames before it
    /// and those of the `lag_s` seconds after it (0: answered at once, as live; see
    /// [`PlaceSmoother`]).
    pub fn tracker(&self, lag_s: f64) -> PlaceTracker<'_> {
        let tree = self.meta.classes.tree();
        // PlaceMeta::read checked that the motion model has a row and column per place.
        let smoother = match (&tree, &self.meta.transitions) {
            (Some(_), Some(t)) => Some(PlaceSmoother::new(t, lag_s)),
            _ => None,
        };
        PlaceTracker {
            loc: self,
            tree,
            smoother,
        }
    }

    /// Places of the frames of recorded walks, in time order, as a [`PlaceTracker`] with
    /// `lag_s` seconds of lag would tell them (in batches for speed): `frames` gives each
    /// view's time in seconds and whether it starts a new walk.
    pub fn predict_walks(
        &self,
        views: &[View],
        frames: &[WalkFrame],
        lag_s: f64,
    ) -> Result<Vec<PlacePrediction>> {
        if views.len() != frames.len() {
            return Err(LearnError::Input(format!(
                "{} views but {} frame times",
                views.len(),
                frames.len()
            )));
        }
        let inputs = pack_views(views, self.meta.input, &self.meta.view)?;
        let probs = head_probs(&self.net, &inputs, self.meta.input, &self.device)?;
        let mut tracker = self.tracker(lag_s);
        let mut out = Vec::with_capacity(views.len());
        for (p, frame) in probs.iter().zip(frames) {
            if frame.starts_walk {
                out.extend(tracker.finish());
            }
            out.extend(tracker.take(p, frame.t));
        }
        out.extend(tracker.finish());
        Ok(out)
    }

    /// A prediction with names from class indices and probabilities.
    fn named(&self, p: [(usize, f32); 3]) -> PlacePrediction {
        let levels = self.meta.classes.levels();
        let named = |level: usize| {
            let (k, prob) = p[level];
            let name = levels[level].get(k).cloned().unwrap_or_default();
            (name, prob as f64)
        };
        PlacePrediction {
            building: named(0),
            floor: named(1),
            corridor: named(2),
            indices: p.map(|(k, _)| k),
        }
    }
}

/// When a frame of a walk was seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkFrame {
    /// Time, seconds (`None`: one training frame interval after the last).
    pub t: Option<f64>,
    /// The frame starts a new walk (a new sequence, a scene cut, a gap): what came before
    /// says nothing about it.
    pub starts_walk: bool,
}

/// A place model following one walk (see [`PlaceSmoother`]): each frame's place given the
/// frames since the walk began and those of the tracker's lag after it. Places come back in
/// frame order, each once, up to the lag late: [`PlaceTracker::step`] gives those now told,
/// [`PlaceTracker::finish`] the rest of the walk. A model trained before place filtering (no
/// motion model in `place.toml`), or with class lists that do not nest, places each frame alone
/// and at once.
#[derive(Debug)]
pub struct PlaceTracker<'a> {
    loc: &'a PlaceLocalizer,
    tree: Option<Vec<[usize; 2]>>,
    smoother: Option<PlaceSmoother>,
}

impl PlaceTracker<'_> {
    /// Whether frames are placed given the ones around them (the model has a motion model).
    pub fn filters(&self) -> bool {
        self.smoother.is_some()
    }

    /// Ends the walk: the places of its frames not yet told, in order. The next frame starts a
    /// new walk.
    pub fn finish(&mut self) -> Vec<PlacePrediction> {
        let (Some(tree), Some(smoother)) = (&self.tree, &mut self.smoother) else {
            return Vec::new();
        };
        let told = smoother.finish();
        told.iter()
            .map(|belief| self.loc.named(decode(belief, tree)))
            .collect()
    }

    /// Takes in the next frame of the walk, `view` (made with the model's view) seen at time
    /// `t` seconds, and returns the places now told: this frame's and earlier ones' whose lag
    /// has run out, oldest first.
    pub fn step(&mut self, view: &View, t: Option<f64>) -> Result<Vec<PlacePrediction>> {
        let meta = &self.loc.meta;
        let inputs = pack_views(std::slice::from_ref(view), meta.input, &meta.view)?;
        let probs = head_probs(&self.loc.net, &inputs, meta.input, &self.loc.device)?;
        let p = probs
            .first()
            .ok_or_else(|| LearnError::Input("no prediction for the image".into()))?;
        Ok(self.take(p, t))
    }

    /// Takes in one frame's head probabilities.
    fn take(&mut self, probs: &[Vec<f32>; 3], t: Option<f64>) -> Vec<PlacePrediction> {
        match (&self.tree, &mut self.smoother) {
            (Some(tree), Some(smoother)) => {
                let rows = [&probs[0][..], &probs[1][..], &probs[2][..]];
                smoother
                    .push(&place_posterior(rows, tree), t)
                    .iter()
                    .map(|belief| self.loc.named(decode(belief, tree)))
                    .collect()
            }
            (tree, _) => vec![self.loc.named(read_heads(probs, tree.as_deref()))],
        }
    }
}

/// The place of each packed input `[N, C, H, W]` (run in chunks of [`CHUNK`]): the class and its
/// probability at each level, decoded jointly by [`joint`] when `tree` is given, each head on
/// its own otherwise.
pub(super) fn classify(
    net: &PlaceNet,
    inputs: &[f32],
    input: [usize; 3],
    tree: Option<&[[usize; 2]]>,
    device: &Device,
) -> Result<Vec<[(usize, f32); 3]>> {
    Ok(head_probs(net, inputs, input, device)?
        .iter()
        .map(|p| read_heads(p, tree))
        .collect())
}

/// One frame's class and probability at each level from its heads' softmax: decoded jointly
/// by [`joint`] when `tree` is given, each head on its own otherwise.
fn read_heads(probs: &[Vec<f32>; 3], tree: Option<&[[usize; 2]]>) -> [(usize, f32); 3] {
    let rows = [&probs[0][..], &probs[1][..], &probs[2][..]];
    match tree {
        Some(tree) => joint(rows, tree),
        None => rows.map(argmax),
    }
}

/// The softmax of each head for each packed input `[N, C, H, W]`, run in chunks of [`CHUNK`].
fn head_probs(
    net: &PlaceNet,
    inputs: &[f32],
    [c, h, w]: [usize; 3],
    device: &Device,
) -> Result<Vec<[Vec<f32>; 3]>> {
    let per = c * h * w;
    let n = inputs.len() / per.max(1);
    let mut out = Vec::with_capacity(n);
    for start in (0..n).step_by(CHUNK) {
        let b = CHUNK.min(n - start);
        let x = Tensor::<4>::from_data(
            TensorData::new(
                inputs[start * per..(start + b) * per].to_vec(),
                [b, c, h, w],
            ),
            device,
        );
        let mut probs: Vec<(Vec<f32>, usize)> = Vec::with_capacity(3);
        for logits in net.logits(net.features(x)) {
            let [_, k] = logits.dims();
            let p = softmax(logits, 1)
                .into_data()
                .try_to_vec::<f32>()
                .map_err(|e| LearnError::Input(format!("cannot read the outputs: {e:?}")))?;
            probs.push((p, k));
        }
        for row in 0..b {
            let level = |l: usize| {
                let (p, k) = &probs[l];
                p[row * k..(row + 1) * k].to_vec()
            };
            out.push([level(0), level(1), level(2)]);
        }
    }
    Ok(out)
}
