//! What happens to one frame, live or recorded: the cut detector (a detected cut starts a new
//! scene), every [`Estimator`] in turn (each given the last estimate of the frame, else the
//! filter's prediction, as its prior), and the [`PoseFilter`] over their measurements.
//!
//! [`crate::Pipeline`] (live: a reader thread and a queue in front) and [`crate::Recorded`]
//! (files: frame after frame, with the place model's lag behind) both run their frames through
//! [`Stages::process`], so a frame gets the same poses whichever way it arrives.

use crate::error::{Result, TrackError};
use crate::estimator::{Estimation, Estimator, rgb_of};
use crate::filter::{FilterConfig, Fused, PoseFilter, Update};
use image::{DynamicImage, RgbImage};
use nalgebra::Matrix3;
use std::time::Instant;

/// The stages a frame goes through.
pub struct Stages<'a> {
    estimators: Vec<Box<dyn Estimator + Send + 'a>>,
    cuts: Option<CutWatch>,
    filter: Option<PoseFilter>,
}

/// What the stages made of one frame.
#[derive(Clone, Debug)]
pub struct Processed {
    /// Whether the cut detector decided a cut at this frame.
    pub cut: bool,
    /// Every estimator's output that it gave, in order (those handed on with a note included).
    pub estimates: Vec<(&'static str, Estimation)>,
    /// The filter's state after the frame and what it did (`started`, `fused`, `rejected`, or
    /// `coasted` when no estimator measured anything); `None` without a filter, or when the
    /// filter has no state yet.
    pub fused: Option<(Fused, &'static str)>,
    /// Measurements the filter refused (outside its gate).
    pub rejected: u64,
    /// Seconds in the cut detector and the estimators.
    pub estimate_s: f64,
    /// Seconds in the filter.
    pub filter_s: f64,
}

impl Processed {
    /// The estimates the filter took (a pass-through with a note is not one).
    pub fn measurements(&self) -> impl Iterator<Item = &(&'static str, Estimation)> {
        self.estimates.iter().filter(|(_, e)| e.measured)
    }

    /// The last estimate of the frame (the most refined: a map's after the network's).
    pub fn last(&self) -> Option<&Estimation> {
        self.estimates.last().map(|(_, e)| e)
    }
}

impl<'a> Stages<'a> {
    /// `estimators` in order; `filter` fuses their measurements (none: estimates only);
    /// `detect_cuts` runs the cut detector on thumbnails of the frames.
    pub fn new(
        estimators: Vec<Box<dyn Estimator + Send + 'a>>,
        filter: Option<FilterConfig>,
        detect_cuts: bool,
    ) -> Stages<'a> {
        Stages {
            estimators,
            cuts: detect_cuts.then(CutWatch::default),
            filter: filter.map(PoseFilter::new),
        }
    }

    /// Runs frame `index` (seen at `t` seconds) through the stages. `new_scene`: the source
    /// knows the frame starts a new scene (a new recording, a gap, a listed cut); a cut the
    /// detector decides does the same. A new scene resets the estimators' history and the
    /// filter.
    pub fn process(
        &mut self,
        index: u64,
        image: &DynamicImage,
        t: f64,
        new_scene: bool,
    ) -> Result<Processed> {
        let started = Instant::now();
        let cut = match &mut self.cuts {
            Some(c) => c.push(index, image)?,
            None => false,
        };
        if cut || new_scene {
            for e in &mut self.estimators {
                e.reset();
            }
        }
        // What an estimator may start from: the last estimate of this frame, else where the
        // filter expects the camera (none at a new scene).
        let predicted = match &self.filter {
            Some(f) if !cut && !new_scene => f.predict(t).map(|f| {
                Estimation::plain(
                    f.pose,
                    Matrix3::from_diagonal(&f.pos_var.into()),
                    f.sigma_rot_rad,
                )
            }),
            _ => None,
        };
        let mut estimates: Vec<(&'static str, Estimation)> =
            Vec::with_capacity(self.estimators.len());
        for e in &mut self.estimators {
            let prior = estimates.last().map(|(_, p)| p).or(predicted.as_ref());
            if let Some(est) = e.estimate(image, prior)? {
                estimates.push((e.name(), est));
            }
        }
        let estimated = Instant::now();
        let mut fused = None;
        let mut rejected = 0;
        if let Some(filter) = &mut self.filter {
            if cut || new_scene {
                filter.reset();
            }
            let mut last: Option<Fused> = None;
            for (_, est) in estimates.iter().filter(|(_, e)| e.measured) {
                let f = filter.push(&est.at(t));
                rejected += u64::from(f.update == Update::Rejected);
                last = Some(f);
            }
            fused = match last {
                Some(f) => Some((f, update_name(f.update))),
                None => filter.predict(t).map(|f| (f, "coasted")),
            };
        }
        let done = Instant::now();
        Ok(Processed {
            cut,
            estimates,
            fused,
            rejected,
            estimate_s: (estimated - started).as_secs_f64(),
            filter_s: (done - estimated).as_secs_f64(),
        })
    }
}

fn update_name(u: Update) -> &'static str {
    match u {
        Update::Started => "started",
        Update::Fused => "fused",
        Update::Rejected => "rejected",
    }
}

/// The streaming cut detector on thumbnails of the frames.
#[derive(Default)]
struct CutWatch {
    detector: Option<scenecut::Detector>,
    thumb: RgbImage,
}

impl CutWatch {
    /// Feeds a frame; whether a cut was decided now. The detector decides a few frames after
    /// the cut itself (its window), so the filter starts over a little late; gating covers the
    /// frames in between.
    fn push(&mut self, index: u64, image: &DynamicImage) -> Result<bool> {
        let (w, h) = (image.width(), image.height());
        if self.detector.is_none() {
            let cfg = scenecut::Config::default();
            let (tw, th) = cfg.thumb_size(w, h);
            self.thumb = RgbImage::new(tw, th);
            self.detector = Some(scenecut::Detector::new(cfg, tw, th)?);
        }
        let Some(det) = &mut self.detector else {
            return Ok(false);
        };
        let rgb = rgb_of(image);
        imgproc::view::resize_rgb(&rgb, &mut self.thumb)
            .map_err(|e| TrackError::Config(format!("cut thumbnail of frame {index}: {e}")))?;
        let events = det.push(index, self.thumb.as_raw())?;
        Ok(events.iter().any(|e| matches!(e, scenecut::Event::Cut(_))))
    }
}
