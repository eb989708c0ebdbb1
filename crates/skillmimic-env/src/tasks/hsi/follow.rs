//! `hsi_follow`: path following (TokenHSI supplementary §B.2.1, Eq. 1), as the released
//! `humanoid_traj.py` and its trajectory generator compute it.
//!
//! * Trajectory: `num_vertices` (101) 2-D vertices from the character's start position, one
//!   segment per Δ = L·(1/30 s)/(n − 1) = 0.1 s. Segment k heads at θ_k = Σ_{j≤k} δ_j with δ_0 ~
//!   U(−π, π) and δ_j ~ U(±`turn_rate_max`·Δ), replaced by U(±`sharp_turn_angle`) with
//!   probability `sharp_turn_prob`; its speed starts at U(`speed`) and changes by
//!   U(±`accel_max`·Δ) per segment, clipped into `speed`. Vertex k+1 = vertex k + speed_k·Δ·
//!   (cos θ_k, −sin θ_k) (the released sign; the heading distribution is symmetric).
//! * Point at time t ([`Goal::at`], the released `calc_pos`): the path is spread over n·Δ = 10.1 s
//!   (not the 10 s its vertices span): u = clamp(t / (n·Δ), 0, 1)·(n − 1), linear interpolation
//!   between vertices ⌊u⌋ and ⌈u⌉.
//! * Observation (20): the 10 points at t, t + `point_dt`, …, t + 9·`point_dt` (0.5 s apart as
//!   released, 0.1 s in the supplementary form), t = steps/30 s, relative to the root in its
//!   heading frame, (x, y) each (m).
//! * Reward (Eq. 1): `exp(−2 ‖x_root,2d − x(t)‖²)` after the step (t = steps/30 s); the shared
//!   power penalty is added by [`super::Hsi`].
//! * Ends: path distance `‖x_root,2d − x(t)‖ > fail_distance` (termination); the time limit.
//! * Metrics: `error_m` (that distance); `success` (the released evaluation, ever reached): 1 from
//!   the first step at or after `success_time`·L at which the root is within `success_distance`
//!   of the point at `success_time`·L/30 s (0.98·300 = 294 steps, 9.8 s, 0.3 m).
//! * Info (20): the same 10 points in world coordinates (x, y).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{BoxObject, EnvState, ResetState, Scene};

use super::config::FollowConfig;
use super::geometry::{Local, put, stand_at_origin};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::{HsiConfig, HsiForm};
use crate::vec_env::Env;

/// Waypoints in the observation.
pub const NUM_POINTS: usize = 10;

/// The trajectory of an episode and the success latch.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Goal {
    /// Vertices (world x, y; m), one segment of `dt` s apart.
    pub verts: Vec<[f64; 2]>,
    /// Segment time Δ (s).
    pub dt: f64,
    /// The success condition was met at some step of this episode.
    pub reached: bool,
}

impl Goal {
    /// The goal of the trajectory `verts` under `c`: one segment every
    /// Δ = L·(1/30 s)/(n − 1) (n = `verts.len()` ≥ 2), not yet reached.
    pub fn with_vertices(verts: Vec<[f64; 2]>, c: &FollowConfig) -> Self {
        let dt = c.episode_length as f64 * DT / (verts.len().max(2) - 1) as f64;
        Self { verts, dt, reached: false }
    }
    /// The trajectory point at time `t` (s): the released `calc_pos` (see the module doc), whose
    /// path spans `verts.len()`·Δ s.
    pub fn at(&self, t: f64) -> [f64; 2] {
        let n = self.verts.len();
        if n < 2 {
            return self.verts.first().copied().unwrap_or([0.0, 0.0]);
        }
        let phase = (t / (n as f64 * self.dt)).clamp(0.0, 1.0);
        let u = phase * (n - 1) as f64;
        let (k0, k1) = (u.floor() as usize, u.ceil() as usize);
        let f = u - k0 as f64;
        let (a, b) = (self.verts[k0], self.verts[k1]);
        [(1.0 - f) * a[0] + f * b[0], (1.0 - f) * a[1] + f * b[1]]
    }
}

/// Draw the released generator's trajectory from `start` (see the module doc).
pub fn draw_trajectory(c: &FollowConfig, start: [f64; 2], rng: &mut ChaCha8Rng, goal: &mut Goal) {
    use std::f64::consts::PI;
    let segments = c.num_vertices - 1;
    let mut verts = std::mem::take(&mut goal.verts);
    verts.clear();
    verts.resize(c.num_vertices, start);
    *goal = Goal::with_vertices(verts, c);
    let dt = goal.dt;
    let uniform = |rng: &mut ChaCha8Rng, half: f64| half * (2.0 * rng.random::<f64>() - 1.0);
    let (lo, hi) = (c.speed[0], c.speed[1]);
    let mut p = start;
    let (mut heading, mut speed) = (0.0, 0.0);
    for k in 0..segments {
        let turn = if k == 0 {
            uniform(rng, PI)
        } else if rng.random::<f64>() < c.sharp_turn_prob {
            uniform(rng, c.sharp_turn_angle)
        } else {
            uniform(rng, c.turn_rate_max * dt)
        };
        heading += turn;
        speed = if k == 0 {
            lo + (hi - lo) * rng.random::<f64>()
        } else {
            (speed + uniform(rng, c.accel_max * dt)).clamp(lo, hi)
        };
        p = [p[0] + speed * dt * heading.cos(), p[1] - speed * dt * heading.sin()];
        goal.verts[k + 1] = p;
    }
}

/// Eq. 1: the path reward for the root at `root` and the current point `target` (world, m).
pub fn path_reward(root: [f64; 3], target: [f64; 2]) -> f64 {
    let (dx, dy) = (target[0] - root[0], target[1] - root[1]);
    (-2.0 * (dx * dx + dy * dy)).exp()
}

/// The path-following task.
pub struct Follow {
    spec: TaskSpec,
    cfg: FollowConfig,
    random_heading: bool,
    /// Time between observed waypoints (s), from `point_dt` and `env.hsi.form`.
    pub point_dt: f64,
}

impl Follow {
    pub fn new(cfg: &FollowConfig, random_heading: bool, form: HsiForm) -> Self {
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
        let point_dt = match form {
            HsiForm::Released => cfg.point_dt,
            HsiForm::Supplementary => 0.1,
        };
        Self { spec, cfg: cfg.clone(), random_heading, point_dt }
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
        draw_trajectory(&self.cfg, [reset.root_pos[0], reset.root_pos[1]], rng, goal);
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, steps: usize, out: &mut [f32]) {
        let l = Local::of(st);
        let t = steps as f64 * DT;
        for k in 0..NUM_POINTS {
            let w = goal.at(t + k as f64 * self.point_dt);
            let p = l.point([w[0], w[1], l.root[2]]);
            put(out, 2 * k, &p[..2]);
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let c = &self.cfg;
        let root = ctx.st.pos(0);
        let w = goal.at(ctx.steps as f64 * DT);
        let d = ((root[0] - w[0]).powi(2) + (root[1] - w[1]).powi(2)).sqrt();
        out.terms[0] = path_reward(root, w) as f32;
        out.fail = d > c.fail_distance;
        let judged = c.success_time * c.episode_length as f64;
        if ctx.steps as f64 >= judged {
            let end = goal.at(judged * DT);
            goal.reached |= (root[0] - end[0]).hypot(root[1] - end[1]) <= c.success_distance;
        }
        out.metrics[0] = d as f32;
        out.metrics[1] = f32::from(goal.reached);
    }
    fn info(&self, goal: &Goal, steps: usize, out: &mut [f32]) {
        let t = steps as f64 * DT;
        for k in 0..NUM_POINTS {
            put(out, 2 * k, &goal.at(t + k as f64 * self.point_dt));
        }
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Follow::new(&h.follow, h.random_heading, h.form);
    super::build_env(task, cfg, 1, cfg.table::<HsiConfig>().follow.episode_length)
}
