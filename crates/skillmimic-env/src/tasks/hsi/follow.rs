//! `hsi_follow`: path following (TokenHSI supplementary §B.2.1, Eq. 1; Trace&Pace's trajectories).
//!
//! * Trajectory: 2-D vertices every `vertex_dt` s from the character's start position; speed
//!   and heading random walks (speed in `speed`, change ≤ `accel_max`·dt; heading change ≤
//!   `turn_rate_max`·dt, plus a jump of U(−π, π) with probability `sharp_turn_prob` per vertex);
//!   the first heading is uniformly random. Points between vertices are linear interpolations,
//!   points past the end hold the last vertex.
//! * Observation (20): the 10 waypoints x(t), x(t + 0.1), …, x(t + 0.9) at t = steps/30 s, relative
//!   to the root in its heading frame, (x, y) each (m).
//! * Reward (Eq. 1): `exp(−2 ‖x_root,2d − x(t)‖²)` after the step (t = steps/30 s).
//! * Ends: path distance `‖x_root,2d − x(t)‖ > fail_distance` (termination); time limit.
//! * Metrics: `error_m` (that distance), `success` (the released code's rule: within
//!   `success_distance` for at least `success_fraction` of the steps so far, and neither the
//!   path distance nor a character fall ended the episode — its value at the episode's end is the
//!   success of the episode).
//! * Info (20): the same 10 waypoints in world coordinates (x, y).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{BoxObject, EnvState, ResetState, Scene};

use super::config::FollowConfig;
use super::geometry::{Local, put, stand_at_origin};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::HsiConfig;
use crate::vec_env::Env;

/// Waypoints in the observation.
pub const NUM_POINTS: usize = 10;
/// Time between observed waypoints (s).
pub const POINT_DT: f64 = 0.1;

/// The trajectory of an episode and the success bookkeeping.
#[derive(Clone, Debug, Default)]
pub struct Goal {
    /// Vertices (world x, y; m), `dt` apart.
    pub verts: Vec<[f64; 2]>,
    pub dt: f64,
    within: usize,
    failed: bool,
}

impl Goal {
    /// The trajectory point at time `t` (s).
    pub fn at(&self, t: f64) -> [f64; 2] {
        let u = (t / self.dt).max(0.0);
        let k = u.floor() as usize;
        if k + 1 >= self.verts.len() {
            return *self.verts.last().unwrap_or(&[0.0, 0.0]);
        }
        let f = u - k as f64;
        let (a, b) = (self.verts[k], self.verts[k + 1]);
        [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
    }
}

/// The path-following task.
pub struct Follow {
    spec: TaskSpec,
    cfg: FollowConfig,
    random_heading: bool,
}

impl Follow {
    pub fn new(cfg: &FollowConfig, random_heading: bool) -> Self {
        let info_names = (0..NUM_POINTS)
            .flat_map(|k| [format!("waypoint{k}_x"), format!("waypoint{k}_y")])
            .collect();
        let spec = hsi_spec(
            "hsi_follow",
            2 * NUM_POINTS,
            cfg.episode_length,
            crate::task::names(&["follow"]),
            info_names,
        );
        Self { spec, cfg: cfg.clone(), random_heading }
    }
}

impl Rule for Follow {
    type Goal = Goal;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, _rng: &mut ChaCha8Rng) -> Vec<BoxObject> {
        Vec::new()
    }
    fn plan(&self, _scene: &Scene, rng: &mut ChaCha8Rng, reset: &mut ResetState, goal: &mut Goal) {
        stand_at_origin(rng, self.random_heading, reset);
        let c = &self.cfg;
        let dt = c.vertex_dt;
        let horizon = c.episode_length as f64 * DT + NUM_POINTS as f64 * POINT_DT;
        let n = (horizon / dt).ceil() as usize + 2;
        let (lo, hi) = (c.speed[0], c.speed[1]);
        let mut speed = if hi > lo { rng.random_range(lo..hi) } else { lo };
        let mut yaw = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let mut p = [reset.root_pos[0], reset.root_pos[1]];
        goal.verts.clear();
        goal.verts.push(p);
        for _ in 1..n {
            let ds = c.accel_max * dt;
            speed = (speed + rng.random_range(-ds..=ds)).clamp(lo, hi);
            let dw = c.turn_rate_max * dt;
            yaw += rng.random_range(-dw..=dw);
            if rng.random::<f64>() < c.sharp_turn_prob {
                yaw += rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            }
            p = [p[0] + speed * dt * yaw.cos(), p[1] + speed * dt * yaw.sin()];
            goal.verts.push(p);
        }
        goal.dt = dt;
        goal.within = 0;
        goal.failed = false;
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, steps: usize, out: &mut [f32]) {
        let l = Local::of(st);
        let t = steps as f64 * DT;
        for k in 0..NUM_POINTS {
            let w = goal.at(t + k as f64 * POINT_DT);
            let p = l.point([w[0], w[1], l.root[2]]);
            put(out, 2 * k, &p[..2]);
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let root = ctx.st.pos(0);
        let w = goal.at(ctx.steps as f64 * DT);
        let d = ((root[0] - w[0]).powi(2) + (root[1] - w[1]).powi(2)).sqrt();
        out.terms[0] = (-2.0 * d * d).exp() as f32;
        out.fail = d > self.cfg.fail_distance;
        goal.failed |= out.fail || ctx.fallen;
        if d <= self.cfg.success_distance {
            goal.within += 1;
        }
        out.metrics[0] = d as f32;
        out.metrics[1] = f32::from(
            !goal.failed && goal.within as f64 >= self.cfg.success_fraction * ctx.steps as f64,
        );
    }
    fn info(&self, goal: &Goal, steps: usize, out: &mut [f32]) {
        let t = steps as f64 * DT;
        for k in 0..NUM_POINTS {
            put(out, 2 * k, &goal.at(t + k as f64 * POINT_DT));
        }
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let task =
        Follow::new(&cfg.table::<HsiConfig>().follow, cfg.table::<HsiConfig>().random_heading);
    super::build_env(task, cfg, 1, cfg.table::<HsiConfig>().follow.episode_length)
}
