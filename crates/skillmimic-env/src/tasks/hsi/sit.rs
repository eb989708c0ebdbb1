//! `hsi_sit`: sitting on a procedural chair or stool (TokenHSI supplementary §B.2.2, Eqs. 2–4).
//!
//! * Object (one per compiled variant, sizes from `[env.hsi.sit]`): a box seat from the floor to
//!   the seat height, depth × width in `seat_size`, facing its +x axis; with probability
//!   `backrest_prob` a backrest (0.06 m thick, 0.5 m tall) on its −x edge. The object frame's
//!   origin is the centre of its footprint on the floor. Each episode places it `distance` m from
//!   the character in a random direction with a random yaw (a static, mocap body).
//! * Target: 0.1 m (`target_above_seat`) above the centre of the seat's top.
//! * Observation (38), heading frame relative to the root: target (3) | object position (3) |
//!   object rotation, tan-norm 6D (6) | object facing direction (x, y of its +x axis) (2) | the 8
//!   corners of its bounding box (24) ([`corners`] order).
//! * Reward (Eqs. 2–4): `0.7 r_near + 0.3 r_far` when the 2-D root–object distance exceeds 0.5 m,
//!   else `0.7 r_near + 0.3`; `r_far = exp(−2 (1.5 − d*·v_root,2d)²)` (d*: horizontal unit vector
//!   root → object; v: finite-difference root velocity), `r_near = exp(−10 ‖x_tar − x_root‖²)`.
//! * Ends: interaction early termination (truncation) after `iet_steps` consecutive steps with the
//!   root within `success_distance` of the target; time limit.
//! * Metrics: `error_m` (root–target distance), `success` (below `success_distance`, not in a
//!   step where the character fell): their values at an episode's end are the paper's error and
//!   success.
//! * Info (13, world): target (3), object position (3), object yaw (1), bounding box lo (3), hi
//!   (3).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::math::{Quat, Vec3, heading};
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ObjectState, ResetState, Scene};

use super::config::SitConfig;
use super::geometry::{
    Local, corners, dir2d, dist_sq, dist2d, draw, put, ring_point, speed_reward, stand_at_origin,
};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::tasks::hsi::config::HsiConfig;
use crate::vec_env::Env;

/// A static object with a target on it (sit and climb).
#[derive(Clone, Debug, Default)]
pub struct Goal {
    /// Target root position (world, m).
    pub target: Vec3,
    pub obj_pos: Vec3,
    pub obj_quat: Quat,
    /// Bounding box of the object in its own frame (m).
    pub lo: Vec3,
    pub hi: Vec3,
    /// Consecutive steps within the success distance.
    pub near_steps: usize,
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
        }
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

    /// Count steps within `d` of the target; true once `iet` consecutive steps were (0 = never).
    pub fn interaction_done(&mut self, err: f64, d: f64, iet: usize) -> bool {
        self.near_steps = if err < d { self.near_steps + 1 } else { 0 };
        iet > 0 && self.near_steps >= iet
    }

    /// The end of a step of a task that brings the root to the target (sit, climb): metrics
    /// `error_m` (root–target distance) and `success` (below `success_distance`, and not in a
    /// step where the character fell), and the interaction early termination after `iet_steps`
    /// consecutive steps within `success_distance`.
    pub fn finish_step(
        &mut self,
        root: Vec3,
        success_distance: f64,
        iet_steps: usize,
        fallen: bool,
        out: &mut TaskOut<'_>,
    ) {
        let err = dist_sq(self.target, root).sqrt();
        out.finish = self.interaction_done(err, success_distance, iet_steps);
        out.metrics[0] = err as f32;
        out.metrics[1] = f32::from(err < success_distance && !fallen);
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
}

impl Sit {
    pub fn new(cfg: &SitConfig, random_heading: bool) -> Self {
        let spec = hsi_spec(
            "hsi_sit",
            38,
            cfg.episode_length,
            crate::task::names(&["near", "far", "sit"]),
            goal_info_names(),
        );
        Self { spec, cfg: cfg.clone(), random_heading }
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
        let at = put(out, 0, &l.point(goal.target));
        let at = put(out, at, &l.point(goal.obj_pos));
        let at = put(out, at, &l.rotation(goal.obj_quat));
        let facing = l.vector(goal.obj_quat.rotate([1.0, 0.0, 0.0]));
        let mut at = put(out, at, &facing[..2]);
        for c in goal.corners() {
            at = put(out, at, &l.point(c));
        }
    }
    fn step(&self, goal: &mut Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let root = ctx.st.pos(0);
        let near = (-10.0 * dist_sq(goal.target, root)).exp();
        let far = speed_reward(2.0, 1.5, dir2d(root, goal.obj_pos), root, ctx.prev_root, DT);
        let total = if dist2d(goal.obj_pos, root) > 0.5 {
            0.7 * near + 0.3 * far
        } else {
            0.7 * near + 0.3
        };
        out.terms[0] = near as f32;
        out.terms[1] = far as f32;
        out.terms[2] = total as f32;
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
    let task = Sit::new(&h.sit, h.random_heading);
    super::build_env(task, cfg, h.object_variants, h.sit.episode_length)
}
