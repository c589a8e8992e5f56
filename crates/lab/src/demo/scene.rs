//! The demo's dataset: walks through one storey of the built-in building, rendered under
//! several appearance variants for training, one more walk for validation and a held-out walk
//! for the test, all written as one native dataset whose `splits.toml` names the three parts.
//!
//! Walks stay on one storey (a zone) so that a few minutes of rendering and training cover the
//! places the test walk passes; the layout is the same under every variant, only the
//! appearance changes, which is what the network has to learn to ignore.

use crate::{Context, Result};
use data::native::{self, DatasetInfo, Generator, Splits};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use synth::dataset::{CameraKind, Export, ExportOptions, Shot, SynthConfig, WorldSource};
use synth::render::RenderMode;
use synth::trajectory::{self, PosedFrame, Rig, WalkConfig};
use synth::variants::Crowd;
use synth::{PlaceKind, Variant, World};

/// What the demo renders. Stored beside the dataset (`demo-plan.toml`) so a second run with the
/// same plan reuses the images instead of rendering them again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScenePlan {
    /// Layout seed of the building and seed of the walks.
    pub seed: u64,
    /// `forward` (6-DoF) or `ceiling` (3-DoF).
    pub camera: String,
    /// Building index of the zone.
    pub building: u8,
    /// Storey index of the zone.
    pub storey: u8,
    /// `corridor`: the storey's corridors only; `storey`: the whole storey, rooms and lobby too.
    pub zone: String,
    /// Rendered image width, pixels.
    pub width: u32,
    /// Rendered image height, pixels.
    pub height: u32,
    /// Appearance variants of the training walks (names as `synth --variant` takes them).
    pub train_variants: Vec<String>,
    /// Training walks per variant.
    pub walks_per_variant: usize,
    /// Frames per training walk.
    pub frames_per_walk: usize,
    /// Frame rate of the training walks when not the rig's (the validation and test walks
    /// always run at the rig's): fewer frames a second spread the same frames over more ground.
    /// Left out of the plan file when the rig's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub train_fps: Option<f64>,
    /// Added to the seeds of the training walks: other routes through the same zone (the
    /// sequence model's training walks, [`ScenePlan::for_sequence_model`]). Left out of the
    /// plan file when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub walk_offset: u64,
    /// Frames of the validation walk (normal appearance).
    pub val_frames: usize,
    /// Frames of the held-out test walk (none rendered for 0).
    pub test_frames: usize,
    /// Render mode of the training and validation walks (`synth --mode` names); the test walk
    /// is always `textured`, photo-like. Left out of the plan file when `textured`.
    #[serde(default = "textured", skip_serializing_if = "is_textured")]
    pub train_mode: String,
    /// Appearance variant of the test walk. Left out of the plan file when `normal`.
    #[serde(default = "normal", skip_serializing_if = "is_normal")]
    pub test_variant: String,
    /// Render the training walks with randomised materials (shape-biased training's domain
    /// randomisation), a new draw every [`MATERIAL_CHUNK`] frames.
    #[serde(default, skip_serializing_if = "is_false")]
    pub random_materials: bool,
    /// With `random_materials`, also randomise the lighting of each draw: some circuits off,
    /// the others, ambient and daylight at random levels (`synth::variants::randomize_lighting`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub random_lighting: bool,
    /// Also write every frame's depth and dominant-plane ids (`depth/`, `planes/`), which the
    /// plane task trains on.
    #[serde(default, skip_serializing_if = "is_false")]
    pub depth: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// [`ScenePlan::walk_offset`] of the sequence model's training walks: past every walk seed a
/// plan uses itself (training walks below 900, validation 900, test 901, cut walks 902).
pub const SEQUENCE_WALK_OFFSET: u64 = 1000;

/// [`ScenePlan::walk_offset`] of the map's survey walks.
pub const MAP_WALK_OFFSET: u64 = 2000;
/// Image size of the map and of the refinement's queries: local features need the detail.
pub const MAP_WIDTH: u32 = 640;
/// See [`MAP_WIDTH`].
pub const MAP_HEIGHT: u32 = 480;
/// Survey walks of the map.
pub const MAP_WALKS: usize = 2;
/// Frames of the survey walks together, by default.
pub const MAP_SURVEY_FRAMES: usize = 800;
/// Frame rate of the survey walks: a frame about every 0.6 m of walking.
pub const MAP_FPS: f64 = 2.0;
/// Frames of the map dataset's validation walk (mapped too).
pub const MAP_VAL_FRAMES: usize = 20;

/// Walks of the sequence model's training data per walk of the network's.
pub const SEQUENCE_WALKS_PER_WALK: usize = 3;

/// Frames of a training walk rendered with one draw of randomised materials.
pub const MATERIAL_CHUNK: usize = 100;

fn textured() -> String {
    RenderMode::Textured.to_string()
}

fn is_textured(mode: &str) -> bool {
    mode == RenderMode::Textured.name()
}

fn normal() -> String {
    Variant::Normal.name().to_string()
}

fn is_normal(variant: &str) -> bool {
    variant == Variant::Normal.name()
}

/// Name of the plan file in the dataset folder.
pub const PLAN_TOML: &str = "demo-plan.toml";
/// The test sequence's name.
pub const TEST_SEQ: &str = "test";

impl ScenePlan {
    fn camera_kind(&self) -> CameraKind {
        if self.camera == "ceiling" {
            CameraKind::Ceiling
        } else {
            CameraKind::Forward
        }
    }

    /// The render mode of the training walks.
    pub fn train_mode(&self) -> Result<RenderMode> {
        self.train_mode
            .parse::<RenderMode>()
            .map_err(|e| crate::err!("render mode '{}': {e}", self.train_mode))
    }

    fn test_variant(&self) -> Result<Variant> {
        self.test_variant
            .parse::<Variant>()
            .map_err(|e| crate::err!("variant '{}': {e}", self.test_variant))
    }

    fn variants(&self) -> Result<Vec<Variant>> {
        self.train_variants
            .iter()
            .map(|v| {
                v.parse::<Variant>()
                    .map_err(|e| crate::err!("variant '{v}': {e}"))
            })
            .collect()
    }

    /// The sequence model's training data beside this plan's: the same building, camera,
    /// appearance variants, training frames and validation walk, but training walks at the
    /// rig's own frame rate, along routes the single-frame network never saw, three times as
    /// many and a third as long, and no test walk.
    ///
    /// A sequence model learns the motion between consecutive frames, so it must train on
    /// walks at the rate it runs at; the forward camera's network trains on 1 Hz walks
    /// (`train_fps`), and the first LSTM trained on them gave 0.84 m on the 10 Hz test walk
    /// (0.61 m trained on 10 Hz walks; the network alone 0.52 m). Frames the network never trained on also give the LSTM features as noisy as the
    /// test walk's, and more routes give it more ways through the zone: on the quick demo's
    /// held-out walk, windows of 20 frames, seeds 0, 1, 2 of the LSTM, 0.36, 0.46 and 0.40 m
    /// against the network's 0.52 m (`study sequence --quick`); windows of 10 gave 0.40 and
    /// 0.57 m (seeds 0, 1), and 0.63 m with only as many walks as the network's.
    /// `window`: the frames of a training window, which every walk must hold (walks are cut
    /// into fewer than three where they would be shorter).
    pub fn for_sequence_model(&self, window: usize) -> ScenePlan {
        let split = SEQUENCE_WALKS_PER_WALK
            .min(self.frames_per_walk / window.max(1))
            .max(1);
        ScenePlan {
            train_fps: None,
            walks_per_variant: self.walks_per_variant * split,
            frames_per_walk: self.frames_per_walk.div_ceil(split),
            walk_offset: SEQUENCE_WALK_OFFSET,
            test_frames: 0,
            ..self.clone()
        }
    }

    /// The survey the demo's keyframe map is built from, and the test walk again at the
    /// map's resolution: walks of their own through the same zone under normal light at
    /// [`MAP_FPS`], 640x480 with depth, and the held-out test walk (the same poses) at
    /// 640x480 for the refinement's queries. The network keeps its 160x120 frames.
    /// `survey_frames`: frames of the survey walks together.
    pub fn for_map(&self, survey_frames: usize) -> ScenePlan {
        ScenePlan {
            width: MAP_WIDTH,
            height: MAP_HEIGHT,
            train_variants: vec![normal()],
            walks_per_variant: MAP_WALKS,
            frames_per_walk: survey_frames.div_ceil(MAP_WALKS).max(1),
            train_fps: Some(MAP_FPS),
            walk_offset: MAP_WALK_OFFSET,
            val_frames: MAP_VAL_FRAMES,
            train_mode: textured(),
            random_materials: false,
            random_lighting: false,
            depth: true,
            ..self.clone()
        }
    }

    /// Frames the dataset will hold.
    pub fn total_frames(&self) -> usize {
        self.train_variants.len() * self.walks_per_variant * self.frames_per_walk
            + self.val_frames
            + self.test_frames
    }
}

/// One sequence to render.
struct Sequence {
    name: String,
    variant: Variant,
    frames: Vec<PosedFrame>,
    /// Seed of the randomised materials of the sequence's first chunk of frames (the next
    /// chunks count on from it), `None` for the building's own.
    materials: Option<u64>,
}

impl Sequence {
    fn new(name: String, variant: Variant, frames: Vec<PosedFrame>) -> Sequence {
        Sequence {
            name,
            variant,
            frames,
            materials: None,
        }
    }

    /// The materials seed of frame `k`, if randomised.
    fn materials_of(&self, k: usize) -> Option<u64> {
        self.materials
            .map(|seed| seed.wrapping_add((k / MATERIAL_CHUNK) as u64))
    }
}

/// The building of the plan under `variant`, with the variant's changes applied.
pub fn world(plan: &ScenePlan, variant: Variant) -> Result<World> {
    let cfg = SynthConfig {
        world: WorldSource::Default { seed: plan.seed },
        variant,
        seed: plan.seed,
        ..SynthConfig::default()
    };
    Ok(synth::dataset::build_world(&cfg)?.0)
}

/// The zone as its own world for walking: the building with the walk graph cut to the zone.
fn zone_world(plan: &ScenePlan) -> Result<World> {
    let mut world = world(plan, Variant::Normal)?;
    let walk = world.walk.within(&world.regions, |p| {
        p.building == plan.building
            && p.storey == plan.storey
            && (plan.zone == "storey" || p.kind == PlaceKind::Corridor)
    });
    crate::ensure!(
        !walk.edges.is_empty(),
        "the default building has no walkable {} on storey {} of building {}",
        plan.zone,
        plan.storey,
        plan.building
    );
    world.walk = walk;
    Ok(world)
}

fn rig(plan: &ScenePlan) -> Rig {
    synth::dataset::rig_of(plan.camera_kind())
}

/// Walks of every sequence: training walks (per variant), the validation walk, the test walk.
fn sequences(plan: &ScenePlan) -> Result<Vec<Sequence>> {
    let zone = zone_world(plan)?;
    let cfg = WalkConfig::for_rig(rig(plan));
    let train_cfg = WalkConfig {
        fps: plan.train_fps.unwrap_or(cfg.fps),
        ..cfg.clone()
    };
    let walk_at = |cfg: &WalkConfig, frames: usize, k: u64| {
        trajectory::walk(&zone, cfg, frames, plan.seed * 1000 + k)
    };
    let walk = |frames: usize, k: u64| walk_at(&cfg, frames, k);
    let mut seqs = Vec::new();
    for (v, variant) in plan.variants()?.into_iter().enumerate() {
        for w in 0..plan.walks_per_variant {
            let k = plan.walk_offset + (v * 100 + w) as u64;
            let mut seq = Sequence::new(
                format!("train-{}-{w}", variant.name()),
                variant,
                walk_at(&train_cfg, plan.frames_per_walk, k)?,
            );
            seq.materials = plan.random_materials.then(|| (plan.seed * 1000 + k) << 16);
            seqs.push(seq);
        }
    }
    seqs.push(Sequence::new(
        "val".into(),
        Variant::Normal,
        walk(plan.val_frames, 900)?,
    ));
    if plan.test_frames > 0 {
        seqs.push(Sequence::new(
            TEST_SEQ.into(),
            plan.test_variant()?,
            walk(plan.test_frames, 901)?,
        ));
    }
    Ok(seqs)
}

/// The rooms and corridors of the plan's storey seen from above, `[x0, y0, x1, y1]` each.
pub fn floor_plan(plan: &ScenePlan) -> Result<Vec<[f64; 4]>> {
    let world = world(plan, Variant::Normal)?;
    Ok(world
        .regions
        .iter()
        .filter(|g| g.place.building == plan.building && g.place.storey == plan.storey)
        .map(|g| [g.min[0], g.min[1], g.max[0], g.max[1]].map(f64::from))
        .collect())
}

/// The camera of every sequence: one phone (or one robot camera) for the whole demo.
pub fn camera(plan: &ScenePlan) -> Result<geom::Camera> {
    Ok(trajectory::camera_for(
        &rig(plan),
        plan.width,
        plan.height,
        plan.seed,
    )?)
}

/// Renders the dataset of `plan` into `dir` unless `dir` already holds it (same plan file);
/// `progress` gets the frames done so far. Returns true when it rendered.
pub fn render(plan: &ScenePlan, dir: &Path, progress: &(dyn Fn(usize) + Sync)) -> Result<bool> {
    let plan_path = dir.join(PLAN_TOML);
    let plan_text = toml::to_string(plan).context("cannot write the demo plan")?;
    let done = std::fs::read_to_string(&plan_path).is_ok_and(|t| t == plan_text)
        && dir.join(native::POSES_CSV).is_file();
    if done {
        return Ok(false);
    }
    let seqs = sequences(plan)?;
    write_dataset(plan, dir, &seqs, None, progress)?;
    data::io::write_atomic(&plan_path, |w| w.write_all(plan_text.as_bytes()))
        .with_context(|| format!("cannot write {}", plan_path.display()))?;
    Ok(true)
}

/// (variant, materials seed) -> the frames rendered from that world, each with the number of
/// its sequence (which says who of the crowd it leaves out).
type Groups<'a> = BTreeMap<(Variant, Option<u64>), Vec<(usize, Shot<'a>)>>;

/// Renders every frame of `seqs` into `dir` as one native dataset (`frames/`, and `depth/` and
/// `planes/` when the plan asks), numbered in order, and writes its metadata with the gold
/// `cuts`. Frames are grouped by what they are rendered from: the building under the
/// sequence's variant, with one draw of randomised materials per chunk of a training walk, and
/// the people of the `people` variant walking the zone.
fn write_dataset(
    plan: &ScenePlan,
    dir: &Path,
    seqs: &[Sequence],
    cuts: Option<&[u64]>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<()> {
    let camera = camera(plan)?;
    let options = ExportOptions {
        seed: plan.seed,
        depth: plan.depth,
        planes: plan.depth,
        resume: false,
    };
    let export = Export::new(dir, &camera, options, progress)?;
    let train_mode = plan.train_mode()?;
    // The dataset's frames in order, and the same frames by the world they are rendered from.
    let mut shots = Vec::new();
    let mut groups = Groups::new();
    for (s, seq) in seqs.iter().enumerate() {
        let mode = if seq.name.starts_with(TEST_SEQ) {
            RenderMode::Textured
        } else {
            train_mode
        };
        for (k, frame) in seq.frames.iter().enumerate() {
            let shot = Shot {
                index: shots.len() as u64,
                seq: &seq.name,
                frame,
                mode,
                left_out: &[],
            };
            groups
                .entry((seq.variant, seq.materials_of(k)))
                .or_default()
                .push((s, shot));
            shots.push(shot);
        }
    }
    let mut worlds: BTreeMap<Variant, World> = BTreeMap::new();
    for ((variant, materials), group) in groups {
        let mut world = match worlds.entry(variant) {
            std::collections::btree_map::Entry::Occupied(e) => e.get().clone(),
            std::collections::btree_map::Entry::Vacant(e) => {
                e.insert(world(plan, variant)?).clone()
            }
        };
        if let Some(seed) = materials {
            synth::variants::randomize_materials(&mut world, seed);
            if plan.random_lighting {
                synth::variants::randomize_lighting(&mut world, seed);
            }
        }
        let people = (variant == Variant::People)
            .then(|| people(plan, &mut world, seqs))
            .transpose()?;
        let group: Vec<Shot> = group
            .into_iter()
            .map(|(s, shot)| Shot {
                left_out: people.as_ref().map_or(&[], |p| &p.left_out[s]),
                ..shot
            })
            .collect();
        export.render(&world, people.as_ref().map(|p| &p.crowd), &group)?;
    }
    let names = |prefix: &str| -> Vec<String> {
        seqs.iter()
            .filter(|s| s.name.starts_with(prefix))
            .map(|s| s.name.clone())
            .collect()
    };
    let splits = Splits {
        train: names("train-"),
        val: names("val"),
        test: names(TEST_SEQ),
    };
    let info = dataset_info(plan, &camera);
    synth::dataset::write_metadata(dir, &info, &shots, false, cuts, &splits)?;
    Ok(())
}

/// A crowd walking the plan's zone, and for each sequence the people left out of it because
/// they would come too close to its camera (for the whole sequence, so nobody pops in or out).
struct People {
    crowd: Crowd,
    left_out: Vec<Vec<bool>>,
}

fn people(plan: &ScenePlan, world: &mut World, seqs: &[Sequence]) -> Result<People> {
    world.walk = zone_world(plan)?.walk;
    let count = Crowd::suggested_count(world).max(6);
    let crowd = Crowd::new(world, count, plan.seed);
    let left_out = seqs
        .iter()
        .map(|s| {
            let cameras: Vec<_> = s
                .frames
                .iter()
                .map(|f| (f.t, nalgebra::Point3::from(f.pose.position())))
                .collect();
            crowd.too_close(world, &cameras, synth::dataset::PERSON_CLEARANCE_M)
        })
        .collect();
    Ok(People { crowd, left_out })
}

/// The same held-out test walk under each of `variants` (sequences `test-<variant>`, all in
/// the test split), rendered photo-like into `dir` as one native dataset unless `dir` already
/// holds it: the appearance changes, nothing else does.
pub fn render_variant_walks(
    plan: &ScenePlan,
    dir: &Path,
    variants: &[Variant],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<()> {
    // The walks are rendered plainly whichever model asks, so the key leaves out what the
    // training walks alone use.
    let plain = ScenePlan {
        depth: false,
        random_materials: false,
        random_lighting: false,
        ..plan.clone()
    };
    let names: Vec<&str> = variants.iter().map(|v| v.name()).collect();
    let key = format!("{}variant_walks = {names:?}\n", toml::to_string(&plain)?);
    let plan_path = dir.join(PLAN_TOML);
    if std::fs::read_to_string(&plan_path).is_ok_and(|t| t == key)
        && dir.join(native::POSES_CSV).is_file()
    {
        return Ok(());
    }
    let zone = zone_world(plan)?;
    let cfg = WalkConfig::for_rig(rig(plan));
    let frames = trajectory::walk(&zone, &cfg, plan.test_frames, plan.seed * 1000 + 901)?;
    let seqs: Vec<Sequence> = variants
        .iter()
        .map(|&v| Sequence::new(format!("{TEST_SEQ}-{}", v.name()), v, frames.clone()))
        .collect();
    write_dataset(&plain, dir, &seqs, None, progress)?;
    data::io::write_atomic(&plan_path, |w| w.write_all(key.as_bytes()))
        .with_context(|| format!("cannot write {}", plan_path.display()))?;
    Ok(())
}

/// Walks through the plan's zone joined by hard cuts to other places (`segments` walks of
/// `frames_per_segment` frames, normal appearance), rendered like the test walk into `dir` as a
/// native dataset with one test sequence and its gold `cuts.csv`, unless `dir` already holds
/// it. Returns the gold cuts.
pub fn render_cut_walk(
    plan: &ScenePlan,
    dir: &Path,
    segments: usize,
    frames_per_segment: [usize; 2],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<u64>> {
    let zone = zone_world(plan)?;
    let cfg = WalkConfig::for_rig(rig(plan));
    let (frames, cuts) = trajectory::with_cuts(
        &zone,
        &cfg,
        segments,
        frames_per_segment,
        plan.seed * 1000 + 902,
    )?;
    let cuts: Vec<u64> = cuts.into_iter().map(|c| c as u64).collect();
    let key = format!(
        "{}segments = {segments}\nframes = {frames_per_segment:?}\n",
        toml::to_string(plan)?
    );
    let plan_path = dir.join(PLAN_TOML);
    if std::fs::read_to_string(&plan_path).is_ok_and(|t| t == key)
        && dir.join(native::POSES_CSV).is_file()
    {
        return Ok(cuts);
    }
    let seqs = [Sequence::new(TEST_SEQ.into(), Variant::Normal, frames)];
    let plain = ScenePlan {
        depth: false,
        random_materials: false,
        random_lighting: false,
        ..plan.clone()
    };
    write_dataset(&plain, dir, &seqs, Some(&cuts), progress)?;
    data::io::write_atomic(&plan_path, |w| w.write_all(key.as_bytes()))
        .with_context(|| format!("cannot write {}", plan_path.display()))?;
    Ok(cuts)
}

/// `dataset.toml` of the plan's datasets.
fn dataset_info(plan: &ScenePlan, camera: &geom::Camera) -> DatasetInfo {
    let mut settings = BTreeMap::new();
    settings.insert(
        "zone".into(),
        format!("building {} storey {}", plan.building, plan.storey),
    );
    settings.insert("mode".into(), plan.train_mode.clone());
    settings.insert("test_mode".into(), RenderMode::Textured.to_string());
    settings.insert("test_variant".into(), plan.test_variant.clone());
    settings.insert("train_variants".into(), plan.train_variants.join(","));
    if let Some(fps) = plan.train_fps {
        settings.insert("train_fps".into(), fps.to_string());
    }
    DatasetInfo {
        name: format!(
            "indoorloc demo: default building, building {} storey {}",
            plan.building, plan.storey
        ),
        dof: plan.camera_kind().dof(),
        units: "m".into(),
        frame_rate: WalkConfig::for_rig(rig(plan)).fps,
        mount: plan.camera_kind().mount(),
        camera: native::CameraInfo::from_camera(camera),
        generator: Some(Generator {
            name: format!("indoorloc demo {}", env!("CARGO_PKG_VERSION")),
            seed: Some(plan.seed),
            source: None,
            settings,
        }),
    }
}

/// A photo-like image as a network trained on `mode` renders must see it: unchanged for
/// `textured` and `shaded`, the renderer's gradient magnitude for `gradmag`, Canny edges
/// (thresholds 50/150, white on black like the `edges` renders) for `edges`.
pub fn photo_as(img: image::DynamicImage, mode: RenderMode) -> Result<image::DynamicImage> {
    Ok(match mode {
        RenderMode::Textured | RenderMode::Shaded => img,
        RenderMode::Gradmag => {
            image::DynamicImage::ImageRgb8(synth::render::gradmag_image(&img.to_rgb8()))
        }
        RenderMode::Edges => {
            let rgb = img.to_rgb8();
            let mut gray = image::GrayImage::new(rgb.width(), rgb.height());
            imgproc::view::rgb_to_gray(&rgb, &mut gray)?;
            let mut edges = image::GrayImage::new(rgb.width(), rgb.height());
            imgproc::view::canny(&gray, &mut edges, 50.0, 150.0)?;
            image::DynamicImage::ImageLuma8(edges)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(train_fps: Option<f64>) -> ScenePlan {
        ScenePlan {
            seed: 1,
            camera: "forward".into(),
            building: 0,
            storey: 0,
            zone: "corridor".into(),
            width: 32,
            height: 24,
            train_variants: vec!["normal".into(), "dim".into()],
            walks_per_variant: 1,
            frames_per_walk: 5,
            train_fps,
            walk_offset: 0,
            val_frames: 3,
            test_frames: 4,
            train_mode: textured(),
            test_variant: normal(),
            random_materials: false,
            random_lighting: false,
            depth: false,
        }
    }

    /// Seconds between a sequence's consecutive frames.
    fn steps(seq: &Sequence) -> Vec<f64> {
        seq.frames.windows(2).map(|w| w[1].t - w[0].t).collect()
    }

    #[test]
    fn training_walks_take_their_own_frame_rate_and_the_test_walk_keeps_the_rigs() -> Result<()> {
        let rig_fps = WalkConfig::for_rig(rig(&plan(None))).fps;
        let slow = sequences(&plan(Some(1.0)))?;
        assert_eq!(slow.len(), 4);
        for seq in &slow {
            let expected = if seq.name.starts_with("train-") {
                1.0
            } else {
                1.0 / rig_fps
            };
            for step in steps(seq) {
                assert!((step - expected).abs() < 1e-9, "{}: {step}", seq.name);
            }
        }
        // The rig's rate: the plan file of an earlier demo (no `train_fps`) still matches.
        for seq in sequences(&plan(None))? {
            assert!(steps(&seq).iter().all(|s| (s - 1.0 / rig_fps).abs() < 1e-9));
        }
        assert!(!toml::to_string(&plan(None))?.contains("train_fps"));
        assert!(!toml::to_string(&plan(None))?.contains("walk_offset"));
        Ok(())
    }

    #[test]
    fn the_sequence_models_walks_run_at_the_rigs_rate_along_new_routes_with_no_test_walk()
    -> Result<()> {
        let rig_fps = WalkConfig::for_rig(rig(&plan(None))).fps;
        let base = plan(Some(1.0));
        let cnn = sequences(&base)?;
        let seq = sequences(&base.for_sequence_model(1))?;
        // walks too short to cut stay whole
        assert_eq!(base.for_sequence_model(3).walks_per_variant, 1);
        let names: Vec<&str> = seq.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "train-normal-0",
                "train-normal-1",
                "train-normal-2",
                "train-dim-0",
                "train-dim-1",
                "train-dim-2",
                "val"
            ]
        );
        let max_apart = |a: &Sequence, b: &Sequence| {
            a.frames
                .iter()
                .zip(&b.frames)
                .map(|(x, y)| (x.pose.translation - y.pose.translation).norm())
                .fold(0.0, f64::max)
        };
        for a in &seq {
            assert!(steps(a).iter().all(|s| (s - 1.0 / rig_fps).abs() < 1e-9));
            assert_eq!(a.frames.len(), if a.name == "val" { 3 } else { 2 });
            for b in &cnn {
                if a.name == "val" && b.name == "val" {
                    assert!(
                        max_apart(a, b) < 1e-9,
                        "the validation walk is the network's"
                    );
                } else if b.name.starts_with("train-") {
                    assert!(max_apart(a, b) > 1e-3, "{} on {}'s route", a.name, b.name);
                }
            }
        }
        Ok(())
    }
}
