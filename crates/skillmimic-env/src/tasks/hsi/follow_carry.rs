//! `hsi_follow_carry`: the skill-composition task Follow + Carry (TokenHSI supplementary §B.3,
//! Eq. 16) — follow a trajectory while carrying a box; learnt by policy adaptation of a
//! multi-task token policy (`ppo.token.adapt_from`), which masks in the frozen follow and carry
//! tokens plus the new one.
//!
//! * Trajectory: `hsi_follow`'s (`[env.hsi.follow]`: speeds, turns, episode length, failure and
//!   success distances).
//! * Objects: the box of `hsi_carry` (sizes and mass from `[env.hsi.carry]`) and one support slab.
//!   Each episode puts the support 0.55 m ahead of the character in the direction of the path's
//!   first move (the first vertex away from the start; the path may start at rest), else along
//!   the character's heading, its top at a height from `env.hsi.carry.support_height`, the box resting on it (our
//!   choice: the supplementary does not say where the box starts; within 0.7 m the reward is
//!   live from the first step, so picking the box up is the first thing the reward asks for).
//! * Observation (121) in three groups, the token layout of the composition:
//!   - `hsi_follow` (20): the follow observation (frozen follow tokenizer);
//!   - `hsi_carry` (42): the carry observation (frozen carry tokenizer) whose target location is
//!     the trajectory point 0.9 s ahead at the box's current height (our choice: the
//!     composition has no box target; this one moves with the path);
//!   - `hsi_follow_carry` (59): the follow observation (20) followed by the revised carry
//!     observation (39: the carry observation without the target location).
//! * Reward (Eq. 16): 0 when the 2-D box–root distance exceeds 0.7 m, else
//!   `0.5 r_follow + 0.5 r_pick` (Eq. 1 and Eq. 13, the latter with its 0.2 weight).
//! * Ends: path distance (as `hsi_follow`), the box centre below `env.hsi.carry.fall_height`
//!   (when set), the time limit of `hsi_follow`.
//! * Metrics: `error_m` (path distance), `success` (`hsi_follow`'s rule and the box within 0.7 m
//!   of the root in 2-D at that step).
//! * Info (23): the 10 waypoints in world coordinates (20) and the box half sizes (3).

use rand_chacha::ChaCha8Rng;
use skillmimic_core::hsi_character::{HANDS, NUM_BODIES};
use skillmimic_sim::{HsiEnvState, HsiObject, HsiReset, HsiScene, ObjectBox, ObjectState};

use super::carry::{Carry, Goal as CarryGoal};
use super::follow::{Follow, Goal as FollowGoal, NUM_POINTS, POINT_DT};
use super::geometry::{dist2d, dist_sq, draw, put};
use super::{Ctx, DT, HsiTask, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::{EnvError, bad};
use crate::task::TaskSpec;
use crate::vec_env::Env;

/// Distance ahead of the character of the box's support (m).
const BOX_DISTANCE: f64 = 0.55;
/// Box–root 2-D distance beyond which the reward is zero (m; Eq. 16).
const CARRY_RADIUS: f64 = 0.7;

/// The trajectory and the box of an episode.
#[derive(Clone, Debug, Default)]
pub struct Goal {
    pub follow: FollowGoal,
    /// Half sizes of the box (m).
    pub half: [f64; 3],
}

/// The Follow + Carry composition task.
pub struct FollowCarry {
    spec: TaskSpec,
    follow: Follow,
    carry: Carry,
    support_height: [f64; 2],
    box_size: [f64; 2],
    box_mass: [f64; 2],
    fall_height: f64,
}

impl FollowCarry {
    pub fn new(cfg: &crate::config_hsi::HsiConfig) -> Self {
        let mut info_names: Vec<String> = (0..NUM_POINTS).flat_map(|k| [format!("waypoint{k}_x"), format!("waypoint{k}_y")]).collect();
        info_names.extend(["half_x", "half_y", "half_z"].map(String::from));
        let mut spec = hsi_spec("hsi_follow_carry", 20 + 42 + 59, cfg.follow.episode_length, vec!["follow", "pick", "total"], info_names);
        spec.token_groups.truncate(1);
        spec.token_groups.extend([("hsi_follow".to_string(), 20), ("hsi_carry".to_string(), 42), ("hsi_follow_carry".to_string(), 59)]);
        let c = &cfg.carry;
        Self { spec, follow: Follow::new(&cfg.follow, cfg.random_heading), carry: Carry::new(c, cfg.random_heading), support_height: c.support_height, box_size: c.box_size, box_mass: c.box_mass, fall_height: c.fall_height }
    }
}

impl HsiTask for FollowCarry {
    type Goal = Goal;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<HsiObject> {
        let half = [0.5 * draw(rng, self.box_size), 0.5 * draw(rng, self.box_size), 0.5 * draw(rng, self.box_size)];
        let mass = draw(rng, self.box_mass);
        vec![
            HsiObject { name: "box".into(), mass: Some(mass), boxes: vec![ObjectBox { center: [0.0; 3], half }], rgba: [0.75, 0.55, 0.3, 1.0] },
            HsiObject { name: "support".into(), mass: None, boxes: vec![ObjectBox { center: [0.0, 0.0, -0.01], half: [half[0] + 0.1, half[1] + 0.1, 0.01] }], rgba: [0.4, 0.45, 0.5, 1.0] },
        ]
    }
    fn plan(&self, scene: &HsiScene, rng: &mut ChaCha8Rng, reset: &mut HsiReset, goal: &mut Goal) {
        self.follow.plan(scene, rng, reset, &mut goal.follow);
        let half = scene.objects()[0].boxes[0].half;
        // direction of the path's first move (the trajectory may start at rest: the first
        // vertex that differs from the start), else the character's heading
        let a = goal.follow.verts[0];
        let ahead = goal.follow.verts.iter().find(|v| (v[0] - a[0]).hypot(v[1] - a[1]) > 1e-3);
        let (dx, dy) = match ahead {
            Some(b) => {
                let len = (b[0] - a[0]).hypot(b[1] - a[1]);
                ((b[0] - a[0]) / len, (b[1] - a[1]) / len)
            }
            None => {
                let f = reset.root_quat.rotate([1.0, 0.0, 0.0]);
                let len = f[0].hypot(f[1]).max(1e-9);
                (f[0] / len, f[1] / len)
            }
        };
        let root = reset.root_pos;
        let h = draw(rng, self.support_height);
        let at = [root[0] + BOX_DISTANCE * dx, root[1] + BOX_DISTANCE * dy, h];
        let yaw = skillmimic_core::math::Quat::about_z(dy.atan2(dx));
        reset.objects[0] = ObjectState { pos: [at[0], at[1], h + half[2] + 1e-3], quat: yaw, ..Default::default() };
        reset.objects[1] = ObjectState { pos: at, quat: yaw, ..Default::default() };
        goal.half = half;
    }
    fn observe(&self, goal: &Goal, st: &HsiEnvState<'_>, steps: usize, out: &mut [f32]) {
        self.follow.observe(&goal.follow, st, steps, &mut out[..20]);
        let ahead = goal.follow.at(steps as f64 * DT + (NUM_POINTS - 1) as f64 * POINT_DT);
        let z = st.pos(NUM_BODIES)[2];
        let cg = CarryGoal { target: [ahead[0], ahead[1], z], start: [0.0; 3], half: goal.half };
        self.carry.observe(&cg, st, steps, &mut out[20..62]);
        out.copy_within(0..20, 62);
        out.copy_within(23..62, 82);
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let mut fterm = [0.0f32];
        let mut fmet = [0.0f32; 2];
        let mut fo = TaskOut { terms: &mut fterm, metrics: &mut fmet, fail: false, finish: false };
        self.follow.step(&mut goal.follow, ctx, &mut fo);
        let fail = fo.fail;
        let st = ctx.st;
        let (root, obj) = (st.pos(0), st.pos(NUM_BODIES));
        let (h0, h1) = (st.pos(HANDS[0]), st.pos(HANDS[1]));
        let hands = [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])];
        let near = dist2d(obj, root) <= CARRY_RADIUS;
        let pick = if near { 0.2 * (-5.0 * dist_sq(obj, hands)).exp() } else { 0.0 };
        let total = if near { 0.5 * fterm[0] as f64 + 0.5 * pick } else { 0.0 };
        out.terms[0] = fterm[0];
        out.terms[1] = pick as f32;
        out.terms[2] = total as f32;
        out.fail = fail || (self.fall_height > 0.0 && obj[2] < self.fall_height);
        out.metrics[0] = fmet[0];
        out.metrics[1] = f32::from(fmet[1] > 0.5 && near);
    }
    fn info(&self, goal: &Goal, steps: usize, out: &mut [f32]) {
        self.follow.info(&goal.follow, steps, &mut out[..20]);
        put(out, 20, &goal.half);
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.hsi.validate()?;
    if cfg.hsi.carry.support_height[1] > 1.0 {
        return Err(bad("env.hsi.carry.support_height", "hsi_follow_carry puts the box within reach: the support must be at most 1 m high").into());
    }
    let task = FollowCarry::new(&cfg.hsi);
    super::build_env(task, cfg, cfg.hsi.object_variants, cfg.hsi.follow.episode_length)
}
