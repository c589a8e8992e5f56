//! A query image's pose from the map: candidates (the keyframes retrieval finds most similar,
//! and those nearest the coarse pose when there is one), the query's features matched to
//! theirs, each match a pixel of the query and a world point, and the pose from PnP + RANSAC
//! ([`crate::pnp`]) on all of them pooled, or on groups of candidates solved apart, the best
//! kept ([`RefineConfig::grouped`], for maps whose images look unlike the queries). The
//! refinement is refused, and the coarse pose kept, when too few inliers agree or when the
//! answer lies farther from the coarse pose than its sigma allows: a blank wall, a dark frame
//! or a frame from elsewhere must not throw a tracker off.

use crate::keyframes::{KeyframeMap, gray_of};
use crate::pnp::{self, Correspondence, PnpConfig, Prior};
use crate::{MapError, Result, retrieval};
use features::MatchConfig;
use geom::Pose;
use image::{DynamicImage, GrayImage};
use nalgebra::{Matrix3, Point2, Vector2, Vector3};
use std::time::Instant;

/// A pose from elsewhere (the network, a filter) that refinement starts from and is checked
/// against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coarse {
    /// The coarse camera-to-world pose.
    pub pose: Pose,
    /// Its position uncertainty (one sigma), metres.
    pub sigma_pos_m: f64,
}

/// Settings of [`KeyframeMap::refine`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineConfig {
    /// Keyframes taken from retrieval.
    pub retrieved: usize,
    /// Keyframes taken nearest the coarse pose (facing within 45° of it).
    pub near_coarse: usize,
    /// Keyframes nearest the first PnP pose matched in a second pass, whose correspondences
    /// join the first pass's for a second PnP (0: one pass).
    pub near_refined: usize,
    /// Keyframes nearest each retrieved one that join it in a group of its own, each group
    /// solved alone and the one with the most inliers kept (the keyframes near the coarse pose
    /// are one more group); 0 pools every candidate into one PnP. Pooling is right when
    /// retrieval is right; where it often is not (photos against a map of renders), the wrong
    /// keyframes' chance matches outnumber the right one's inliers, or agree on a wrong pose.
    pub group_neighbours: usize,
    /// Feature matching.
    pub matching: MatchConfig,
    /// PnP + RANSAC.
    pub pnp: PnpConfig,
    /// Fewest inliers of an accepted pose.
    pub min_inliers: usize,
    /// A refined pose farther than this many coarse sigmas from the coarse pose is refused…
    pub gate_sigmas: f64,
    /// …but never closer than this, metres: a network's sigma can be far too small (on the
    /// kitchen's validation blocks the network's truth lay within 3 sigma for 5 frames of 100).
    /// Chosen on those validation blocks (map of the training blocks, coarse poses from the
    /// network of `study real`): refined within (5 cm, 5°) for 14 % of frames with 0.25 m,
    /// 93 % with 0.5 m, 98 % with 0.75 m and no more above it; 0.75 m is the least that
    /// reaches it.
    pub gate_floor_m: f64,
    /// Error of the map itself (depth noise, the mapped poses' own error), one sigma, metres;
    /// added to the PnP covariance, which knows only the pixels' noise. On the kitchen frames
    /// the refined pose of validation frames is about 2 cm from the ground truth while PnP's
    /// own sigma is a millimetre or less.
    pub map_sigma_m: f64,
}

impl Default for RefineConfig {
    /// Three retrieved keyframes and two near the coarse pose, three near the first PnP pose,
    /// 15 inliers, 3 sigmas (≥ 0.75 m), a 2 cm map sigma.
    fn default() -> Self {
        RefineConfig {
            retrieved: 3,
            near_coarse: 2,
            near_refined: 3,
            group_neighbours: 0,
            matching: MatchConfig::default(),
            pnp: PnpConfig::default(),
            min_inliers: 15,
            gate_sigmas: 3.0,
            gate_floor_m: 0.75,
            map_sigma_m: 0.02,
        }
    }
}

impl RefineConfig {
    /// The settings for a map whose images look unlike the queries (renders of a scan against
    /// photos of the room): the `retrieved` most similar keyframes, each with its two nearest,
    /// solved as groups of their own. On the kitchen's 200 held-out photos against a map of
    /// 800 renders of its scan (`study synth-to-real`), 10 such groups refine 66 % of the
    /// photos against 53 % for three pooled keyframes (median 0.062 against 0.091 m), with
    /// the same centimetres on those refined; on a map of the photos themselves both refine
    /// every photo (2.2 against 2.3 cm median), the groups at twice the matching time.
    pub fn grouped(retrieved: usize) -> Self {
        RefineConfig {
            retrieved,
            group_neighbours: 2,
            ..RefineConfig::default()
        }
    }

    /// How far from a coarse pose a refined one may lie, metres.
    pub fn gate_radius(&self, coarse: &Coarse) -> f64 {
        (self.gate_sigmas * coarse.sigma_pos_m).max(self.gate_floor_m)
    }
}

/// Why a query kept its coarse pose.
#[derive(Clone, Debug, PartialEq)]
pub enum Fallback {
    /// The query image has no features (blank, dark, blurred).
    NoFeatures,
    /// Too few of its features match the candidate keyframes.
    TooFewMatches {
        /// Matches found.
        matches: usize,
    },
    /// PnP found no pose with enough inliers.
    TooFewInliers {
        /// Inliers of the best pose.
        inliers: usize,
        /// Inliers needed.
        needed: usize,
    },
    /// The refined pose is farther from the coarse pose than its sigma allows.
    FarFromCoarse {
        /// Distance between the two, metres.
        distance_m: f64,
        /// The largest distance accepted, metres.
        allowed_m: f64,
    },
}

impl std::fmt::Display for Fallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fallback::NoFeatures => write!(f, "no features in the query"),
            Fallback::TooFewMatches { matches } => write!(f, "{matches} matches, too few"),
            Fallback::TooFewInliers { inliers, needed } => {
                write!(f, "{inliers} inliers, {needed} needed")
            }
            Fallback::FarFromCoarse {
                distance_m,
                allowed_m,
            } => write!(
                f,
                "refined pose {distance_m:.2} m from the coarse one, {allowed_m:.2} m allowed"
            ),
        }
    }
}

/// Where a refinement's time went, milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Grey conversion, retrieval descriptor and search, local features.
    pub features_ms: f64,
    /// Matching against the candidates.
    pub matching_ms: f64,
    /// PnP + RANSAC + refinement.
    pub pnp_ms: f64,
}

/// What [`KeyframeMap::refine`] answers.
#[derive(Clone, Debug, PartialEq)]
pub struct Refinement {
    /// The refined pose, or the coarse one (retrieval's when none was given) on a fallback.
    pub pose: Pose,
    /// True when the pose comes from the map's geometry.
    pub refined: bool,
    /// PnP inliers (0 when PnP did not run).
    pub inliers: usize,
    /// Matches PnP was given.
    pub matches: usize,
    /// Covariance of the refined position, m², when refined; on a fallback without a coarse
    /// pose, retrieval's (the spread of the most similar keyframes); `None` on a fallback to the
    /// coarse pose, whose own uncertainty stands.
    pub cov_pos_m2: Option<Matrix3<f64>>,
    /// Covariance of the refined rotation (a small rotation vector), rad², as `cov_pos_m2`.
    pub cov_rot_rad2: Option<Matrix3<f64>>,
    /// Why the coarse pose was kept.
    pub fallback: Option<Fallback>,
    /// The keyframes matched against (indices into the map).
    pub candidates: Vec<usize>,
    /// Where the time went.
    pub timings: Timings,
}

impl KeyframeMap {
    /// Refines the pose of a query image (see the module docs). The query may be of another
    /// resolution than the mapped images (the same camera, scaled); a larger one is reduced to
    /// theirs (by area) before its features are found.
    pub fn refine(
        &self,
        img: &DynamicImage,
        coarse: Option<&Coarse>,
        cfg: &RefineConfig,
    ) -> Result<Refinement> {
        if self.is_empty() {
            return Err(MapError::Input("the map has no keyframes".into()));
        }
        let (mw, mh) = (f64::from(self.camera.width), f64::from(self.camera.height));
        let (qw, qh) = (f64::from(img.width()), f64::from(img.height()));
        if ((qw / qh) / (mw / mh) - 1.0).abs() > 0.01 {
            return Err(MapError::Input(format!(
                "a {}x{} query, but the map's camera is {}x{}: another camera (build a map of \
                 this one's images)",
                img.width(),
                img.height(),
                self.camera.width,
                self.camera.height
            )));
        }
        let t0 = Instant::now();
        // A query larger than the mapped images is matched at their size: ORB's corners pair
        // best between images of one scale, and a map of renders (`study synth-to-real`) is
        // best rendered smaller than the photos (its texture is coarser than their pixels).
        let larger = img.width() > self.camera.width;
        let camera =
            if larger || (img.width(), img.height()) == (self.camera.width, self.camera.height) {
                self.camera
            } else {
                self.camera.resized(img.width(), img.height())
            };
        let thumb = retrieval::descriptor(img)?;
        let hits = self.retrieval.query(&thumb, cfg.retrieved.max(1));
        let mut candidates: Vec<usize> = hits.iter().map(|h| h.index).collect();
        let near_coarse = coarse.map_or_else(Vec::new, |c| {
            self.nearest_keyframes(&c.pose, cfg.near_coarse)
        });
        for &k in &near_coarse {
            if !candidates.contains(&k) {
                candidates.push(k);
            }
        }
        // What a fallback answers: the coarse pose, or retrieval's with its spread as its
        // uncertainty (a fallback must not claim certainty).
        let (fallback_pose, fallback_cov) = match coarse {
            Some(c) => (c.pose, None),
            None => {
                let r = self.retrieval.localize_descriptor(&thumb)?;
                let rot = r.sigma_rot_deg.to_radians();
                (
                    r.pose,
                    Some((
                        Matrix3::identity() * (r.sigma_pos_m * r.sigma_pos_m / 3.0),
                        Matrix3::identity() * (rot * rot / 3.0),
                    )),
                )
            }
        };
        let mut gray = gray_of(img)?;
        if larger {
            let mut small = GrayImage::new(camera.width, camera.height);
            imgproc::view::resize_gray(&gray, &mut small)
                .map_err(|e| MapError::Input(format!("query reduced to the map's size: {e}")))?;
            gray = small;
        }
        let query = features::extract(&gray, &self.extract)
            .map_err(|e| MapError::Input(format!("query features: {e}")))?;
        let mut timings = Timings {
            features_ms: ms_since(t0),
            ..Timings::default()
        };
        let fallback = |why: Fallback, inliers, matches, candidates, timings| Refinement {
            pose: fallback_pose,
            refined: false,
            inliers,
            matches,
            cov_pos_m2: fallback_cov.map(|c| c.0),
            cov_rot_rad2: fallback_cov.map(|c| c.1),
            fallback: Some(why),
            candidates,
            timings,
        };
        if query.is_empty() {
            return Ok(fallback(Fallback::NoFeatures, 0, 0, candidates, timings));
        }
        let t1 = Instant::now();
        // PnP models a pinhole: the query's corners are moved to where an undistorted lens
        // would have put them.
        let pixels: Vec<Vector2<f64>> = query
            .keypoints
            .iter()
            .map(|kp| {
                let p = Point2::new(f64::from(kp.x), f64::from(kp.y));
                if camera.dist.is_zero() {
                    p.coords
                } else {
                    camera.undistort_pixel(&p).coords
                }
            })
            .collect();
        let query = Query {
            features: &query,
            pixels: &pixels,
        };
        let groups = self.candidate_groups(&hits, &near_coarse, &candidates, cfg);
        let GroupAnswer {
            solved,
            mut corr,
            winner,
            matched,
        } = self.solve_groups(&query, &groups, &camera, coarse, cfg, &mut timings);
        timings.matching_ms = ms_since(t1) - timings.pnp_ms;
        candidates = matched.iter().map(|(k, _)| *k).collect();
        let Some(mut solved) = solved else {
            return Ok(fallback(
                Fallback::TooFewMatches {
                    matches: corr.len(),
                },
                0,
                corr.len(),
                candidates,
                timings,
            ));
        };
        if let Solved::Pose(first) = &solved {
            let more: Vec<usize> = self
                .nearest_keyframes(&first.pose.to_pose(), cfg.near_refined)
                .into_iter()
                .filter(|k| !winner.contains(k))
                .collect();
            if !more.is_empty() {
                let t3 = Instant::now();
                for &k in &more {
                    match matched.iter().find(|(m, _)| *m == k) {
                        Some((_, c)) => corr.extend_from_slice(c),
                        None => self.match_keyframe(&query, k, cfg, &mut corr),
                    }
                    if !candidates.contains(&k) {
                        candidates.push(k);
                    }
                }
                timings.matching_ms += ms_since(t3);
                let t4 = Instant::now();
                let first_inliers = first.inliers.len();
                if let Solved::Pose(second) = solve_near(&camera, &corr, coarse, cfg)
                    && second.inliers.len() >= first_inliers
                {
                    solved = Solved::Pose(second);
                }
                timings.pnp_ms += ms_since(t4);
            }
        }
        let sol = match solved {
            Solved::Pose(sol) => sol,
            Solved::Weak { inliers } => {
                return Ok(fallback(
                    Fallback::TooFewInliers {
                        inliers,
                        needed: cfg.min_inliers,
                    },
                    inliers,
                    corr.len(),
                    candidates,
                    timings,
                ));
            }
            Solved::Contradicts {
                distance_m,
                allowed_m,
                inliers,
            } => {
                return Ok(fallback(
                    Fallback::FarFromCoarse {
                        distance_m,
                        allowed_m,
                    },
                    inliers,
                    corr.len(),
                    candidates,
                    timings,
                ));
            }
        };
        let (pose, inliers) = (sol.pose.to_pose(), sol.inliers.len());
        Ok(Refinement {
            pose,
            refined: true,
            inliers,
            matches: corr.len(),
            cov_pos_m2: Some(
                sol.cov_pos_m2 + Matrix3::identity() * (cfg.map_sigma_m * cfg.map_sigma_m / 3.0),
            ),
            cov_rot_rad2: Some(sol.cov_rot_rad2),
            fallback: None,
            candidates,
            timings,
        })
    }

    /// Appends the correspondences of the query's features matched to keyframe `k`'s.
    fn match_keyframe(
        &self,
        query: &Query,
        k: usize,
        cfg: &RefineConfig,
        corr: &mut Vec<Correspondence>,
    ) {
        let kf = &self.features[k];
        let found = query.features;
        for m in features::match_descriptors(&found.descriptors, &kf.descriptors, &cfg.matching) {
            let kp = &found.keypoints[m.query];
            let p = kf.points[m.train];
            corr.push(Correspondence {
                world: Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])),
                pixel: query.pixels[m.query],
                sigma_px: f64::from(self.extract.scale_factor).powi(i32::from(kp.level)),
            });
        }
    }

    /// Matches the query to each group's keyframes (each keyframe once) and solves each group
    /// with enough matches; the best answer ([`Solved::beats`]) wins. Adds PnP's time to
    /// `timings.pnp_ms`.
    fn solve_groups(
        &self,
        query: &Query,
        groups: &[Vec<usize>],
        camera: &geom::Camera,
        coarse: Option<&Coarse>,
        cfg: &RefineConfig,
        timings: &mut Timings,
    ) -> GroupAnswer {
        let mut best = GroupAnswer::default();
        for group in groups {
            let mut corr = Vec::new();
            for &k in group {
                if let Some((_, c)) = best.matched.iter().find(|(m, _)| *m == k) {
                    corr.extend_from_slice(c);
                } else {
                    let mut c = Vec::new();
                    self.match_keyframe(query, k, cfg, &mut c);
                    corr.extend_from_slice(&c);
                    best.matched.push((k, c));
                }
            }
            if corr.len() < cfg.min_inliers.max(4) {
                if best.solved.is_none() && best.corr.len() < corr.len() {
                    best.corr = corr;
                }
                continue;
            }
            let t = Instant::now();
            let this = solve_near(camera, &corr, coarse, cfg);
            timings.pnp_ms += ms_since(t);
            if best.solved.as_ref().is_none_or(|b| this.beats(b)) {
                best.solved = Some(this);
                best.corr = corr;
                best.winner.clone_from(group);
            }
        }
        best
    }

    /// The keyframes matched together in one PnP each: every candidate in one group, or with
    /// [`RefineConfig::group_neighbours`] each retrieved keyframe with its nearest keyframes,
    /// and those nearest the coarse pose (`near_coarse`).
    fn candidate_groups(
        &self,
        hits: &[retrieval::Hit],
        near_coarse: &[usize],
        candidates: &[usize],
        cfg: &RefineConfig,
    ) -> Vec<Vec<usize>> {
        if cfg.group_neighbours == 0 {
            return vec![candidates.to_vec()];
        }
        let mut groups: Vec<Vec<usize>> = hits
            .iter()
            .map(|h| {
                let pose = &self.retrieval.keyframes[h.index].pose;
                let mut group = vec![h.index];
                group.extend(
                    self.nearest_keyframes(pose, cfg.group_neighbours + 1)
                        .into_iter()
                        .filter(|&k| k != h.index),
                );
                group
            })
            .collect();
        if !near_coarse.is_empty() {
            groups.push(near_coarse.to_vec());
        }
        groups
    }

    /// The `k` keyframes nearest a pose that face within 45° of it.
    fn nearest_keyframes(&self, pose: &Pose, k: usize) -> Vec<usize> {
        let mut near: Vec<(f64, usize)> = self
            .retrieval
            .keyframes
            .iter()
            .enumerate()
            .filter(|(_, kf)| geom::metrics::rotation_error_deg(pose, &kf.pose) < 45.0)
            .map(|(i, kf)| (geom::metrics::position_error(pose, &kf.pose), i))
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        near.into_iter().take(k).map(|(_, i)| i).collect()
    }
}

/// A query's features and their undistorted pixels.
struct Query<'a> {
    features: &'a features::Features,
    pixels: &'a [Vector2<f64>],
}

/// The best of [`KeyframeMap::solve_groups`]'s groups.
#[derive(Default)]
struct GroupAnswer {
    /// PnP's answer for the winning group (`None`: no group had enough matches).
    solved: Option<Solved>,
    /// The winning group's correspondences (without a winner, the largest group's).
    corr: Vec<Correspondence>,
    /// The winning group's keyframes.
    winner: Vec<usize>,
    /// Every keyframe matched, in order, with its correspondences.
    matched: Vec<(usize, Vec<Correspondence>)>,
}

/// What PnP made of a query's matches.
enum Solved {
    /// A pose with enough inliers, within the coarse pose's gate when there is one.
    Pose(Box<pnp::PnpSolution>),
    /// Too few inliers anywhere.
    Weak {
        /// Inliers of the best pose.
        inliers: usize,
    },
    /// A pose with many more inliers than any within the gate lies outside it.
    Contradicts {
        distance_m: f64,
        allowed_m: f64,
        inliers: usize,
    },
}

impl Solved {
    /// Whether this answer is better than `other`: a pose over no pose, then more inliers.
    fn beats(&self, other: &Solved) -> bool {
        match (self, other) {
            (Solved::Pose(a), Solved::Pose(b)) => a.inliers.len() > b.inliers.len(),
            (Solved::Pose(_), _) => true,
            (_, Solved::Pose(_)) => false,
            (a, b) => a.inliers() > b.inliers(),
        }
    }

    fn inliers(&self) -> usize {
        match self {
            Solved::Pose(s) => s.inliers.len(),
            Solved::Weak { inliers } | Solved::Contradicts { inliers, .. } => *inliers,
        }
    }
}

/// A pose near the coarse one is taken over a better-fitting one farther away only when it
/// explains at least this share of the other's inliers (a repetition of the building that
/// fits as well), not when the coarse pose is simply wrong.
const NEAR_SHARE: f64 = 0.5;

/// PnP on the matches: free, then, when the free pose lies outside the coarse pose's gate,
/// again among poses within it (see [`crate::pnp::PnpConfig::prior`]).
fn solve_near(
    camera: &geom::Camera,
    corr: &[Correspondence],
    coarse: Option<&Coarse>,
    cfg: &RefineConfig,
) -> Solved {
    let free = pnp::solve(camera, corr, &cfg.pnp);
    let free_inliers = free.as_ref().map_or(0, |s| s.inliers.len());
    let Some(c) = coarse else {
        return match free {
            Some(s) if free_inliers >= cfg.min_inliers => Solved::Pose(Box::new(s)),
            _ => Solved::Weak {
                inliers: free_inliers,
            },
        };
    };
    let centre = Vector3::from(c.pose.position());
    let allowed_m = cfg.gate_radius(c);
    let distance = |s: &pnp::PnpSolution| (s.pose.centre() - centre).norm();
    if let Some(s) = free.as_ref()
        && free_inliers >= cfg.min_inliers
        && distance(s) <= allowed_m
    {
        return Solved::Pose(Box::new(free.expect("checked")));
    }
    let near_cfg = PnpConfig {
        prior: Some(Prior {
            centre,
            radius_m: allowed_m,
        }),
        ..cfg.pnp
    };
    let near = pnp::solve(camera, corr, &near_cfg).filter(|s| distance(s) <= allowed_m);
    let near_inliers = near.as_ref().map_or(0, |s| s.inliers.len());
    if near_inliers >= cfg.min_inliers && near_inliers as f64 >= NEAR_SHARE * free_inliers as f64 {
        return Solved::Pose(Box::new(near.expect("checked")));
    }
    match free {
        Some(s) if free_inliers >= cfg.min_inliers => Solved::Contradicts {
            distance_m: distance(&s),
            allowed_m,
            inliers: free_inliers,
        },
        _ => Solved::Weak {
            inliers: near_inliers.max(free_inliers),
        },
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
