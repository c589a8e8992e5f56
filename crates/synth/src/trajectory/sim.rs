//! The walker: moves along a [`Path`] at 100 Hz with a smoothly varying pace, a rate-limited
//! heading, pauses and head bob, and is sampled at the frame rate.

use super::path::Path;
use super::route::RouteStyle;
use super::{Graph, PosedFrame, Rig, WalkConfig, direction_of, rng, stream, uniform};
use crate::error::Result;
use crate::world::{PlaceKind, World};
use geom::rotation::wrap_angle;
use geom::{Pose, Pose3};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::Rng;
use std::f64::consts::{PI, TAU};

/// Simulation step, seconds (at most; a whole number of steps fits in a frame).
const DT_MAX: f64 = 0.01;
/// Acceleration from a standstill, m/s².
const A_ACC: f64 = 0.6;
/// Planned braking for corners and dead ends, m/s² (twice that is available to follow the plan).
const A_DEC: f64 = 0.8;
/// Lateral acceleration a walker accepts in a corner, m/s².
const A_LAT: f64 = 1.0;
/// Gain from heading error to yaw rate, 1/s.
const K_YAW: f64 = 2.5;
/// Largest yaw acceleration, rad/s²: turns start and end smoothly.
const ALPHA_MAX: f64 = 4.0;
/// Heading error (to the look-ahead target) up to which the walker keeps full speed, and from
/// which it stands still to turn.
const ALIGN_FULL: f64 = 25.0 * PI / 180.0;
const ALIGN_STOP: f64 = 70.0 * PI / 180.0;
/// Arc length over which the lateral drift fades in after a turn, metres.
const TAPER_M: f64 = 2.0;
/// Head bob settings are relative to this default amplitude.
const BOB_REF: f64 = 0.015;

/// A pause: standing still and (forward rig) glancing around.
struct Pause {
    until: f64,
    base_yaw: f64,
    glance_yaw: f64,
    glance_pitch: f64,
    next_glance: f64,
}

/// What stays fixed for one walker: the person (or robot) and their habits.
struct Walker {
    forward: bool,
    height: f64,
    bob: f64,
    speed: [f64; 2],
    pace_base: f64,
    pace_period: [f64; 2],
    pace_phase: [f64; 2],
    lateral: f64,
    lateral_wave: [f64; 2],
    lateral_phase: [f64; 2],
    lookahead: f64,
    omega: f64,
    base_pitch: f64,
    roll_bias: f64,
}

impl Walker {
    fn new(cfg: &WalkConfig, r: &mut impl Rng) -> Walker {
        let forward = matches!(cfg.rig, Rig::Forward { .. });
        let bob = if forward {
            f64::from(cfg.head_bob_m)
        } else {
            0.0
        };
        let [lo, hi] = cfg.rig.height_range().map(f64::from);
        // Keep the bob's peaks (at most 1.25 × amplitude) inside the height range.
        let margin = 1.25 * bob;
        let height = if hi - lo > 2.0 * margin {
            uniform(r, lo + margin, hi - margin)
        } else {
            (lo + hi) / 2.0
        };
        Walker {
            forward,
            height,
            bob,
            speed: cfg.speed_mps.map(f64::from),
            pace_base: uniform(r, 0.35, 0.8),
            pace_period: [uniform(r, 25.0, 45.0), uniform(r, 7.0, 13.0)],
            pace_phase: [uniform(r, 0.0, TAU), uniform(r, 0.0, TAU)],
            lateral: f64::from(cfg.lateral_m).min(0.3),
            lateral_wave: [uniform(r, 6.0, 10.0), uniform(r, 13.0, 21.0)],
            lateral_phase: [uniform(r, 0.0, TAU), uniform(r, 0.0, TAU)],
            lookahead: if forward { 1.5 } else { 0.6 },
            omega: f64::from(cfg.turn_rate_deg_s).to_radians(),
            base_pitch: if forward {
                uniform(r, -6.0, 1.0).to_radians()
            } else {
                0.0
            },
            roll_bias: if forward {
                uniform(r, -1.5, 1.5).to_radians()
            } else {
                0.0
            },
        }
    }

    /// The pace the walker wants at time `t`, m/s: smooth, within the speed range.
    fn desired_speed(&self, t: f64) -> f64 {
        let u = self.pace_base
            + 0.22 * (TAU * t / self.pace_period[0] + self.pace_phase[0]).sin()
            + 0.12 * (TAU * t / self.pace_period[1] + self.pace_phase[1]).sin();
        self.speed[0] + (self.speed[1] - self.speed[0]) * u.clamp(0.0, 1.0)
    }

    /// The point on the floor at arc length `s`: the path plus the lateral drift, which fades
    /// out near turns so that the drift's direction never jumps.
    fn ground(&self, path: &Path, s: f64) -> (Vector3<f64>, Vector3<f64>, usize) {
        let pp = path.at(s);
        let wave = 0.6 * (TAU * s / self.lateral_wave[0] + self.lateral_phase[0]).sin()
            + 0.4 * (TAU * s / self.lateral_wave[1] + self.lateral_phase[1]).sin();
        let x = (path.distance_to_turn(s) / TAPER_M).clamp(0.0, 1.0);
        let taper = x * x * (3.0 - 2.0 * x);
        let t = pp.tangent;
        let txy = t.xy().norm();
        let left = if txy > 1e-6 {
            Vector3::new(-t.y / txy, t.x / txy, 0.0)
        } else {
            Vector3::zeros()
        };
        (pp.p + left * (self.lateral * wave * taper), t, pp.region)
    }
}

/// Walks `frames` frames from node `start`, times starting at `t0`.
pub(crate) fn simulate(
    world: &World,
    graph: &Graph<'_>,
    cfg: &WalkConfig,
    frames: usize,
    seed: u64,
    start: usize,
    t0: f64,
) -> Result<Vec<PosedFrame>> {
    let mut wr = rng(seed, stream::WALKER);
    let w = Walker::new(cfg, &mut wr);
    let duration = frames as f64 / cfg.fps;
    let length = duration * w.speed[1] * 1.05 + 2.0 * w.lookahead + 20.0;
    let style = RouteStyle {
        room_probability: f64::from(cfg.room_probability),
        storey_dwell_m: Some(cfg.storey_dwell_m.map(f64::from)),
    };
    let route = graph.route(start, length, &style, &mut rng(seed, stream::ROUTE));
    let points: Vec<(Vector3<f64>, usize)> = route
        .iter()
        .map(|&i| (graph.pos(i), graph.region(i)))
        .collect();
    let path = Path::new(&points, w.omega, A_LAT);

    let substeps = ((1.0 / cfg.fps) / DT_MAX).ceil().max(1.0) as usize;
    let dt = 1.0 / (cfg.fps * substeps as f64);
    let pause_rate = f64::from(cfg.pause_probability);
    let pause_len = cfg.pause_s.map(f64::from);

    let mut s = 0.0;
    let mut t = 0.0;
    let mut v = w.desired_speed(0.0).min(path.speed_limit(0.0, A_DEC, 4.0));
    let mut yaw = {
        let (g0, tan, _) = w.ground(&path, 0.0);
        let (g1, _, _) = w.ground(&path, w.lookahead.min(path.total));
        let d = g1 - g0;
        if d.xy().norm() > 1e-3 {
            d.y.atan2(d.x)
        } else {
            tan.y.atan2(tan.x)
        }
    };
    let mut target_yaw = yaw;
    let mut yaw_rate = 0.0;
    let mut pitch = w.base_pitch;
    let mut phase = uniform(&mut wr, 0.0, TAU);
    let mut pause: Option<Pause> = None;
    let mut calm_until = 3.0;

    let mut out = Vec::with_capacity(frames);
    for i in 0..frames {
        let state = Kinematics {
            s,
            v,
            yaw,
            pitch,
            phase,
        };
        out.push(frame(world, &w, &path, &state, t0 + i as f64 / cfg.fps)?);
        for _ in 0..substeps {
            t += dt;
            // Pauses.
            if let Some(p) = &mut pause {
                if t >= p.until {
                    pause = None;
                    calm_until = t + 3.0;
                } else if w.forward && t >= p.next_glance {
                    p.glance_yaw = if wr.random::<f64>() < 0.3 {
                        0.0
                    } else {
                        let side = if wr.random::<bool>() { 1.0 } else { -1.0 };
                        side * uniform(&mut wr, 20.0, 75.0).to_radians()
                    };
                    p.glance_pitch = uniform(&mut wr, -8.0, 10.0).to_radians();
                    p.next_glance = t + uniform(&mut wr, 0.8, 2.0);
                }
            } else if v > 0.3 && t > calm_until && wr.random::<f64>() < pause_rate * dt {
                pause = Some(start_pause(t, yaw, pause_len, &mut wr));
            }

            let (here, tangent, _) = w.ground(&path, s);
            // Where to look: a point ahead on the path, never past the next dead end (turning
            // round starts only once there).
            match &pause {
                Some(p) => target_yaw = wrap_angle(p.base_yaw + p.glance_yaw),
                None => {
                    let stop = path.next_uturn(s).map_or(path.total, |u| u.0);
                    let ahead = (s + w.lookahead).min(stop).min(path.total);
                    let d = w.ground(&path, ahead).0 - here;
                    if d.xy().norm() > 0.25 {
                        target_yaw = d.y.atan2(d.x);
                    }
                }
            }
            let err = wrap_angle(target_yaw - yaw);
            let want = (K_YAW * err).clamp(-w.omega, w.omega);
            yaw_rate += (want - yaw_rate).clamp(-ALPHA_MAX * dt, ALPHA_MAX * dt);
            yaw = wrap_angle(yaw + yaw_rate * dt);

            // Pitch: level-ish, a little towards the slope on stairs, free while glancing.
            let pitch_target = match &pause {
                Some(p) => p.glance_pitch,
                None => {
                    let slope = tangent.z.atan2(tangent.xy().norm());
                    w.base_pitch + (0.5 * slope).clamp(-8f64.to_radians(), 8f64.to_radians())
                }
            }
            .clamp(-12f64.to_radians(), 12f64.to_radians());
            if w.forward {
                pitch += (pitch_target - pitch) * (1.0 - (-dt / 0.6).exp());
            }

            // Speed: the pace, capped by what lies ahead, and only while facing where the walk
            // goes next (the look-ahead target, not the tangent here: facing into a corner
            // before reaching it is what people do, and the target only moves when the walker
            // does, so waiting to face it can never stall).
            let v_target = if pause.is_some() {
                0.0
            } else {
                let align = wrap_angle(target_yaw - yaw).abs();
                let f = ((align.cos() - ALIGN_STOP.cos()) / (ALIGN_FULL.cos() - ALIGN_STOP.cos()))
                    .clamp(0.0, 1.0);
                w.desired_speed(t).min(path.speed_limit(s, A_DEC, 4.0)) * f
            };
            v = if v < v_target {
                (v + A_ACC * dt).min(v_target)
            } else {
                (v - 2.0 * A_DEC * dt).max(v_target)
            };

            // Move, stopping exactly at a dead end.
            let mut s_new = s + v * dt;
            if let Some((s_u, region)) = path.next_uturn(s)
                && (s_new >= s_u || s_u - s_new < 0.02)
            {
                s_new = s_u;
                v = 0.0;
                let in_room = world
                    .regions
                    .get(region)
                    .is_some_and(|r| r.place.kind == PlaceKind::Room);
                if w.forward && in_room && pause.is_none() && wr.random::<f64>() < 0.6 {
                    pause = Some(start_pause(t, yaw, pause_len, &mut wr));
                }
            }
            if s_new >= path.total {
                s_new = path.total;
                v = 0.0;
            }
            s = s_new;
            let step_hz = 1.0 + 0.7 * v;
            phase = (phase + PI * step_hz * dt) % TAU;
        }
    }
    Ok(out)
}

fn start_pause(t: f64, yaw: f64, len: [f64; 2], r: &mut impl Rng) -> Pause {
    Pause {
        until: t + uniform(r, len[0], len[1]),
        base_yaw: yaw,
        glance_yaw: 0.0,
        glance_pitch: 0.0,
        next_glance: t + uniform(r, 0.3, 1.0),
    }
}

/// The walker's state at a frame.
#[derive(Clone, Copy)]
struct Kinematics {
    /// Arc length along the path, metres.
    s: f64,
    /// Speed, m/s.
    v: f64,
    /// Heading (yaw), radians.
    yaw: f64,
    /// Pitch before head bob, radians (positive looks up).
    pitch: f64,
    /// Stride phase, radians.
    phase: f64,
}

/// The labelled pose of the walker's state. `phase` is the stride phase: the head rises and
/// falls twice per stride (once per step) and sways and rolls once.
fn frame(world: &World, w: &Walker, path: &Path, k: &Kinematics, t: f64) -> Result<PosedFrame> {
    let Kinematics {
        s,
        v,
        yaw,
        pitch,
        phase,
    } = *k;
    let (ground, _, region) = w.ground(path, s);
    let pose = if w.forward {
        let a = (v / 1.2).clamp(0.0, 1.25) * (w.bob / BOB_REF);
        let z_bob = w.bob * (v / 1.2).clamp(0.0, 1.25) * (2.0 * phase).cos();
        let sway = 0.01 * a * phase.sin();
        let roll = w.roll_bias + 1f64.to_radians() * a * phase.sin();
        let pitch = pitch + 0.4f64.to_radians() * a * (2.0 * phase + 0.5).cos();
        let right = Vector3::new(yaw.sin(), -yaw.cos(), 0.0);
        let c = ground + right * sway + Vector3::z() * (w.height + z_bob);
        let level = Pose3 {
            x: c.x,
            y: c.y,
            heading: yaw,
        }
        .to_pose(geom::Mount::Forward, c.z);
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch)
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
        Pose::new(level.rotation * tilt, level.translation)
    } else {
        Pose3 {
            x: ground.x,
            y: ground.y,
            heading: yaw,
        }
        .to_pose(geom::Mount::Ceiling, ground.z + w.height)
    };
    if !pose.translation.iter().all(|c| c.is_finite()) {
        return Err(super::config(format!(
            "walk produced a non-finite camera position at t = {t:.2} s"
        )));
    }
    let mount = if w.forward {
        geom::Mount::Forward
    } else {
        geom::Mount::Ceiling
    };
    let c32 = Point3::from(pose.translation.cast::<f32>());
    let place = world
        .place_at(&c32)
        .or_else(|| world.regions.get(region).map(|r| &r.place))
        .cloned();
    let direction = place
        .as_ref()
        .and_then(|p| direction_of(p, pose.to_pose3(mount).heading));
    Ok(PosedFrame {
        t,
        pose,
        place,
        direction,
    })
}
