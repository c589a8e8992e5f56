//! `indoorloc synth`: renders posed sequences of a world into a native dataset (DESIGN.md), with
//! labels, depth, plane ids, gold scene cuts and splits by sequence; optionally also the 7-Scenes
//! layout.
//!
//! Frames render in parallel (rayon, one [`Renderer`] per worker) and every random choice is
//! seeded per sequence or per frame, so the same settings give byte-identical files whatever the
//! thread count. Every file is written atomically; frames already on disk from an interrupted
//! run are rendered again only when missing (`resume`), so a long job can be restarted.

use crate::error::{Result, SynthError};
use crate::import::{ImportOptions, load};
use crate::procedural::default_world;
use crate::render::{RenderMode, RenderOptions, RenderScene, Renderer};
use crate::trajectory::{self, MAX_FPS, MIN_FPS, PosedFrame, Rig, WalkConfig};
use crate::variants::{self, Crowd};
use crate::world::{Variant, World};
use data::native::{self, DatasetInfo, Generator, Label, Splits};
use data::{PoseFrame, Trajectory};
use geom::{Camera, Mount, Pose};
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// People who would pass within this distance (m) of the camera are left out of that shot (the
/// frames between two cuts): a camera inside a figure would see only a shirt, real walkers step
/// around a camera, and nobody may pop in or out of view between two frames.
pub const PERSON_CLEARANCE_M: f64 = 0.6;

/// Where the building comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum WorldSource {
    /// The procedural default building with this layout seed.
    Default {
        /// Layout seed.
        seed: u64,
    },
    /// A model file (OBJ, glTF, GLB).
    File {
        /// The model.
        path: PathBuf,
        /// Units and up axis.
        options: ImportOptions,
    },
}

/// How camera poses are drawn.
#[derive(Clone, PartialEq, Default)]
pub enum Sampler {
    /// Natural walks along the walk graph, one per sequence.
    #[default]
    Walk,
    /// Walks joined by hard cuts to other places (gold cuts in `cuts.csv`).
    WalkWithCuts,
    /// Uniform random poses in free space.
    Random,
    /// Poses near given camera poses, spread evenly along them in order ([`trajectory::near_poses`]): for a scan, whose
    /// free space is known only along its own camera's path. The poses are cut into
    /// `sequences` runs of consecutive poses and sequence `k` draws near run `k` alone, so a
    /// split by sequence is a split along the path. Needs no walk graph.
    Near {
        /// Camera-to-world poses in the world frame, in the order of their path.
        poses: Vec<Pose>,
        /// Largest distance of a drawn camera centre from its pose's, metres (0.3 on the
        /// command line).
        radius_m: f64,
        /// Largest rotation of a drawn camera from its pose, degrees (10 on the command line).
        angle_deg: f64,
    },
}

impl Sampler {
    /// The name `dataset.toml` records.
    pub fn name(&self) -> &'static str {
        match self {
            Sampler::Walk => "walk",
            Sampler::WalkWithCuts => "walkwithcuts",
            Sampler::Random => "random",
            Sampler::Near { .. } => "near",
        }
    }

    /// Whether it walks the walk graph.
    fn walks(&self) -> bool {
        matches!(self, Sampler::Walk | Sampler::WalkWithCuts)
    }
}

/// Written by hand so that [`SETTINGS_FILE`] (the config's `Debug`) names a path of thousands
/// of poses by its length and a hash of their bits, not by every number.
impl std::fmt::Debug for Sampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Sampler::Walk => f.write_str("Walk"),
            Sampler::WalkWithCuts => f.write_str("WalkWithCuts"),
            Sampler::Random => f.write_str("Random"),
            Sampler::Near {
                poses,
                radius_m,
                angle_deg,
            } => {
                let bits = poses.iter().flat_map(|p| {
                    let (q, t) = (p.rotation.quaternion().coords, p.translation);
                    [q.x, q.y, q.z, q.w, t.x, t.y, t.z]
                });
                let hash = bits.fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
                    (h ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3)
                });
                f.debug_struct("Near")
                    .field(
                        "poses",
                        &format_args!("{} poses, FNV-1a {hash:016x}", poses.len()),
                    )
                    .field("radius_m", radius_m)
                    .field("angle_deg", angle_deg)
                    .finish()
            }
        }
    }
}

/// Camera mounting of the sequences.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CameraKind {
    /// Hand-held / head-mounted, looking ahead (6-DoF dataset).
    #[default]
    Forward,
    /// On a robot, looking up at the ceiling (3-DoF dataset).
    Ceiling,
}

impl CameraKind {
    /// Degrees of freedom of its poses as `dataset.toml` states them: a ceiling camera on a
    /// robot moves in the plane (3), a forward camera freely (6).
    pub fn dof(self) -> u8 {
        match self {
            CameraKind::Forward => 6,
            CameraKind::Ceiling => 3,
        }
    }

    /// How it is mounted, as `dataset.toml` states it.
    pub fn mount(self) -> Mount {
        match self {
            CameraKind::Forward => Mount::Forward,
            CameraKind::Ceiling => Mount::Ceiling,
        }
    }
}

/// Everything that shapes a synthetic dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthConfig {
    /// The building.
    pub world: WorldSource,
    /// Forward or ceiling camera.
    pub camera: CameraKind,
    /// How poses are drawn.
    pub sampler: Sampler,
    /// Total frames.
    pub frames: usize,
    /// Number of sequences the frames are split into (splits are made of sequences).
    pub sequences: usize,
    /// Frame rate of walks, frames per second; `None`: the rig's own (10 for a person, 5 for
    /// a robot). A lower rate spreads the same number of frames over more ground.
    pub fps: Option<f64>,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Render mode.
    pub mode: RenderMode,
    /// Appearance variant.
    pub variant: Variant,
    /// Seed of trajectories, variants, the camera's intrinsics and sensor noise.
    pub seed: u64,
    /// Seed of the trajectories alone (default: `seed`): other walks seen by the same camera.
    pub walk_seed: Option<u64>,
    /// The camera, in place of one drawn from the seed ([`trajectory::camera_for`]): resized to
    /// `width` x `height` ([`Camera::resized`]), so a scan is seen through the lens of the
    /// dataset it was made from at any output size.
    pub intrinsics: Option<Camera>,
    /// Write `depth/` (16-bit millimetres).
    pub depth: bool,
    /// Write `planes/` (8-bit dominant-plane ids).
    pub planes: bool,
    /// Finish an interrupted run into the same folder with the same settings: frames whose
    /// every output is on disk are kept.
    pub resume: bool,
    /// Replace a dataset already in the folder (without `resume` or `force` a folder that
    /// holds one is refused, so that no work is lost by a mistyped path).
    pub force: bool,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            world: WorldSource::Default { seed: 1 },
            camera: CameraKind::Forward,
            sampler: Sampler::Walk,
            frames: 600,
            sequences: 6,
            fps: None,
            width: 320,
            height: 240,
            mode: RenderMode::Textured,
            variant: Variant::Normal,
            seed: 1,
            walk_seed: None,
            intrinsics: None,
            depth: true,
            planes: true,
            resume: false,
            force: false,
        }
    }
}

/// What a run wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSummary {
    /// Frames in the dataset.
    pub frames: usize,
    /// Frames rendered by this run (fewer than `frames` when resuming).
    pub rendered: usize,
    /// Seconds spent rendering and writing images.
    pub render_seconds: f64,
    /// Warnings (from importing a model).
    pub warnings: Vec<String>,
}

/// Builds the world of `cfg` with its variant applied.
pub fn build_world(cfg: &SynthConfig) -> Result<(World, Vec<String>)> {
    let (mut world, warnings) = match &cfg.world {
        WorldSource::Default { seed } => (default_world(*seed, cfg.variant), Vec::new()),
        WorldSource::File { path, options } => {
            let (w, report) = load(path, options)?;
            (w, report.warnings)
        }
    };
    variants::apply(&mut world, cfg.variant, cfg.seed);
    Ok((world, warnings))
}

/// The camera rig of a camera kind.
pub fn rig_of(kind: CameraKind) -> Rig {
    match kind {
        CameraKind::Forward => Rig::forward(),
        CameraKind::Ceiling => Rig::ceiling(),
    }
}

/// One frame of [`run`]'s plan: where, when, and which sequence (by number).
struct Planned {
    seq: usize,
    frame: PosedFrame,
}

/// The most frames one dataset may hold: the plan of every frame is made, and held in memory,
/// before the first is rendered (`u64::MAX` frames asked for memory without end).
pub const MAX_FRAMES: usize = 2_000_000;
/// The largest image side, pixels.
pub const MAX_SIDE: u32 = 8192;

/// Renders the dataset into `out`; `progress` is called with the number of frames done so far.
pub fn run(
    cfg: &SynthConfig,
    out: &Path,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SynthSummary> {
    if cfg.frames == 0 || cfg.sequences == 0 || cfg.sequences > cfg.frames {
        return Err(SynthError::Config(format!(
            "need 1 ≤ sequences ≤ frames (got {} sequences, {} frames)",
            cfg.sequences, cfg.frames
        )));
    }
    if cfg.frames > MAX_FRAMES {
        return Err(SynthError::Config(format!(
            "{} frames is more than {MAX_FRAMES}, the most one dataset holds (split the \
             rendering into several datasets)",
            cfg.frames
        )));
    }
    if cfg.width < 8 || cfg.height < 8 || cfg.width > MAX_SIDE || cfg.height > MAX_SIDE {
        return Err(SynthError::Config(format!(
            "image size {}x{} must be within 8x8 and {MAX_SIDE}x{MAX_SIDE}",
            cfg.width, cfg.height
        )));
    }
    if let Some(fps) = cfg.fps
        && !(fps.is_finite() && (MIN_FPS..=MAX_FPS).contains(&fps))
    {
        return Err(SynthError::Config(format!(
            "fps {fps:e} must be within [{MIN_FPS}, {MAX_FPS}] frames per second"
        )));
    }
    prepare_folder(cfg, out)?;
    let (mut world, warnings) = build_world(cfg)?;
    check_sampler(cfg, &world)?;
    let crowd = (cfg.variant == Variant::People).then(|| {
        let count = Crowd::suggested_count(&world);
        Crowd::new(&mut world, count, cfg.seed)
    });
    let rig = rig_of(cfg.camera);
    let camera = camera_of(cfg, &rig)?;
    let (planned, cuts, fps) = plan_shots(&world, cfg, &rig)?;
    let left_out = crowd
        .as_ref()
        .map(|c| people_left_out(c, &world, &planned, &cuts))
        .unwrap_or_default();
    let names: Vec<String> = (0..cfg.sequences).map(seq_name).collect();
    let shots: Vec<Shot> = planned
        .iter()
        .enumerate()
        .map(|(index, p)| Shot {
            index: index as u64,
            seq: &names[p.seq],
            frame: &p.frame,
            mode: cfg.mode,
            left_out: left_out.get(index).map_or(&[], Vec::as_slice),
        })
        .collect();

    // Every image folder, also those of outputs turned off: the layout of every synth dataset.
    for sub in IMAGE_DIRS {
        let dir = out.join(sub);
        std::fs::create_dir_all(&dir).map_err(|source| SynthError::Io { path: dir, source })?;
    }
    let options = ExportOptions {
        seed: cfg.seed,
        depth: cfg.depth,
        planes: cfg.planes,
        resume: cfg.resume,
    };
    let export = Export::new(out, &camera, options, progress)?;
    let start = std::time::Instant::now();
    export.render(&world, crowd.as_ref(), &shots)?;
    let render_seconds = start.elapsed().as_secs_f64();

    let splits = native::split_by_sequence(&names, 0.15, 0.15, cfg.seed);
    let cuts = (!cuts.is_empty()).then_some(cuts.as_slice());
    let info = dataset_info(cfg, &world, &camera, fps);
    write_metadata(out, &info, &shots, true, cuts, &splits)?;
    Ok(SynthSummary {
        frames: shots.len(),
        rendered: export.rendered(),
        render_seconds,
        warnings,
    })
}

/// The camera of `cfg`'s frames: its [`SynthConfig::intrinsics`] at the output size, else one
/// drawn for `rig` from the seed.
pub fn camera_of(cfg: &SynthConfig, rig: &Rig) -> Result<Camera> {
    match &cfg.intrinsics {
        Some(cam) => {
            cam.validate()?;
            Ok(cam.resized(cfg.width, cfg.height))
        }
        None => trajectory::camera_for(rig, cfg.width, cfg.height, cfg.seed),
    }
}

/// Refuses a walking sampler on a model without a walk graph (a scan with no walkable floor) with
/// an error naming the file and what works instead, rather than the walk's own words; and a
/// path too short to cut into the sequences asked for.
fn check_sampler(cfg: &SynthConfig, world: &World) -> Result<()> {
    if let Sampler::Near { poses, .. } = &cfg.sampler
        && poses.len() < cfg.sequences
    {
        return Err(SynthError::Config(format!(
            "{} poses to draw near cannot be cut into {} sequences",
            poses.len(),
            cfg.sequences
        )));
    }
    if !cfg.sampler.walks() || !(world.walk.nodes.is_empty() || world.walk.edges.is_empty()) {
        return Ok(());
    }
    let msg = "the model has no walk graph (no walkable floor was found, or none of its floor \
               points are joined), so it cannot be walked: sample random poses in it, or poses \
               near a camera path (a scan's own dataset)";
    Err(match &cfg.world {
        WorldSource::File { path, .. } => SynthError::Model {
            path: path.clone(),
            msg: msg.into(),
        },
        WorldSource::Default { .. } => SynthError::Config(msg.into()),
    })
}

/// What every frame of one dataset shares, whichever world renders it: which images it writes
/// besides the colour frame, and the seed its render noise is drawn from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExportOptions {
    /// Seed of the render noise; frame `index` draws its own from `seed * 1_000_003 + index`,
    /// so a frame looks the same whichever order or group renders it.
    pub seed: u64,
    /// Write `depth/` (16-bit millimetres).
    pub depth: bool,
    /// Write `planes/` (8-bit dominant-plane ids).
    pub planes: bool,
    /// Keep a frame whose every output is already on disk instead of rendering it again
    /// (finishing an interrupted run).
    pub resume: bool,
}

/// One frame of a native dataset to render: everything that varies from frame to frame. The
/// world it is rendered in is the [`Export::render`] call's, so that frames of several
/// appearance variants or material draws go into one dataset, each group from its own world.
#[derive(Clone, Copy, Debug)]
pub struct Shot<'a> {
    /// Frame number in the dataset: the name of its images and of its line in `poses.csv`, and
    /// the seed of its render noise.
    pub index: u64,
    /// Name of its sequence in `poses.csv` (splits are made of sequences).
    pub seq: &'a str,
    /// The camera's pose, the time (where the people walking the world are) and the place
    /// (the labels of `labels.csv`).
    pub frame: &'a PosedFrame,
    /// How it is rendered.
    pub mode: RenderMode,
    /// Per person of the crowd, whether they are left out of this frame (too close to the
    /// camera somewhere in its shot, [`PERSON_CLEARANCE_M`]); missing entries count as
    /// present. Unused without a crowd.
    pub left_out: &'a [bool],
}

/// A native dataset being rendered into a folder with one camera: [`Shot`]s are rendered in
/// parallel (one [`Renderer`] per worker) into `frames/`, `depth/` and `planes/`, in one call
/// per world they are seen in, and counted across calls for `progress`.
pub struct Export<'a> {
    out: &'a Path,
    camera: &'a Camera,
    options: ExportOptions,
    progress: &'a (dyn Fn(usize) + Sync),
    done: AtomicUsize,
    rendered: AtomicUsize,
}

impl<'a> Export<'a> {
    /// Makes the image folders the options ask for in `out`; `progress` is called with the
    /// number of frames done so far (kept on disk with `resume` included).
    pub fn new(
        out: &'a Path,
        camera: &'a Camera,
        options: ExportOptions,
        progress: &'a (dyn Fn(usize) + Sync),
    ) -> Result<Self> {
        let subs = [
            ("frames", true),
            ("depth", options.depth),
            ("planes", options.planes),
        ];
        for (sub, _) in subs.iter().filter(|(_, on)| *on) {
            let dir = out.join(sub);
            std::fs::create_dir_all(&dir).map_err(|source| SynthError::Io { path: dir, source })?;
        }
        Ok(Export {
            out,
            camera,
            options,
            progress,
            done: AtomicUsize::new(0),
            rendered: AtomicUsize::new(0),
        })
    }

    /// Renders `shots` in `world`, with the people of `crowd` walking it, and writes their
    /// images.
    pub fn render(&self, world: &World, crowd: Option<&Crowd>, shots: &[Shot<'_>]) -> Result<()> {
        let scene = RenderScene::new(world)?;
        let ExportOptions {
            seed,
            depth,
            planes,
            resume,
        } = self.options;
        let (width, height) = (self.camera.width, self.camera.height);
        shots
            .par_iter()
            .try_for_each_init(Renderer::new, |renderer, shot| -> Result<()> {
                let path = |sub: &str| {
                    self.out
                        .join(sub)
                        .join(format!("{}.png", native::frame_name(shot.index)))
                };
                let complete = path("frames").is_file()
                    && (!depth || path("depth").is_file())
                    && (!planes || path("planes").is_file());
                if !(resume && complete) {
                    let opts = RenderOptions {
                        mode: shot.mode,
                        seed: seed.wrapping_mul(1_000_003).wrapping_add(shot.index),
                        ..RenderOptions::default()
                    };
                    let extra = crowd
                        .map(|c| c.triangles_without(world, shot.frame.t, shot.left_out))
                        .unwrap_or_default();
                    let img =
                        renderer.render(&scene, self.camera, &shot.frame.pose, &opts, &extra)?;
                    write_png(&path("frames"), &encode_rgb(&img.rgb)?)?;
                    if depth {
                        write_png(&path("depth"), &encode_depth_mm(&img.depth, width, height)?)?;
                    }
                    if planes {
                        write_png(&path("planes"), &encode_planes(&img.plane, width, height)?)?;
                    }
                    self.rendered.fetch_add(1, Ordering::Relaxed);
                }
                (self.progress)(self.done.fetch_add(1, Ordering::Relaxed) + 1);
                Ok(())
            })
    }

    /// Frames rendered so far (those kept on disk with `resume` not counted).
    pub fn rendered(&self) -> usize {
        self.rendered.load(Ordering::Relaxed)
    }
}

/// File in a dataset folder recording the settings it is rendered with, so that `resume`
/// continues only the same run.
pub const SETTINGS_FILE: &str = "synth-settings.txt";

/// The image folders a run writes.
const IMAGE_DIRS: [&str; 3] = ["frames", "depth", "planes"];

/// The settings that shape the content (everything but `resume` and `force`).
fn settings_key(cfg: &SynthConfig) -> String {
    format!(
        "{:?}\n",
        SynthConfig {
            resume: false,
            force: false,
            ..cfg.clone()
        }
    )
}

/// Makes `out` ready for a run: a folder holding a dataset (or a part of one) is refused unless
/// the run resumes it with the settings it was made with, or `force` replaces it (its dataset
/// files and image folders are removed first); temporary files an interrupted run left are
/// removed. Records the run's settings.
fn prepare_folder(cfg: &SynthConfig, out: &Path) -> Result<()> {
    let settings_path = out.join(SETTINGS_FILE);
    let images = |sub: &str| {
        std::fs::read_dir(out.join(sub)).map_or(0, |d| d.filter_map(|e| e.ok()).count())
    };
    let held = IMAGE_DIRS.iter().map(|d| images(d)).sum::<usize>();
    let occupied = held > 0 || out.join(native::DATASET_TOML).is_file() || settings_path.is_file();
    let key = settings_key(cfg);
    if occupied && cfg.resume {
        let recorded = std::fs::read_to_string(&settings_path).map_err(|_| {
            SynthError::Config(format!(
                "{} holds no record of the settings its images were made with ({SETTINGS_FILE}): \
                 it cannot be resumed; --force replaces it",
                out.display()
            ))
        })?;
        if recorded != key {
            return Err(SynthError::Config(format!(
                "{} was rendered with other settings than these ({}): resume it with the same \
                 settings, or --force to replace it; recorded: {}",
                out.display(),
                settings_path.display(),
                recorded.trim()
            )));
        }
    } else if occupied && !cfg.force {
        return Err(SynthError::Config(format!(
            "{} already holds a dataset ({held} images): --resume finishes an interrupted run \
             with the same settings, --force replaces it",
            out.display()
        )));
    } else if occupied {
        for sub in IMAGE_DIRS {
            remove(&out.join(sub), |p| std::fs::remove_dir_all(p))?;
        }
        for file in [
            native::DATASET_TOML,
            native::POSES_CSV,
            native::LABELS_CSV,
            native::CUTS_CSV,
            native::SPLITS_TOML,
            SETTINGS_FILE,
        ] {
            remove(&out.join(file), |p| std::fs::remove_file(p))?;
        }
    }
    for sub in IMAGE_DIRS {
        let Ok(entries) = std::fs::read_dir(out.join(sub)) else {
            continue;
        };
        for entry in entries.filter_map(|e| e.ok()) {
            if entry.file_name().to_string_lossy().ends_with(".tmp") {
                remove(&entry.path(), |p| std::fs::remove_file(p))?;
            }
        }
    }
    data::io::write_atomic(&settings_path, |w| w.write_all(key.as_bytes()))?;
    Ok(())
}

/// Removes `path` with `how`; a path that is not there is no error.
fn remove(path: &Path, how: impl Fn(&Path) -> std::io::Result<()>) -> Result<()> {
    match how(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(SynthError::Io {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Per frame, the people left out of it: those who come within [`PERSON_CLEARANCE_M`] of the
/// camera anywhere in the frame's shot (the frames of one sequence between two cuts), so that
/// nobody appears or vanishes between two frames of a shot.
fn people_left_out(
    crowd: &Crowd,
    world: &World,
    shots: &[Planned],
    cuts: &[u64],
) -> Vec<Vec<bool>> {
    let mut out = Vec::with_capacity(shots.len());
    let mut start = 0;
    while start < shots.len() {
        let mut end = start + 1;
        while end < shots.len()
            && shots[end].seq == shots[start].seq
            && cuts.binary_search(&(end as u64)).is_err()
        {
            end += 1;
        }
        let cameras: Vec<_> = shots[start..end]
            .iter()
            .map(|s| (s.frame.t, nalgebra::Point3::from(s.frame.pose.position())))
            .collect();
        let left = crowd.too_close(world, &cameras, PERSON_CLEARANCE_M);
        out.extend(std::iter::repeat_n(left, end - start));
        start = end;
    }
    out
}

/// Draws the poses of every sequence: `(shots, gold cuts as frame indices, frame rate)`.
fn plan_shots(
    world: &World,
    cfg: &SynthConfig,
    rig: &Rig,
) -> Result<(Vec<Planned>, Vec<u64>, f64)> {
    let mut walk_cfg = WalkConfig::for_rig(rig.clone());
    if let Some(fps) = cfg.fps {
        walk_cfg.fps = fps;
    }
    let mut shots = Vec::with_capacity(cfg.frames);
    let mut cuts = Vec::new();
    for seq in 0..cfg.sequences {
        // Frames spread evenly over sequences; the first ones take the remainder.
        let n = cfg.frames / cfg.sequences + usize::from(seq < cfg.frames % cfg.sequences);
        let seed = cfg
            .walk_seed
            .unwrap_or(cfg.seed)
            .wrapping_mul(7919)
            .wrapping_add(seq as u64);
        let frames = match &cfg.sampler {
            Sampler::Walk => trajectory::walk(world, &walk_cfg, n, seed)?,
            Sampler::Random => trajectory::random_poses(world, rig, n, seed)?,
            Sampler::Near {
                poses,
                radius_m,
                angle_deg,
            } => {
                // Run `seq` of `sequences` near-equal runs of consecutive poses.
                let run = |k: usize| k * poses.len() / cfg.sequences;
                let near = poses.get(run(seq)..run(seq + 1)).unwrap_or_default();
                trajectory::near_poses(world, near, n, *radius_m, *angle_deg, seed)?
            }
            Sampler::WalkWithCuts => {
                let segments = (n / 40).clamp(2, 8);
                // Segment lengths vary; the shortest draw still covers n frames in total.
                let lo = n.div_ceil(segments);
                let (mut frames, seq_cuts) =
                    trajectory::with_cuts(world, &walk_cfg, segments, [lo, lo + lo / 2], seed)?;
                frames.truncate(n);
                let base = shots.len() as u64;
                cuts.extend(
                    seq_cuts
                        .into_iter()
                        .filter(|&c| c < n)
                        .map(|c| base + c as u64),
                );
                frames
            }
        };
        if seq > 0 {
            // A new sequence starts somewhere else: a cut in a continuous video of all of them.
            cuts.push(shots.len() as u64);
        }
        shots.extend(frames.into_iter().map(|frame| Planned { seq, frame }));
    }
    cuts.sort_unstable();
    cuts.dedup();
    Ok((shots, cuts, walk_cfg.fps))
}

fn seq_name(seq: usize) -> String {
    format!("walk-{seq:02}")
}

/// `dataset.toml` of a [`run`].
fn dataset_info(cfg: &SynthConfig, world: &World, camera: &Camera, fps: f64) -> DatasetInfo {
    let mut settings = BTreeMap::new();
    settings.insert("world".into(), world.name.clone());
    settings.insert("mode".into(), cfg.mode.to_string());
    settings.insert("variant".into(), cfg.variant.name().into());
    settings.insert("sampler".into(), cfg.sampler.name().into());
    DatasetInfo {
        name: format!("{} ({}, {})", world.name, cfg.mode, cfg.variant.name()),
        dof: cfg.camera.dof(),
        units: "m".into(),
        frame_rate: fps,
        mount: cfg.camera.mount(),
        camera: native::CameraInfo::from_camera(camera),
        generator: Some(Generator {
            name: format!("indoorloc synth {}", env!("CARGO_PKG_VERSION")),
            seed: Some(cfg.seed),
            source: None,
            settings,
        }),
    }
}

/// Writes the metadata of the dataset `shots` were rendered into, `shots` in dataset order:
/// `poses.csv` (each shot's frame number, sequence, time and pose), `dataset.toml` (`info`),
/// `splits.toml`, with `labels` a `labels.csv` of the places of the shots that have one (none
/// when no shot has), and `cuts.csv` with `cuts` (frame numbers of the gold scene cuts).
/// A `labels.csv` or `cuts.csv` not asked for is removed, so the folder says only what the
/// shots do.
pub fn write_metadata(
    out: &Path,
    info: &DatasetInfo,
    shots: &[Shot<'_>],
    labels: bool,
    cuts: Option<&[u64]>,
    splits: &Splits,
) -> Result<()> {
    let frames: Vec<PoseFrame> = shots
        .iter()
        .map(|s| PoseFrame {
            name: native::frame_name(s.index),
            seq: s.seq.to_string(),
            t: Some(s.frame.t),
            pose: s.frame.pose,
        })
        .collect();
    let labels: Vec<Label> = if labels {
        shots.iter().filter_map(label).collect()
    } else {
        Vec::new()
    };
    let labels = (!labels.is_empty()).then_some(labels.as_slice());
    native::write_metadata(out, info, &Trajectory::new(frames), labels, cuts, splits)?;
    Ok(())
}

/// The place of a shot as `labels.csv` names it, if it is in one.
fn label(shot: &Shot<'_>) -> Option<Label> {
    let place = shot.frame.place.as_ref()?;
    Some(Label {
        frame: shot.index,
        building: format!("B{}", place.building),
        floor: format!("F{}", place.storey),
        corridor: place
            .corridor
            .map_or_else(|| "none".into(), |c| format!("C{c}")),
        direction: shot.frame.direction.map_or("none", |d| d.name()).into(),
    })
}

fn write_png(path: &Path, bytes: &[u8]) -> Result<()> {
    data::io::write_atomic(path, |w| w.write_all(bytes)).map_err(SynthError::from)
}

fn encode(width: u32, height: u32, raw: &[u8], color: image::ExtendedColorType) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut bytes,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Adaptive,
    )
    .write_image(raw, width, height, color)
    .map_err(|e| SynthError::Config(format!("PNG encoding failed: {e}")))?;
    Ok(bytes)
}

/// PNG bytes of an RGB image.
pub fn encode_rgb(img: &image::RgbImage) -> Result<Vec<u8>> {
    encode(
        img.width(),
        img.height(),
        img.as_raw(),
        image::ExtendedColorType::Rgb8,
    )
}

/// PNG bytes of a 16-bit depth image in millimetres (0 = no depth; saturates at 65.535 m).
pub fn encode_depth_mm(depth: &[f32], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut raw = Vec::with_capacity(depth.len() * 2);
    for &d in depth {
        let mm = if d.is_finite() && d > 0.0 {
            (d * 1000.0).round().min(65535.0) as u16
        } else {
            0
        };
        // Native order: the `image` encoder turns 16-bit samples into PNG's big-endian itself
        // (bytes handed to it already big-endian came out swapped, 802 mm read as 8707).
        raw.extend_from_slice(&mm.to_ne_bytes());
    }
    encode(width, height, &raw, image::ExtendedColorType::L16)
}

/// PNG bytes of 8-bit dominant-plane ids: this frame's planes ranked by pixel count, the largest
/// 1, the next 2, ... up to 255; 0 for no plane (and for planes beyond the 255 largest).
pub fn encode_planes(plane: &[u32], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut counts: HashMap<u32, usize> = HashMap::new();
    for &p in plane.iter().filter(|&&p| p != 0) {
        *counts.entry(p).or_default() += 1;
    }
    let mut ranked: Vec<(u32, usize)> = counts.into_iter().collect();
    // Largest first; ties by id so the output does not depend on hash order.
    ranked.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let rank: HashMap<u32, u8> = ranked
        .iter()
        .take(255)
        .enumerate()
        .map(|(i, &(id, _))| (id, (i + 1) as u8))
        .collect();
    let raw: Vec<u8> = plane
        .iter()
        .map(|p| rank.get(p).copied().unwrap_or(0))
        .collect();
    encode(width, height, &raw, image::ExtendedColorType::L8)
}

/// Writes the 7-Scenes layout of a native dataset (`seq-XX/frame-NNNNNN.{color.png, pose.txt,
/// depth.png}`, `TrainSplit.txt`, `TestSplit.txt`; validation sequences count as training).
pub fn export_7scenes(native_dir: &Path, out: &Path) -> Result<()> {
    let ds = native::NativeDataset::open(native_dir)?;
    let seqs = ds.sequences();
    let seq_no: HashMap<&str, usize> = seqs
        .iter()
        .enumerate()
        .map(|(i, s)| (s.as_str(), i + 1))
        .collect();
    let mut frames = Vec::with_capacity(ds.trajectory.len());
    let mut per_seq_index: HashMap<usize, usize> = HashMap::new();
    for (i, f) in ds.trajectory.frames.iter().enumerate() {
        let no = seq_no.get(f.seq.as_str()).copied().unwrap_or(0);
        let k = per_seq_index.entry(no).or_default();
        let stem = format!("frame-{:06}", *k);
        *k += 1;
        let dir = out.join(format!("seq-{no:02}"));
        std::fs::create_dir_all(&dir).map_err(|source| SynthError::Io {
            path: dir.clone(),
            source,
        })?;
        let frame_no = ds.frame_number(i).unwrap_or(i as u64);
        copy(
            &ds.frame_path(frame_no),
            &dir.join(format!("{stem}.color.png")),
        )?;
        let depth = ds.depth_path(frame_no);
        if depth.is_file() {
            copy(&depth, &dir.join(format!("{stem}.depth.png")))?;
        }
        frames.push(PoseFrame {
            name: stem,
            seq: format!("seq-{no:02}"),
            t: f.t,
            pose: f.pose,
        });
    }
    data::sevenscenes::write(&Trajectory::new(frames), out)?;
    let list = |names: &[String]| -> String {
        names
            .iter()
            .filter_map(|s| seq_no.get(s.as_str()))
            .map(|no| format!("sequence{no}\n"))
            .collect()
    };
    let mut train = ds.splits.train.clone();
    train.extend(ds.splits.val.iter().cloned());
    data::io::write_text_atomic(&out.join("TrainSplit.txt"), &list(&train))?;
    data::io::write_text_atomic(&out.join("TestSplit.txt"), &list(&ds.splits.test))?;
    Ok(())
}

fn copy(from: &Path, to: &Path) -> Result<()> {
    let bytes = std::fs::read(from).map_err(|source| SynthError::Io {
        path: from.to_path_buf(),
        source,
    })?;
    write_png(to, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    /// A scan (no walk graph) rendered near its own camera path: the dataset's poses mapped into
    /// the world by the GLB's record, every drawn pose within the spread of its sequence's run
    /// of the path, the dataset's camera at the output size, the photographed colours on
    /// screen. Walking it is an error naming the file; random poses work.
    #[test]
    fn synth_renders_a_scan_near_its_own_camera_path() -> TestResult {
        use crate::import::{scan_frame, test_scan};
        let dir = tempfile::tempdir()?;
        // The dataset's frame is the world turned and shifted.
        let to_world = Pose::from_euler_ypr(0.4, 0.1, -0.05, [0.5, -1.0, 0.2])?;
        let model = test_scan::write(
            &dir.path().join("kitchen.glb"),
            Some(&test_scan::extras(&to_world)),
            true,
        )?;
        // In the world: level cameras 1 m from the back wall (y = 2), facing it, away from the
        // atlas's seam at x = 1.5 m.
        let path: Vec<Pose> = [0.8, 0.9, 2.1, 2.2, 0.85, 2.15]
            .iter()
            .map(|&x| {
                geom::Pose3 {
                    x,
                    y: 1.0,
                    heading: std::f64::consts::FRAC_PI_2,
                }
                .to_pose(Mount::Forward, 1.2)
            })
            .collect();
        let recorded: Vec<Pose> = path.iter().map(|w| to_world.inverse().compose(w)).collect();
        let to_world = scan_frame(&model)?.ok_or("no record")?;
        let poses: Vec<Pose> = recorded.iter().map(|d| to_world.compose(d)).collect();
        let lens = Camera::new(640, 480, 585.0, 585.0, 320.0, 240.0, Default::default())?;
        let cfg = SynthConfig {
            world: WorldSource::File {
                path: model.clone(),
                options: ImportOptions::default(),
            },
            sampler: Sampler::Near {
                poses,
                radius_m: 0.3,
                angle_deg: 10.0,
            },
            frames: 12,
            sequences: 3,
            width: 64,
            height: 48,
            intrinsics: Some(lens),
            ..SynthConfig::default()
        };
        let out = dir.path().join("near");
        let summary = run(&cfg, &out, &|_| {})?;
        assert_eq!(summary.frames, 12);
        assert!(
            summary
                .warnings
                .iter()
                .any(|w| w.contains("no walkable floor"))
        );
        let ds = native::NativeDataset::open(&out)?;
        assert_eq!(ds.info.camera.to_camera()?, lens.resized(64, 48));
        assert_eq!(
            ds.info
                .generator
                .as_ref()
                .map(|g| g.settings["sampler"].as_str()),
            Some("near")
        );
        let seqs = ds.sequences();
        for (i, f) in ds.trajectory.frames.iter().enumerate() {
            // Sequence k draws near run k: path[2k..2k + 2].
            let k = seqs.iter().position(|s| *s == f.seq).ok_or("sequence")?;
            let d = path[2 * k..2 * k + 2]
                .iter()
                .map(|p| (p.translation - f.pose.translation).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 0.3 + 1e-6, "frame {i}: {d} m from its run");
            let frame = image::open(ds.frame_path(i as u64))?.to_rgb8();
            let centre = frame.get_pixel(32, 24).0;
            assert!(
                test_scan::ATLAS
                    .iter()
                    .any(|c| (0..3).all(|j| centre[j].abs_diff(c[j]) <= 12)),
                "frame {i}: {centre:?}"
            );
        }
        let settings = std::fs::read_to_string(out.join(SETTINGS_FILE))?;
        assert!(settings.contains("6 poses, FNV-1a"), "{settings}");

        let walk = SynthConfig {
            sampler: Sampler::Walk,
            force: true,
            ..cfg.clone()
        };
        let msg = run(&walk, &out, &|_| {})
            .err()
            .ok_or("walked a scan")?
            .to_string();
        assert!(
            msg.contains("kitchen.glb") && msg.contains("no walk graph"),
            "{msg}"
        );
        let random = SynthConfig {
            sampler: Sampler::Random,
            frames: 2,
            sequences: 1,
            force: true,
            ..cfg.clone()
        };
        assert_eq!(run(&random, &out, &|_| {})?.frames, 2);
        let short = SynthConfig {
            sequences: 7,
            force: true,
            ..cfg
        };
        let msg = run(&short, &out, &|_| {})
            .err()
            .ok_or("cut 6 poses in 7")?
            .to_string();
        assert!(msg.contains("7 sequences"), "{msg}");
        Ok(())
    }

    #[test]
    fn depth_pngs_read_back_in_millimetres() {
        let png = encode_depth_mm(&[0.802, 3.769, 0.0, f32::NAN, 70.0, 1.0], 3, 2).unwrap();
        let img = image::load_from_memory(&png).unwrap();
        let image::DynamicImage::ImageLuma16(d) = img else {
            panic!("not 16-bit grey");
        };
        assert_eq!(d.as_raw(), &[802, 3769, 0, 0, 65535, 1000]);
    }
}
