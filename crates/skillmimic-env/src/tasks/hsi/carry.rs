//! `hsi_carry`: carrying a box to a target location (TokenHSI supplementary §B.2.4, Eqs. 9–15;
//! InterPhys's multi-stage reward), as the released `humanoid_carry.py` and its config do it.
//!
//! * Objects (per compiled variant): the box (a free body; a cube whose side is drawn from
//!   `box_size` in `box_size_step` steps — 0.20, 0.25, …, 0.60 m as released — at `box_density`
//!   100 kg/m³, 0.8–21.6 kg) and two static 0.02 m thick platforms (`platform_size`, 0.4 × 0.4 m),
//!   one under the box's start and one under its target.
//! * Start ([`Carry::plan`]): the character stands at the origin; the box's centre is
//!   U(`distance`) = U(1, 10) m away in a random direction with a random yaw, at half its height
//!   (on the floor) or, with probability `raise_prob`, raised by U(0, `raise_height`) with its top
//!   at most `max_top` (1.2 m); its platform's top is at the box's bottom and the box starts
//!   `drop_height` (0.05 m) above it. The target: horizontally uniform in [−4.5, 4.5]² (redrawn
//!   while within `keep_clear` = 1 m of the character or the box), its height drawn like the
//!   start's, with its own platform.
//! * Observation (42), heading frame relative to the root. Released (default): box linear
//!   velocity (3) | box angular velocity (3) | box position (3) | box rotation, tan-norm 6D (6) |
//!   the 8 corners of the box ([`super::geometry::corners`] order) (24) | target location (3).
//!   Supplementary form: target (3) | position (3) | rotation (6) | linear velocity (3) | angular
//!   velocity (3) | corners (24) (the text's order).
//! * Reward = walk + carry + pick + put + box speed (velocities are finite differences over the
//!   1/30 s policy step; ‖·‖₂d horizontal):
//!   - walk: `0.2 v`, v = `exp(−5 (1.5 − d*·v_root,2d)²)` (d*: root → box), 0 when `d*·v ≤ 0`, 1
//!     when the box is within 0.5 m (2-D, <) of the root;
//!   - carry: `0.2 v + 0.2 exp(−10 ‖x_tar − x_box‖²)`, v = `exp(−5 (1.5 − d#·v_box,2d)²)` (d#: box →
//!     target), 0 when `d#·v ≤ 0` or while the box is low (centre ≤ half its height +
//!     `low_margin`), 1 when the box is within 0.5 m (2-D, <) of the target;
//!   - pick: 0 when the box is more than 0.7 m (2-D) from the root, else
//!     `0.2 exp(−5 ‖x_box − x̄_hands‖²)`;
//!   - put: 0.2 when the box is within 0.001 m of the target's height and 0.1 m (2-D, ≤) of it,
//!     else 0;
//!   - box speed: `−1.0 (1 − exp(−2 (2.5 − max(‖v_box‖, 2.5))²))` (3-D box speed).
//!
//!   Supplementary form (Eqs. 9–15): no sign masks, no low mask, no box-speed term, and
//!   `put = 0.2 exp(−10 (z_box − z_tar)²)` within 0.1 m (2-D).
//! * Ends: the fall rule of the released carry file (a low body alone, from the second step,
//!   [`super::FallRule::Low`]); an optional object fall (box centre below `fall_height`, off at 0 as
//!   released); the time limit (599 steps of 600).
//! * Metrics: `error_m` (box–target distance, m); `success` (the released evaluation, ever
//!   reached): 1 from the first step at which the box is within `success_distance` (≤ 0.2 m) of
//!   its target, whatever follows.
//! * Info (9, world): target (3), start platform top centre (3), box half sizes (3) (the box's
//!   pose is in `qpos`).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::{HANDS, NUM_BODIES};
use skillmimic_core::math::{Quat, Vec3};
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ObjectState, ResetState, Scene};

use super::config::CarryConfig;
use super::geometry::{
    Local, corners, dir2d, dist_sq, dist2d, dist2d_sq, draw, excess_penalty, put, ring_point,
    speed, speed_reward, speed_reward_towards, stand_at_origin,
};
use super::{Ctx, DT, FallRule, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::{HsiConfig, HsiForm};
use crate::vec_env::Env;

/// Half thickness of a platform (m).
const SLAB_HALF: f64 = 0.01;

/// The box's target and the episode's layout.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Goal {
    /// Target location of the box centre (world, m).
    pub target: Vec3,
    /// Top centre of the start platform (world, m).
    pub start: Vec3,
    /// Half sizes of the box (m).
    pub half: Vec3,
    /// The box was within the success distance of its target at some step of this episode.
    pub reached: bool,
}

/// The box of a variant: half sizes (m) and mass (kg) drawn under `c` (see the module doc).
pub fn draw_box(rng: &mut ChaCha8Rng, c: &CarryConfig) -> (Vec3, f64) {
    let side = |rng: &mut ChaCha8Rng| {
        if c.box_size_step > 0.0 && c.box_size[1] > c.box_size[0] {
            let n = ((c.box_size[1] - c.box_size[0]) / c.box_size_step + 1e-9).floor() as usize + 1;
            c.box_size[0] + c.box_size_step * rng.random_range(0..n) as f64
        } else {
            draw(rng, c.box_size)
        }
    };
    let size = if c.cube {
        let a = side(rng);
        [a; 3]
    } else {
        [side(rng), side(rng), side(rng)]
    };
    let mass = c.box_density * size[0] * size[1] * size[2];
    (size.map(|a| 0.5 * a), mass)
}

/// The height (m) of the centre of a box of half height `half_z` at a start or target: on the
/// floor, or with probability `raise_prob` raised by U(0, `raise_height`) with its top at most
/// `max_top` (and never below the floor).
fn draw_height(rng: &mut ChaCha8Rng, c: &CarryConfig, half_z: f64) -> f64 {
    if rng.random::<f64>() >= c.raise_prob {
        return half_z;
    }
    let z = half_z + c.raise_height * rng.random::<f64>();
    regulate_height(z, half_z, c.max_top).max(half_z)
}

/// The released `_regulate_height`: the centre height `z` (m) of a box of half height `half_z`
/// lowered so that its top is at most `max_top`.
pub fn regulate_height(z: f64, half_z: f64, max_top: f64) -> f64 {
    (z + half_z).min(max_top) - half_z
}

/// The carrying task.
pub struct Carry {
    spec: TaskSpec,
    cfg: CarryConfig,
    random_heading: bool,
    form: HsiForm,
}

impl Carry {
    pub fn new(cfg: &CarryConfig, random_heading: bool, form: HsiForm) -> Self {
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
            crate::task::names(&["walk", "carry", "pick", "put", "box_speed", "total"]),
            info_names,
        );
        Self { spec, cfg: cfg.clone(), random_heading, form }
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
        let (half, mass) = draw_box(rng, c);
        let platform = |name: &str| BoxObject {
            name: name.into(),
            mass: None,
            boxes: vec![ObjectBox {
                center: [0.0, 0.0, -SLAB_HALF],
                half: [0.5 * c.platform_size[0], 0.5 * c.platform_size[1], SLAB_HALF],
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
            platform("support_start"),
            platform("support_target"),
        ]
    }
    fn plan(&self, scene: &Scene, rng: &mut ChaCha8Rng, reset: &mut ResetState, goal: &mut Goal) {
        stand_at_origin(rng, self.random_heading, reset);
        let c = &self.cfg;
        let half = scene.box_objects()[0].boxes[0].half;
        let p = ring_point(rng, c.distance);
        let z = draw_height(rng, c, half[2]);
        let yaw = Quat::about_z(rng.random_range(0.0..std::f64::consts::TAU));
        let start = [p[0], p[1], z - half[2]];
        reset.objects[0] =
            ObjectState { pos: [p[0], p[1], z + c.drop_height], quat: yaw, ..Default::default() };
        reset.objects[1] = ObjectState { pos: start, quat: yaw, ..Default::default() };
        // the target: uniform in the square, away from the character (at the origin) and the box
        let a = c.target_area;
        let mut t = [0.0; 2];
        for _ in 0..1000 {
            t = [rng.random_range(-a..=a), rng.random_range(-a..=a)];
            let clear = |q: [f64; 2]| (t[0] - q[0]).hypot(t[1] - q[1]) >= c.keep_clear;
            if clear([0.0, 0.0]) && clear(p) {
                break;
            }
        }
        let zt = draw_height(rng, c, half[2]);
        reset.objects[2] = ObjectState { pos: [t[0], t[1], zt - half[2]], ..Default::default() };
        *goal = Goal { target: [t[0], t[1], zt], start, half, reached: false };
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, _steps: usize, out: &mut [f32]) {
        observe_box(goal.target, goal.half, st, NUM_BODIES, self.form, out);
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let st = ctx.st;
        let (c, released) = (&self.cfg, self.form == HsiForm::Released);
        let root = st.pos(0);
        let (obj, _) = box_state(st);
        let (h0, h1) = (st.pos(HANDS[0]), st.pos(HANDS[1]));
        let hands = [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])];
        let near = (-10.0 * dist_sq(goal.target, obj)).exp();
        let pick =
            if dist2d(obj, root) > 0.7 { 0.0 } else { 0.2 * (-5.0 * dist_sq(obj, hands)).exp() };
        let (walk, carry, put_r, box_speed) = if released {
            let walk = if dist2d_sq(obj, root) < 0.25 {
                1.0
            } else {
                speed_reward_towards(5.0, 1.5, dir2d(root, obj), root, ctx.prev_root, DT)
            };
            let moving = if dist2d_sq(goal.target, obj) < 0.25 {
                1.0
            } else if obj[2] <= goal.half[2] + c.low_margin {
                0.0
            } else {
                speed_reward_towards(5.0, 1.5, dir2d(obj, goal.target), obj, ctx.prev_obj, DT)
            };
            let placed =
                dist2d_sq(goal.target, obj) <= 0.01 && (obj[2] - goal.target[2]).abs() <= 0.001;
            let put_r = if placed { 0.2 } else { 0.0 };
            let v = speed(obj, ctx.prev_obj, DT);
            let penalty = excess_penalty(
                c.box_speed_penalty_coefficient,
                2.0,
                c.box_speed_penalty_threshold,
                v,
            );
            (0.2 * walk, 0.2 * moving + 0.2 * near, put_r, penalty)
        } else {
            let walk = if dist2d(obj, root) < 0.5 {
                0.2
            } else {
                0.2 * speed_reward(5.0, 1.5, dir2d(root, obj), root, ctx.prev_root, DT)
            };
            let carry = if dist2d(obj, goal.target) > 0.5 {
                0.2 * near
                    + 0.2 * speed_reward(5.0, 1.5, dir2d(obj, goal.target), obj, ctx.prev_obj, DT)
            } else {
                0.2 * near + 0.2
            };
            let put_r = if dist2d(obj, goal.target) > 0.1 {
                0.0
            } else {
                0.2 * (-10.0 * (obj[2] - goal.target[2]).powi(2)).exp()
            };
            (walk, carry, put_r, 0.0)
        };
        let total = walk + carry + pick + put_r + box_speed;
        for (k, v) in [walk, carry, pick, put_r, box_speed, total].into_iter().enumerate() {
            out.terms[k] = v as f32;
        }
        out.fail = c.fall_height > 0.0 && obj[2] < c.fall_height;
        let err = dist_sq(goal.target, obj).sqrt();
        goal.reached |= err <= c.success_distance;
        out.metrics[0] = err as f32;
        out.metrics[1] = f32::from(goal.reached);
    }
    fn info(&self, goal: &Goal, _steps: usize, out: &mut [f32]) {
        let at = put(out, 0, &goal.target);
        let at = put(out, at, &goal.start);
        put(out, at, &goal.half);
    }
    fn fall_rule(&self) -> FallRule {
        FallRule::Low { from_step: 2 }
    }
    /// The box (object 0): carrying clips (`builtin:carry`) start with it in the hands.
    fn anchor(&self, goal: &Goal) -> Option<super::reference_init::Anchor> {
        Some(super::reference_init::Anchor::Held { object: 0, half: goal.half })
    }
}

/// The 42-d carry observation (see the module doc; the order of `form`) of the box whose body is
/// `body` (object k of the scene: `NUM_BODIES + k`) with half sizes `half` and target location
/// `target` (world, m).
pub fn observe_box(
    target: Vec3,
    half: Vec3,
    st: &EnvState<'_>,
    body: usize,
    form: HsiForm,
    out: &mut [f32],
) {
    let l = Local::of(st);
    let (pos, quat) = (st.pos(body), st.quat(body));
    let neg = [-half[0], -half[1], -half[2]];
    let write_corners = |out: &mut [f32], mut at: usize| {
        for c in corners(pos, quat, neg, half) {
            at = put(out, at, &l.point(c));
        }
        at
    };
    if form == HsiForm::Released {
        let at = put(out, 0, &l.vector(st.linvel(body)));
        let at = put(out, at, &l.vector(st.angvel(body)));
        let at = put(out, at, &l.point(pos));
        let at = put(out, at, &l.rotation(quat));
        let at = write_corners(out, at);
        put(out, at, &l.point(target));
    } else {
        let at = put(out, 0, &l.point(target));
        let at = put(out, at, &l.point(pos));
        let at = put(out, at, &l.rotation(quat));
        let at = put(out, at, &l.vector(st.linvel(body)));
        let at = put(out, at, &l.vector(st.angvel(body)));
        write_corners(out, at);
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Carry::new(&h.carry, h.random_heading, h.form);
    super::build_env(task, cfg, h.object_variants, h.carry.episode_length)
}
