//! `hsi_climb`: climbing onto a procedural platform (TokenHSI supplementary §B.2.3, Eqs. 5–8), as
//! the released `humanoid_climb.py` does it.
//!
//! * Object (one per compiled variant): a box platform from the floor to a height in `height`,
//!   sides in `size`; placed per episode like the sit task's seat ([`Goal::place`]), U(1, 10) m
//!   from the character as released.
//! * Target: 0.94 m (`target_above_top`) above the centre of the platform's top.
//! * Observation (27), heading frame relative to the root: target (3) | the 8 bounding-box
//!   corners (24, [`super::geometry::corners`] order).
//! * Reward, released (default): with d the 2-D root–object distance and the gate
//!   r = ½‖footprint diagonal‖ + `gate_margin` (0.3 m), `0.2 r_far + 0.5 r_near + 0.3 r_foot`:
//!   `r_far = exp(−2 (1.5 − d*·v_root,2d)²)`, 0 when `d*·v ≤ 0`, 1 when d ≤ r;
//!   `r_near = exp(−10 ‖x_tar − x_root‖²)`; `r_foot = exp(−50 ((z_tar − 0.94) − z̄_feet)²)` when
//!   d ≤ r, else 0 (z̄_feet the mean height of the two foot bodies' frames). Plus, when d ≤ 1.5 m
//!   (`penalty_radius`), a speed penalty `−1.0 (1 − exp(−2 (thr − max(‖v_root‖, thr))²))` (3-D
//!   speed), thr = 1.3 m/s when d ≤ r, else 1.5 m/s.
//!   Supplementary form (Eqs. 5–8): `0.5 r_near + 0.2 r_far` when d > 0.7 m, else
//!   `0.5 r_near + 0.2 + 0.3 r_foot`; no sign mask, no penalty.
//! * Ends: the released climb file's training fall rule (a low body alone, from the first step);
//!   interaction early termination and success as the sit task's ([`Goal::finish_step`]); time
//!   limit. Info: as the sit task's.

use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::FEET;
use skillmimic_core::math::{heading, wrap_angle};
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ResetState, Scene};

use super::config::ClimbConfig;
use super::geometry::{
    Local, dir2d, dist_sq, dist2d, draw, excess_penalty, put, speed, speed_reward,
    speed_reward_towards, stand_at_origin,
};
use super::sit::{Goal, goal_info_names};
use super::{Ctx, DT, FallRule, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::{HsiConfig, HsiForm};
use crate::vec_env::Env;

/// The released close gate of an object whose bounding box is `[lo, hi]` (object frame, m): half
/// the diagonal of its footprint plus `margin` (m).
pub fn gate_radius(lo: [f64; 3], hi: [f64; 3], margin: f64) -> f64 {
    0.5 * (hi[0] - lo[0]).hypot(hi[1] - lo[1]) + margin
}

/// The climbing task.
pub struct Climb {
    spec: TaskSpec,
    cfg: ClimbConfig,
    random_heading: bool,
    form: HsiForm,
}

impl Climb {
    pub fn new(cfg: &ClimbConfig, random_heading: bool, form: HsiForm) -> Self {
        let spec = hsi_spec(
            "hsi_climb",
            27,
            cfg.episode_length,
            crate::task::names(&["near", "far", "foot", "speed", "climb"]),
            goal_info_names(),
        );
        Self { spec, cfg: cfg.clone(), random_heading, form }
    }
}

impl Rule for Climb {
    type Goal = Goal;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<BoxObject> {
        let c = &self.cfg;
        let h = draw(rng, c.height);
        let (sx, sy) = (draw(rng, c.size), draw(rng, c.size));
        vec![BoxObject {
            name: "platform".into(),
            mass: None,
            boxes: vec![ObjectBox {
                center: [0.0, 0.0, 0.5 * h],
                half: [0.5 * sx, 0.5 * sy, 0.5 * h],
            }],
            rgba: [0.45, 0.45, 0.5, 1.0],
        }]
    }
    fn plan(&self, scene: &Scene, rng: &mut ChaCha8Rng, reset: &mut ResetState, goal: &mut Goal) {
        stand_at_origin(rng, self.random_heading, reset);
        *goal = Goal::place(scene, rng, self.cfg.distance, self.cfg.target_above_top, 0, reset);
        goal.gate = gate_radius(goal.lo, goal.hi, self.cfg.gate_margin);
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, _steps: usize, out: &mut [f32]) {
        let l = Local::of(st);
        let mut at = put(out, 0, &l.point(goal.target));
        for c in goal.corners() {
            at = put(out, at, &l.point(c));
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let c = &self.cfg;
        let root = ctx.st.pos(0);
        let near = (-10.0 * dist_sq(goal.target, root)).exp();
        let feet = 0.5 * (ctx.st.pos(FEET[0])[2] + ctx.st.pos(FEET[1])[2]);
        let foot = (-50.0 * ((goal.target[2] - c.target_above_top) - feet).powi(2)).exp();
        let (far, foot, speed_pen, total) = if self.form == HsiForm::Released {
            let obj = goal.centre();
            let d = dist2d(obj, root);
            let inside = d <= goal.gate;
            let far = if inside {
                1.0
            } else {
                speed_reward_towards(2.0, 1.5, dir2d(root, obj), root, ctx.prev_root, DT)
            };
            let foot = if inside { foot } else { 0.0 };
            let speed_pen = if d <= c.penalty_radius {
                let thr = if inside {
                    c.speed_penalty_threshold
                } else {
                    c.speed_penalty_threshold_approach
                };
                excess_penalty(
                    c.speed_penalty_coefficient,
                    2.0,
                    thr,
                    speed(root, ctx.prev_root, DT),
                )
            } else {
                0.0
            };
            (far, foot, speed_pen, 0.2 * far + 0.5 * near + 0.3 * foot + speed_pen)
        } else {
            let far = speed_reward(2.0, 1.5, dir2d(root, goal.obj_pos), root, ctx.prev_root, DT);
            let close = dist2d(goal.obj_pos, root) <= 0.7;
            let total = if close { 0.5 * near + 0.2 + 0.3 * foot } else { 0.5 * near + 0.2 * far };
            (far, foot, 0.0, total)
        };
        for (k, v) in [near, far, foot, speed_pen, total].into_iter().enumerate() {
            out.terms[k] = v as f32;
        }
        goal.finish_step(root, c.success_distance, c.iet_steps, out);
    }
    fn info(&self, goal: &Goal, _steps: usize, out: &mut [f32]) {
        goal.write_info(out);
    }
    fn fall_rule(&self) -> FallRule {
        FallRule::Low { from_step: 1 }
    }
    /// The face of the platform that looks towards the character's start (the origin, where the
    /// rule stands it): built-in step-ups (`builtin:climb`) start where they have the character
    /// relative to that face.
    fn anchor(&self, goal: &Goal) -> Option<super::reference_init::Anchor> {
        Some(step_face(goal))
    }
}

/// The anchor of the platform face through which the ray from the platform's centre towards the
/// origin leaves its footprint: the centre of that face's top edge and the yaw pointing across
/// it into the platform.
pub fn step_face(goal: &Goal) -> super::reference_init::Anchor {
    let (lo, hi) = (goal.lo, goal.hi);
    let c = goal.centre();
    let d = goal.obj_quat.conj().rotate([-c[0], -c[1], 0.0]);
    let (hx, hy) = (0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1]));
    let (mx, my) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
    // (local edge point, yaw of the inward direction in the platform's frame)
    let (local, turn) = if d[0].abs() * hy >= d[1].abs() * hx {
        if d[0] < 0.0 {
            ([lo[0], my, hi[2]], 0.0)
        } else {
            ([hi[0], my, hi[2]], std::f64::consts::PI)
        }
    } else if d[1] < 0.0 {
        ([mx, lo[1], hi[2]], std::f64::consts::FRAC_PI_2)
    } else {
        ([mx, hi[1], hi[2]], -std::f64::consts::FRAC_PI_2)
    };
    let r = goal.obj_quat.rotate(local);
    let p = goal.obj_pos;
    super::reference_init::Anchor::Step {
        edge: [p[0] + r[0], p[1] + r[1], p[2] + r[2]],
        yaw: wrap_angle(heading(goal.obj_quat) + turn),
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Climb::new(&h.climb, h.random_heading, h.form);
    super::build_env(task, cfg, h.object_variants, h.climb.episode_length)
}
