//! `hsi_carry`: carrying a box between two thin supports (TokenHSI supplementary §B.2.4,
//! Eqs. 9–15; InterPhys's multi-stage reward).
//!
//! * Objects (per compiled variant): the box (a free body, sides drawn independently from
//!   `box_size`, mass from `box_mass`) and two static supports (0.02 m thick slabs, 0.1 m wider
//!   than the box on each side). Each episode puts the start support `distance` m from the
//!   character in a random direction, its top at a height from `support_height`, the box resting
//!   on it with a random yaw, and the target support `distance` m from the start support, its top
//!   at another drawn height. The box's target location is its centre resting on the target
//!   support.
//! * Observation (42), heading frame relative to the root: target location (3) | box position (3)
//!   | box rotation, tan-norm 6D (6) | box linear velocity (3) | box angular velocity (3) | the 8
//!   corners of the box (24).
//! * Reward (Eq. 15) = walk + carry + pick + put:
//!   - walk (Eq. 9): 0.2 when the 2-D box–root distance is below 0.5 m, else
//!     `0.2 exp(−5 (1.5 − d*·v_root,2d)²)` (d*: root → box);
//!   - carry (Eqs. 10–12): `0.2 r_near + 0.2 r_far` when the 2-D box–target distance exceeds
//!     0.5 m, else `0.2 r_near + 0.2`; `r_far = exp(−5 (1.5 − d#·v_box,2d)²)` (d#: box → target),
//!     `r_near = exp(−10 ‖x_tar − x_box‖²)`;
//!   - pick (Eq. 13): 0 when the 2-D box–root distance exceeds 0.7 m, else
//!     `0.2 exp(−5 ‖x_box − x̄_hands‖²)`;
//!   - put (Eq. 14): 0 when the 2-D box–target distance exceeds 0.1 m, else
//!     `0.2 exp(−10 (z_box − z_tar)²)`.
//!
//!   Velocities are finite differences over the policy step.
//! * Ends: object fall (box centre below `fall_height`, off at 0 — Tab. A lists no object-fall
//!   termination for this task); time limit (600 steps = 20 s).
//! * Metrics: `error_m` (box–target distance), `success` (below `success_distance`, not in a
//!   step where the character fell).
//! * Info (9, world): target (3), start support top centre (3), box half sizes (3) (the box's
//!   pose is in `qpos`).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::{HANDS, NUM_BODIES};
use skillmimic_core::math::{Quat, Vec3};
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ObjectState, ResetState, Scene};

use super::config::CarryConfig;
use super::geometry::{
    Local, corners, dir2d, dist_sq, dist2d, draw, put, ring_point, speed_reward, stand_at_origin,
};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::HsiConfig;
use crate::vec_env::Env;

/// Half thickness of a support slab (m).
const SLAB_HALF: f64 = 0.01;

/// The box's target and the episode's layout.
#[derive(Clone, Debug, Default)]
pub struct Goal {
    /// Target location of the box centre (world, m).
    pub target: Vec3,
    /// Top centre of the start support (world, m).
    pub start: Vec3,
    /// Half sizes of the box (m).
    pub half: Vec3,
}

/// The carrying task.
pub struct Carry {
    spec: TaskSpec,
    cfg: CarryConfig,
    random_heading: bool,
}

impl Carry {
    pub fn new(cfg: &CarryConfig, random_heading: bool) -> Self {
        let info_names = [
            "target_x", "target_y", "target_z", "start_x", "start_y", "start_z", "half_x",
            "half_y", "half_z",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let spec = hsi_spec(
            "hsi_carry",
            42,
            cfg.episode_length,
            crate::task::names(&["walk", "carry", "pick", "put", "total"]),
            info_names,
        );
        Self { spec, cfg: cfg.clone(), random_heading }
    }
}

fn box_state(st: &EnvState<'_>) -> (Vec3, Quat) {
    (st.pos(NUM_BODIES), st.quat(NUM_BODIES))
}

impl Rule for Carry {
    type Goal = Goal;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<BoxObject> {
        let c = &self.cfg;
        let half =
            [0.5 * draw(rng, c.box_size), 0.5 * draw(rng, c.box_size), 0.5 * draw(rng, c.box_size)];
        let mass = draw(rng, c.box_mass);
        let slab = |name: &str| BoxObject {
            name: name.into(),
            mass: None,
            boxes: vec![ObjectBox {
                center: [0.0, 0.0, -SLAB_HALF],
                half: [half[0] + 0.1, half[1] + 0.1, SLAB_HALF],
            }],
            rgba: [0.4, 0.45, 0.5, 1.0],
        };
        vec![
            BoxObject {
                name: "box".into(),
                mass: Some(mass),
                boxes: vec![ObjectBox { center: [0.0; 3], half }],
                rgba: [0.75, 0.55, 0.3, 1.0],
            },
            slab("support_start"),
            slab("support_target"),
        ]
    }
    fn plan(&self, scene: &Scene, rng: &mut ChaCha8Rng, reset: &mut ResetState, goal: &mut Goal) {
        stand_at_origin(rng, self.random_heading, reset);
        let c = &self.cfg;
        let half = scene.box_objects()[0].boxes[0].half;
        let p = ring_point(rng, c.distance);
        let hs = draw(rng, c.support_height);
        let yaw_s = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let q = ring_point(rng, c.distance);
        let ht = draw(rng, c.support_height);
        let yaw_t = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let start = [p[0], p[1], hs];
        let tgt = [p[0] + q[0], p[1] + q[1], ht];
        reset.objects[0] = ObjectState {
            pos: [start[0], start[1], hs + half[2] + 1e-3],
            quat: Quat::about_z(yaw_s),
            ..Default::default()
        };
        reset.objects[1] =
            ObjectState { pos: start, quat: Quat::about_z(yaw_s), ..Default::default() };
        reset.objects[2] =
            ObjectState { pos: tgt, quat: Quat::about_z(yaw_t), ..Default::default() };
        *goal = Goal { target: [tgt[0], tgt[1], ht + half[2]], start, half };
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, _steps: usize, out: &mut [f32]) {
        observe_box(goal.target, goal.half, st, NUM_BODIES, out);
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let st = ctx.st;
        let root = st.pos(0);
        let (obj, _) = box_state(st);
        let walk = if dist2d(obj, root) < 0.5 {
            0.2
        } else {
            0.2 * speed_reward(5.0, 1.5, dir2d(root, obj), root, ctx.prev_root, DT)
        };
        let near = (-10.0 * dist_sq(goal.target, obj)).exp();
        let carry = if dist2d(obj, goal.target) > 0.5 {
            0.2 * near
                + 0.2 * speed_reward(5.0, 1.5, dir2d(obj, goal.target), obj, ctx.prev_obj, DT)
        } else {
            0.2 * near + 0.2
        };
        let (h0, h1) = (st.pos(HANDS[0]), st.pos(HANDS[1]));
        let hands = [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])];
        let pick =
            if dist2d(obj, root) > 0.7 { 0.0 } else { 0.2 * (-5.0 * dist_sq(obj, hands)).exp() };
        let put_r = if dist2d(obj, goal.target) > 0.1 {
            0.0
        } else {
            0.2 * (-10.0 * (obj[2] - goal.target[2]).powi(2)).exp()
        };
        for (k, v) in
            [walk, carry, pick, put_r, walk + carry + pick + put_r].into_iter().enumerate()
        {
            out.terms[k] = v as f32;
        }
        out.fail = self.cfg.fall_height > 0.0 && obj[2] < self.cfg.fall_height;
        let err = dist_sq(goal.target, obj).sqrt();
        out.metrics[0] = err as f32;
        out.metrics[1] = f32::from(err < self.cfg.success_distance && !ctx.fallen);
    }
    fn info(&self, goal: &Goal, _steps: usize, out: &mut [f32]) {
        let at = put(out, 0, &goal.target);
        let at = put(out, at, &goal.start);
        put(out, at, &goal.half);
    }
}

/// The 42-d carry observation (see the module doc) of the box whose body is `body` (object k of
/// the scene: `NUM_BODIES + k`) with half sizes `half` and target location `target` (world, m).
pub fn observe_box(target: Vec3, half: Vec3, st: &EnvState<'_>, body: usize, out: &mut [f32]) {
    let l = Local::of(st);
    let (pos, quat) = (st.pos(body), st.quat(body));
    let at = put(out, 0, &l.point(target));
    let at = put(out, at, &l.point(pos));
    let at = put(out, at, &l.rotation(quat));
    let at = put(out, at, &l.vector(st.linvel(body)));
    let mut at = put(out, at, &l.vector(st.angvel(body)));
    let neg = [-half[0], -half[1], -half[2]];
    for c in corners(pos, quat, neg, half) {
        at = put(out, at, &l.point(c));
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Carry::new(&h.carry, h.random_heading);
    super::build_env(task, cfg, h.object_variants, h.carry.episode_length)
}
