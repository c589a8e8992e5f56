//! Cuts in rendered walks through the default building: walks joined by hard cuts to other
//! places, with the gold cuts the renderer writes (`cuts.csv`), under two appearance variants
//! (lit, and people walking through the view, whose occlusions must not count as cuts).

use scenecut::{Collect, Config, Gold, detect_input, score_hard};
use synth::Variant;
use synth::dataset::{Sampler, SynthConfig};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn rendered_cuts(variant: Variant, seed: u64) -> TestResult {
    let dir = tempfile::tempdir()?;
    let cfg = SynthConfig {
        sampler: Sampler::WalkWithCuts,
        frames: 360,
        sequences: 2,
        width: 160,
        height: 120,
        variant,
        seed,
        depth: false,
        planes: false,
        ..SynthConfig::default()
    };
    synth::dataset::run(&cfg, dir.path(), &|_| {})?;
    let gold = Gold::read(&dir.path().join("cuts.csv"), dir.path())?;
    assert!(gold.hard_cuts.len() >= 5, "{:?}", gold.hard_cuts);
    let det = detect_input(
        dir.path(),
        &Config::default(),
        Collect::default(),
        &mut |_, _| {},
    )?;
    assert_eq!(det.frames, 360);
    let score = score_hard(&det.cut_frames(), &gold, 2);
    println!(
        "{variant:?} seed {seed}: gold {:?} found {:?} P {:.2} R {:.2} F1 {:.2}",
        gold.hard_cuts,
        det.cut_frames(),
        score.precision,
        score.recall,
        score.f1
    );
    assert!(score.recall >= 0.99 && score.precision >= 0.99, "{score:?}");
    Ok(())
}

#[test]
fn every_cut_in_a_rendered_walk() -> TestResult {
    rendered_cuts(Variant::Normal, 3)
}

#[test]
fn people_in_view_are_not_cuts() -> TestResult {
    rendered_cuts(Variant::People, 5)
}
