//! Place inference: [`PlaceLocalizer`] turns images into the most likely building, floor and
//! corridor with their probabilities, the three heads decoded together ([`super::joint`]) so
//! that the answer is one consistent place.

use std::path::Path;

use burn::module::Module;
use burn::tensor::activation::softmax;
use burn::tensor::{Device, Tensor, TensorData};
use image::DynamicImage;
use imgproc::view::{View, ViewSpec};

use super::{
    PLACE_BPK, PLACE_TOML, PlaceMeta, PlaceNet, PlaceSmoother, argmax, decode, joint,
    place_posterior,
};
use crate::checkpoint;
use crate::infer::{CHUNK, pack_views};
use crate::loader::Reframe;
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

/// Test-time reframing: the network sees each view and a few reframed copies of it
/// ([`Reframe`], the moves place training draws at random with `reframe`), and a frame's
/// probabilities at each level are the mean of its copies'. A place should not hang on how
/// the camera happened to be aimed within a few degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceTta {
    /// The copies, the view itself ([`Reframe::IDENTITY`]) among them if it should count.
    pub copies: Vec<Reframe>,
}

impl Default for PlaceTta {
    /// The view, zoomed in by 10 % and out by 10 % (the camera a step nearer and further):
    /// the reframings that helped most. On the place study's held-out walks (4800 frames,
    /// some lights off; the random-split model after two of its eight epochs), places were right in
    /// 89.4 % of frames alone, 90.1 % with these, 89.8 % with a 5 % zoom and shifts of 4 %
    /// left and right, and 89.8 % with three shifts (the view's and 4 % either way).
    fn default() -> PlaceTta {
        let zoom = |zoom| Reframe {
            zoom,
            ..Reframe::IDENTITY
        };
        PlaceTta {
            copies: vec![Reframe::IDENTITY, zoom(1.1), zoom(0.9)],
        }
    }
}

/// A loaded place model.
#[derive(Debug)]
pub struct PlaceLocalizer {
    net: PlaceNet,
    meta: PlaceMeta,
    spec: ViewSpec,
    device: Device,
    tta: Option<PlaceTta>,
}

impl PlaceLocalizer {
    /// Loads `dir/place.toml` and `dir/place.bpk` on the CPU.
    pub fn load(dir: &Path) -> Result<PlaceLocalizer> {
        let meta = PlaceMeta::read(dir)?;
        let device = Device::flex();
        let bytes = checkpoint::read_checked(dir, PLACE_BPK, &meta.weights_hash)?;
        let net = checkpoint::load_into(meta.net.init(&device, 0)?, bytes, &dir.join(PLACE_BPK))?;
        let spec = ViewSpec::resolve(&meta.view)
            .map_err(|e| LearnError::corrupt(dir.join(PLACE_TOML), e.to_string()))?;
        Ok(PlaceLocalizer {
            net: net.valid().fold_batchnorm(),
            meta,
            spec,
            device,
            tta: None,
        })
    }

    /// The same model with test-time reframing (`None`: each view as it is, the default).
    /// Every way of asking for places (one image, batches, walks, trackers) then uses it.
    pub fn with_tta(mut self, tta: Option<PlaceTta>) -> PlaceLocalizer {
        self.tta = tta.filter(|t| !t.copies.is_empty());
        self
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
        let tree = self.meta.classes.tree();
        Ok(self
            .probs(views)?
            .iter()
            .map(|p| self.named(read_heads(p, tree.as_deref())))
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
        let probs = self.probs(views)?;
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

    /// The softmax of each head for each view, averaged over the test-time copies when the
    /// model has them.
    fn probs(&self, views: &[View]) -> Result<Vec<[Vec<f32>; 3]>> {
        let inputs = pack_views(views, self.meta.input, &self.meta.view)?;
        let Some(tta) = &self.tta else {
            return head_probs(&self.net, &inputs, self.meta.input, &self.device);
        };
        let [c, h, w] = self.meta.input;
        let per = c * h * w;
        let mut copies = Vec::with_capacity(inputs.len() * tta.copies.len());
        for view in inputs.chunks_exact(per) {
            for reframe in &tta.copies {
                let start = copies.len();
                copies.extend_from_slice(view);
                reframe.apply(&mut copies[start..], c, h, w);
            }
        }
        let probs = head_probs(&self.net, &copies, self.meta.input, &self.device)?;
        let n = tta.copies.len() as f32;
        Ok(probs
            .chunks(tta.copies.len())
            .map(|group| {
                let mean = |level: usize| {
                    let mut sum = vec![0.0f32; group[0][level].len()];
                    for p in group {
                        for (s, v) in sum.iter_mut().zip(&p[level]) {
                            *s += v / n;
                        }
                    }
                    sum
                };
                [mean(0), mean(1), mean(2)]
            })
            .collect())
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
        let probs = self.loc.probs(std::slice::from_ref(view))?;
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
