//! The recorded-input loop: scene starts reset the estimators, unreadable frames are skipped
//! and named, and a recording gives the same estimates through `Recorded` as through the live
//! `Pipeline` (both run `Stages`).

use geom::Pose;
use image::{DynamicImage, Rgb, RgbImage};
use nalgebra::{UnitQuaternion, Vector3};
use std::path::Path;
use track::{
    Estimation, Estimator, Event, Pipeline, PipelineConfig, Recorded, Split, Stages, TrackError,
};

/// Answers x = frames since its last reset, y = the value painted into the frame / 10.
struct Counting {
    since_reset: u32,
}

impl Estimator for Counting {
    fn name(&self) -> &'static str {
        "counting"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        _prior: Option<&Estimation>,
    ) -> track::Result<Option<Estimation>> {
        self.since_reset += 1;
        let painted = f64::from(image.to_rgb8().get_pixel(0, 0)[0]) / 10.0;
        let pose = Pose::new(
            UnitQuaternion::identity(),
            Vector3::new(f64::from(self.since_reset), painted, 1.5),
        );
        Ok(Some(Estimation::isotropic(pose, 0.2, 0.05)))
    }

    fn reset(&mut self) {
        self.since_reset = 0;
    }
}

/// A folder of `n` frames, frame `i` painted with `10 i`.
fn painted_folder(dir: &Path, n: u8) {
    for i in 0..n {
        let img = RgbImage::from_pixel(32, 24, Rgb([10 * i, 0, 0]));
        img.save(dir.join(format!("{i:03}.png"))).unwrap();
    }
}

fn xy(e: &Estimation) -> (f64, f64) {
    let [x, y, _] = e.pose.position();
    (x, y)
}

#[test]
fn listed_cuts_start_a_scene_and_every_frame_comes_out_in_order() {
    let dir = tempfile::tempdir().unwrap();
    painted_folder(dir.path(), 6);
    let stages = Stages::new(vec![Box::new(Counting { since_reset: 0 })], None, false);
    let mut seen = Vec::new();
    let summary = Recorded::new(stages)
        .with_cuts(vec![3])
        .run(
            track::frames(dir.path(), Split::All, None).unwrap(),
            |out| {
                seen.push((out.index, xy(out.processed.last().unwrap())));
                Ok::<(), TrackError>(())
            },
        )
        .unwrap();
    assert_eq!(summary.done, 6);
    assert!(summary.unreadable.is_empty());
    let expected: Vec<(usize, (f64, f64))> = (0..6)
        .map(|i| (i, ((i % 3 + 1) as f64, i as f64)))
        .collect();
    assert_eq!(seen, expected);
}

#[test]
fn an_unreadable_frame_is_skipped_and_named() {
    let dir = tempfile::tempdir().unwrap();
    painted_folder(dir.path(), 3);
    std::fs::write(dir.path().join("001.png"), b"not a png").unwrap();
    let stages = Stages::new(vec![Box::new(Counting { since_reset: 0 })], None, false);
    let mut names = Vec::new();
    let summary = Recorded::new(stages)
        .run(
            track::frames(dir.path(), Split::All, None).unwrap(),
            |out| {
                names.push(out.name);
                Ok::<(), TrackError>(())
            },
        )
        .unwrap();
    assert_eq!(summary.done, 2);
    assert_eq!(summary.unreadable.len(), 1, "{:?}", summary.unreadable);
    assert_eq!(names.len(), 2);
}

#[test]
fn a_split_needs_a_posed_dataset() {
    let dir = tempfile::tempdir().unwrap();
    painted_folder(dir.path(), 2);
    let err = track::frames(dir.path(), Split::Test, None).err().unwrap();
    assert!(err.to_string().contains("need a posed dataset"), "{err}");
}

#[test]
fn recorded_and_live_loops_give_the_same_estimates() {
    let dir = tempfile::tempdir().unwrap();
    painted_folder(dir.path(), 8);
    let stages = Stages::new(vec![Box::new(Counting { since_reset: 0 })], None, false);
    let mut recorded = Vec::new();
    Recorded::new(stages)
        .run(
            track::frames(dir.path(), Split::All, None).unwrap(),
            |out| {
                recorded.push(xy(out.processed.last().unwrap()));
                Ok::<(), TrackError>(())
            },
        )
        .unwrap();
    let source = track::source::open(dir.path().to_str().unwrap(), None, None).unwrap();
    let cfg = PipelineConfig {
        detect_cuts: false,
        ..PipelineConfig::default()
    };
    let pipeline = Pipeline::new(source, vec![Box::new(Counting { since_reset: 0 })], cfg).unwrap();
    let mut live = Vec::new();
    let end = pipeline.run(|e, _| {
        if let Event::Pose(p) = e {
            let m = &p.measurements[0];
            live.push((m.position[0], m.position[1]));
        }
    });
    assert!(matches!(end, Event::End { frames: 8, .. }), "{end:?}");
    assert_eq!(recorded, live);
}
