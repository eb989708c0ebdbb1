//! `hsi_climb`: climbing onto a procedural platform (TokenHSI supplementary §B.2.3, Eqs. 5–8).
//!
//! * Object (one per compiled variant): a box platform from the floor to a height in `height`,
//!   sides in `size`; placed per episode like the sit task's seat ([`Goal::place`]).
//! * Target: 0.94 m (`target_above_top`) above the centre of the platform's top.
//! * Observation (27), heading frame relative to the root: target (3) | the 8 bounding-box
//!   corners (24).
//! * Reward (Eqs. 5–8): `0.5 r_near + 0.2 r_far` when the 2-D root–object distance exceeds 0.7 m,
//!   else `0.5 r_near + 0.2 + 0.3 r_foot`; `r_far = exp(−2 (1.5 − d*·v_root,2d)²)`,
//!   `r_near = exp(−10 ‖x_tar − x_root‖²)`, `r_foot = exp(−50 ((z_tar − 0.94) − z̄_feet)²)` with
//!   z̄_feet the mean height of the two foot bodies' frames and 0.94 the configured offset.
//! * Ends, metrics and info: as the sit task's.

use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::FEET;
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ResetState, Scene};

use super::config::ClimbConfig;
use super::geometry::{Local, dir2d, dist_sq, dist2d, draw, put, speed_reward, stand_at_origin};
use super::sit::{Goal, goal_info_names};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::HsiConfig;
use crate::vec_env::Env;

/// The climbing task.
pub struct Climb {
    spec: TaskSpec,
    cfg: ClimbConfig,
    random_heading: bool,
}

impl Climb {
    pub fn new(cfg: &ClimbConfig, random_heading: bool) -> Self {
        let spec = hsi_spec(
            "hsi_climb",
            27,
            cfg.episode_length,
            crate::task::names(&["near", "far", "foot", "climb"]),
            goal_info_names(),
        );
        Self { spec, cfg: cfg.clone(), random_heading }
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
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, _steps: usize, out: &mut [f32]) {
        let l = Local::of(st);
        let mut at = put(out, 0, &l.point(goal.target));
        for c in goal.corners() {
            at = put(out, at, &l.point(c));
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let root = ctx.st.pos(0);
        let near = (-10.0 * dist_sq(goal.target, root)).exp();
        let far = speed_reward(2.0, 1.5, dir2d(root, goal.obj_pos), root, ctx.prev_root, DT);
        let feet = 0.5 * (ctx.st.pos(FEET[0])[2] + ctx.st.pos(FEET[1])[2]);
        let foot = (-50.0 * ((goal.target[2] - self.cfg.target_above_top) - feet).powi(2)).exp();
        let close = dist2d(goal.obj_pos, root) <= 0.7;
        let total = if close { 0.5 * near + 0.2 + 0.3 * foot } else { 0.5 * near + 0.2 * far };
        out.terms[0] = near as f32;
        out.terms[1] = far as f32;
        out.terms[2] = foot as f32;
        out.terms[3] = total as f32;
        goal.finish_step(root, self.cfg.success_distance, self.cfg.iet_steps, ctx.fallen, out);
    }
    fn info(&self, goal: &Goal, _steps: usize, out: &mut [f32]) {
        goal.write_info(out);
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Climb::new(&h.climb, h.random_heading);
    super::build_env(task, cfg, h.object_variants, h.climb.episode_length)
}
