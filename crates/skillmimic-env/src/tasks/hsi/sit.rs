//! `hsi_sit`: sitting on a procedural chair or stool (TokenHSI supplementary §B.2.2, Eqs. 2–4), as
//! the released `humanoid_sit.py` does it.
//!
//! * Object (one per compiled variant, sizes from `[env.hsi.sit]`): a box seat from the floor to
//!   the seat height, depth × width in `seat_size`, facing its +x axis; with probability
//!   `backrest_prob` a backrest (0.06 m thick, 0.5 m tall) on its −x edge. The object's frame has
//!   its origin at the centre of its footprint on the floor; its bounding-box centre (the released
//!   object root) is half the box's height above it. Each episode places it `distance` m from the
//!   character in a random direction with a random yaw (a static, mocap body). (The released
//!   objects are chair meshes whose front is their +y axis; the front of ours is +x, and the
//!   facing observation is the front in both.)
//! * Target: 0.1 m (`target_above_seat`) above the centre of the seat's top (the released target
//!   is the mean seat height around the bounding box's centre plus 0.1 m: the same point here).
//! * Observation (38), heading frame relative to the root. Released (default): target (3) | the 8
//!   corners of the bounding box ([`corners`] order) (24) | facing direction (x, y of the front)
//!   (2) | bounding-box centre (3) | object rotation, tan-norm 6D (6). Supplementary form (the
//!   text's order): target | object position (frame origin) | rotation | facing | corners.
//! * Reward (Eqs. 2–4): `0.7 r_near + 0.3 r_far`, `r_far = exp(−2 (1.5 − d*·v_root,2d)²)`
//!   (d*: horizontal unit vector root → object; v: finite-difference root velocity), 1 when the
//!   2-D root–object distance is at most 0.5 m; `r_near = exp(−10 ‖x_tar − x_root‖²)`. The
//!   released form adds, within `penalty_radius` (1.5 m, 2-D) of the object, a speed penalty
//!   `−0.5 (1 − exp(−2 (1.3 − max(‖v_root‖, 1.3))²))` (3-D speed) and a turning penalty
//!   `−0.5 (1 − exp(−0.5 (3 − max(ω, 3))²))`, ω = |yaw_t − yaw_{t−1}| / (1/30 s) with the yaw in
//!   [0, 2π) not unwrapped ([`yaw_0_2pi`]).
//! * Ends: the released sit file's fall rule (a low body alone, from the first step,
//!   [`super::FallRule::Low`]); interaction early termination (a truncation) once the steps with
//!   the root within `success_distance` (≤ 0.2 m) of the target — cumulative over the episode —
//!   reach `iet_steps` − 1 = 59 ([`Goal::finish_step`]); the time limit.
//! * Metrics: `error_m` (root–target distance, m), `success` (the released evaluation, ever
//!   reached: 1 from the first step within `success_distance`, whatever follows).
//! * Info (13, world): target (3), object position (3), object yaw (1), bounding box lo (3), hi
//!   (3).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::math::{Quat, Vec3, heading};
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ObjectState, ResetState, Scene};

use super::config::SitConfig;
use super::geometry::{
    Local, corners, dir2d, dist_sq, dist2d, draw, excess_penalty, put, ring_point, speed,
    speed_reward, stand_at_origin, yaw_0_2pi,
};
use super::{Ctx, DT, FallRule, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::{HsiConfig, HsiForm};
use crate::vec_env::Env;

/// A static object with a target on it (sit and climb).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Goal {
    /// Target root position (world, m).
    pub target: Vec3,
    pub obj_pos: Vec3,
    pub obj_quat: Quat,
    /// Bounding box of the object in its own frame (m).
    pub lo: Vec3,
    pub hi: Vec3,
    /// Steps of this episode with the root within the success distance (cumulative).
    pub near_steps: usize,
    /// The root was within the success distance at some step of this episode.
    pub reached: bool,
    /// Climb's close gate (m, 2-D): half the footprint's diagonal plus the gate margin.
    pub gate: f64,
}

impl Goal {
    /// Place the scene's object 0 at `distance` from the origin with a random yaw; the target
    /// is `above` m over the centre of the object's top face (its bounding box's top).
    pub fn place(
        scene: &Scene,
        rng: &mut ChaCha8Rng,
        distance: [f64; 2],
        above: f64,
        top_of: usize,
        reset: &mut ResetState,
    ) -> Self {
        let obj = &scene.box_objects()[0];
        let (lo, hi) = obj.bounds();
        let p = ring_point(rng, distance);
        let yaw = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let q = Quat::about_z(yaw);
        let pos = [p[0], p[1], 0.0];
        reset.objects[0] = ObjectState { pos, quat: q, ..Default::default() };
        // the top of box `top_of` (the seat, not the backrest)
        let b = obj.boxes[top_of];
        let local = [b.center[0], b.center[1], b.center[2] + b.half[2] + above];
        let r = q.rotate(local);
        Self {
            target: [pos[0] + r[0], pos[1] + r[1], r[2]],
            obj_pos: pos,
            obj_quat: q,
            lo,
            hi,
            near_steps: 0,
            reached: false,
            gate: 0.0,
        }
    }

    /// The world centre of the object's bounding box (the released object root).
    pub fn centre(&self) -> Vec3 {
        let c = [
            0.5 * (self.lo[0] + self.hi[0]),
            0.5 * (self.lo[1] + self.hi[1]),
            0.5 * (self.lo[2] + self.hi[2]),
        ];
        let r = self.obj_quat.rotate(c);
        [self.obj_pos[0] + r[0], self.obj_pos[1] + r[1], self.obj_pos[2] + r[2]]
    }

    /// World corners of the object's bounding box.
    pub fn corners(&self) -> [Vec3; 8] {
        corners(self.obj_pos, self.obj_quat, self.lo, self.hi)
    }

    /// Info entries (13): target, object position, yaw, box lo, hi.
    pub fn write_info(&self, out: &mut [f32]) {
        let at = put(out, 0, &self.target);
        let at = put(out, at, &self.obj_pos);
        let at = put(out, at, &[heading(self.obj_quat)]);
        let at = put(out, at, &self.lo);
        put(out, at, &self.hi);
    }

    /// The released interaction early termination: count the steps with `err` ≤ `d` over the
    /// episode (not necessarily consecutive); true once the count reaches `iet` − 1 (`iet` = 0:
    /// never).
    pub fn interaction_done(&mut self, err: f64, d: f64, iet: usize) -> bool {
        self.near_steps += usize::from(err <= d);
        iet > 0 && self.near_steps + 1 >= iet
    }

    /// The end of a step of a task that brings the root to the target (sit, climb), as released:
    /// metrics `error_m` (root–target distance) and `success` (within `success_distance` at some
    /// step of the episode, whatever follows), and the interaction early termination
    /// ([`Self::interaction_done`]).
    pub fn finish_step(
        &mut self,
        root: Vec3,
        success_distance: f64,
        iet_steps: usize,
        out: &mut TaskOut<'_>,
    ) {
        let err = dist_sq(self.target, root).sqrt();
        out.finish = self.interaction_done(err, success_distance, iet_steps);
        self.reached |= err <= success_distance;
        out.metrics[0] = err as f32;
        out.metrics[1] = f32::from(self.reached);
    }
}

/// Info names of a [`Goal`].
pub fn goal_info_names() -> Vec<String> {
    [
        "target_x",
        "target_y",
        "target_z",
        "object_x",
        "object_y",
        "object_z",
        "object_yaw",
        "box_lo_x",
        "box_lo_y",
        "box_lo_z",
        "box_hi_x",
        "box_hi_y",
        "box_hi_z",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// The sitting task.
pub struct Sit {
    spec: TaskSpec,
    cfg: SitConfig,
    random_heading: bool,
    form: HsiForm,
}

impl Sit {
    pub fn new(cfg: &SitConfig, random_heading: bool, form: HsiForm) -> Self {
        let spec = hsi_spec(
            "hsi_sit",
            38,
            cfg.episode_length,
            crate::task::names(&["near", "far", "speed", "turn", "sit"]),
            goal_info_names(),
        );
        Self { spec, cfg: cfg.clone(), random_heading, form }
    }
}

impl Rule for Sit {
    type Goal = Goal;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<BoxObject> {
        let c = &self.cfg;
        let h = draw(rng, c.seat_height);
        let (depth, width) = (draw(rng, c.seat_size), draw(rng, c.seat_size));
        let mut boxes = vec![ObjectBox {
            center: [0.0, 0.0, 0.5 * h],
            half: [0.5 * depth, 0.5 * width, 0.5 * h],
        }];
        if rng.random::<f64>() < c.backrest_prob {
            boxes.push(ObjectBox {
                center: [-0.5 * depth + 0.03, 0.0, h + 0.25],
                half: [0.03, 0.5 * width, 0.25],
            });
        }
        vec![BoxObject { name: "seat".into(), mass: None, boxes, rgba: [0.55, 0.4, 0.3, 1.0] }]
    }
    fn plan(&self, scene: &Scene, rng: &mut ChaCha8Rng, reset: &mut ResetState, goal: &mut Goal) {
        stand_at_origin(rng, self.random_heading, reset);
        *goal = Goal::place(scene, rng, self.cfg.distance, self.cfg.target_above_seat, 0, reset);
    }
    fn observe(&self, goal: &Goal, st: &EnvState<'_>, _steps: usize, out: &mut [f32]) {
        let l = Local::of(st);
        let facing = l.vector(goal.obj_quat.rotate([1.0, 0.0, 0.0]));
        let write_corners = |out: &mut [f32], mut at: usize| {
            for c in goal.corners() {
                at = put(out, at, &l.point(c));
            }
            at
        };
        let at = put(out, 0, &l.point(goal.target));
        if self.form == HsiForm::Released {
            let at = write_corners(out, at);
            let at = put(out, at, &facing[..2]);
            let at = put(out, at, &l.point(goal.centre()));
            put(out, at, &l.rotation(goal.obj_quat));
        } else {
            let at = put(out, at, &l.point(goal.obj_pos));
            let at = put(out, at, &l.rotation(goal.obj_quat));
            let at = put(out, at, &facing[..2]);
            write_corners(out, at);
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let c = &self.cfg;
        let released = self.form == HsiForm::Released;
        let root = ctx.st.pos(0);
        // the object's horizontal position: its bounding-box centre's (released; the same as the
        // frame origin's for these objects)
        let obj = if released { goal.centre() } else { goal.obj_pos };
        let near = (-10.0 * dist_sq(goal.target, root)).exp();
        let far = if dist2d(obj, root) > 0.5 {
            speed_reward(2.0, 1.5, dir2d(root, obj), root, ctx.prev_root, DT)
        } else {
            1.0
        };
        let (mut speed_pen, mut turn_pen) = (0.0, 0.0);
        if released && dist2d(obj, root) <= c.penalty_radius {
            let v = speed(root, ctx.prev_root, DT);
            speed_pen =
                excess_penalty(c.speed_penalty_coefficient, 2.0, c.speed_penalty_threshold, v);
            let turn = (yaw_0_2pi(ctx.st.quat(0)) - yaw_0_2pi(ctx.prev_root_quat)).abs() / DT;
            turn_pen =
                excess_penalty(c.turn_penalty_coefficient, 0.5, c.turn_penalty_threshold, turn);
        }
        let total = 0.7 * near + 0.3 * far + speed_pen + turn_pen;
        for (k, v) in [near, far, speed_pen, turn_pen, total].into_iter().enumerate() {
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
    /// The seat: the centre of its top (the target less `target_above_seat`) and its yaw (its
    /// front, +x, is the way a seated character faces).
    fn anchor(&self, goal: &Goal) -> Option<super::reference_init::Anchor> {
        let t = goal.target;
        let top = [t[0], t[1], t[2] - self.cfg.target_above_seat];
        Some(super::reference_init::Anchor::Seat { top, yaw: heading(goal.obj_quat) })
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    let h = cfg.table::<HsiConfig>();
    let task = Sit::new(&h.sit, h.random_heading, h.form);
    super::build_env(task, cfg, h.object_variants, h.sit.episode_length)
}
