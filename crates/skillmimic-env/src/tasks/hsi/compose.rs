//! Skill-composition tasks (TokenHSI supplementary §B.3, Eqs. 16–18): a foundational task done
//! while carrying a box — `hsi_follow_carry`, `hsi_sit_carry`, `hsi_climb_carry`. They are learnt
//! by policy adaptation of a multi-task token policy (`ppo.token.adapt_from`), which masks in the
//! frozen tokens of the two foundational tasks plus the new one.
//!
//! * Objects: the primary task's objects (trajectory: none; sit: the seat; climb: the platform),
//!   then `hsi_carry`'s box (sizes and mass from `[env.hsi.carry]`) and one support slab. Each
//!   episode plans the primary task as its own task does, then puts the support 0.55 m from the
//!   character — follow: in the direction of the path's first move (the first vertex away from the
//!   start; the path may start at rest); sit / climb: towards the target, or — where the support
//!   would come within 5 cm of the seat / platform — the first of left, right, behind that keeps
//!   clear; else along the character's heading — its top at a height from
//!   `env.hsi.carry.support_height`, the box resting on it (our choice: the supplementary does not
//!   say where the box starts; within 0.7 m the reward is live from the first step, so picking the
//!   box up comes first).
//! * Observation (2·p + 81, p = the primary observation: follow 20, sit 38, climb 27) in three
//!   groups, the token layout of the composition:
//!   - the primary group (`hsi_follow` / `hsi_sit` / `hsi_climb`, p): the primary observation;
//!   - `hsi_carry` (42): the carry observation of the box, whose target location is — follow: the
//!     trajectory point 0.9 s ahead at the box's current height; sit / climb: the task's root
//!     target (our choice: the composition has no box target);
//!   - the new group (named after the task, p + 39): the primary observation followed by the
//!     revised carry observation (the carry observation without its target location, 39).
//! * Reward (Eqs. 16–18): 0 when the 2-D box–root distance exceeds 0.7 m, else
//!   `w r_primary + (1 − w) r_pick` with w = 0.5 (follow) or 0.7 (sit, climb); r_primary is the
//!   primary task's total (Eq. 1, 2, 5), r_pick Eq. 13 with its 0.2 weight. Terms: the primary's,
//!   `pick`, `total`.
//! * Ends: the primary task's (path distance; interaction early termination), the box centre
//!   below `env.hsi.carry.fall_height` (when set), the primary's time limit.
//! * Metrics: the primary's `error_m`; `success` = the primary's success with the box within
//!   0.7 m of the root in 2-D at that step.
//! * Info: the primary's, then the box half sizes (3).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::{HANDS, NUM_BODIES};
use skillmimic_core::math::Quat;
use skillmimic_sim::{BoxObject, EnvState, ObjectBox, ObjectState, ResetState, Scene};

use super::carry::observe_box;
use super::climb::Climb;
use super::follow::{Follow, NUM_POINTS};
use super::geometry::{dist_sq, dist2d, draw, put};
use super::sit::{Goal as TargetGoal, Sit};
use super::{Ctx, DT, Rule, TaskOut, hsi_spec};
use crate::config::EnvConfig;
use crate::error::{EnvError, bad};
use crate::task::TaskSpec;
use crate::tasks::hsi::config::{HsiConfig, HsiForm};
use crate::vec_env::Env;

/// Distance from the character of the box's support (m).
const BOX_DISTANCE: f64 = 0.55;
/// Box–root 2-D distance beyond which the reward is zero (m; Eqs. 16–18).
const CARRY_RADIUS: f64 = 0.7;
/// Width of the revised carry observation (the carry observation without its target).
const REVISED: usize = 39;

/// A foundational task that can be composed with carrying.
/// An object pose and its bounding box in its own frame: position, rotation, lo, hi (m).
pub type KeepOut = ([f64; 3], Quat, [f64; 3], [f64; 3]);

pub trait Primary: Rule {
    /// Registry name of the composition (also its new token group).
    const NAME: &'static str;
    /// Weight w of the primary reward (the pick reward gets 1 − w).
    const WEIGHT: f64;
    /// Horizontal direction (world) from the root in which the box starts, if the goal gives one.
    fn box_direction(&self, goal: &Self::Goal, reset: &ResetState) -> Option<[f64; 2]>;
    /// The target location the frozen carry token reads (world, m); `box_pos` the box's centre.
    fn carry_target(&self, goal: &Self::Goal, steps: usize, box_pos: [f64; 3]) -> [f64; 3];
    /// The primary object's pose and bounding box in its own frame (position, rotation, lo, hi;
    /// m), which the box must not start in.
    fn keep_out(&self, _goal: &Self::Goal) -> Option<KeepOut> {
        None
    }
}

/// Clearance (m) kept between the box's support and the primary object at the start.
const CLEARANCE: f64 = 0.05;

/// Whether a disc of radius `r` at `p` (world xy) comes within [`CLEARANCE`] of the object's
/// bounding box (xy in its own frame).
fn overlaps(p: [f64; 2], r: f64, obj: &([f64; 3], Quat, [f64; 3], [f64; 3])) -> bool {
    let (pos, quat, lo, hi) = obj;
    let local = quat.conj().rotate([p[0] - pos[0], p[1] - pos[1], 0.0]);
    let dx = (lo[0] - local[0]).max(local[0] - hi[0]).max(0.0);
    let dy = (lo[1] - local[1]).max(local[1] - hi[1]).max(0.0);
    dx.hypot(dy) < r + CLEARANCE
}

fn unit(d: [f64; 2]) -> Option<[f64; 2]> {
    let len = d[0].hypot(d[1]);
    (len > 1e-3).then(|| [d[0] / len, d[1] / len])
}

impl Primary for Follow {
    const NAME: &'static str = "hsi_follow_carry";
    const WEIGHT: f64 = 0.5;
    fn box_direction(&self, goal: &Self::Goal, _reset: &ResetState) -> Option<[f64; 2]> {
        let a = goal.verts[0];
        goal.verts.iter().find_map(|v| unit([v[0] - a[0], v[1] - a[1]]))
    }
    fn carry_target(&self, goal: &Self::Goal, steps: usize, box_pos: [f64; 3]) -> [f64; 3] {
        let p = goal.at(steps as f64 * DT + (NUM_POINTS - 1) as f64 * self.point_dt);
        [p[0], p[1], box_pos[2]]
    }
}

fn towards_target(goal: &TargetGoal, reset: &ResetState) -> Option<[f64; 2]> {
    unit([goal.target[0] - reset.root_pos[0], goal.target[1] - reset.root_pos[1]])
}

impl Primary for Sit {
    fn keep_out(&self, goal: &TargetGoal) -> Option<KeepOut> {
        Some((goal.obj_pos, goal.obj_quat, goal.lo, goal.hi))
    }
    const NAME: &'static str = "hsi_sit_carry";
    const WEIGHT: f64 = 0.7;
    fn box_direction(&self, goal: &TargetGoal, reset: &ResetState) -> Option<[f64; 2]> {
        towards_target(goal, reset)
    }
    fn carry_target(&self, goal: &TargetGoal, _steps: usize, _box_pos: [f64; 3]) -> [f64; 3] {
        goal.target
    }
}

impl Primary for Climb {
    fn keep_out(&self, goal: &TargetGoal) -> Option<KeepOut> {
        Some((goal.obj_pos, goal.obj_quat, goal.lo, goal.hi))
    }
    const NAME: &'static str = "hsi_climb_carry";
    const WEIGHT: f64 = 0.7;
    fn box_direction(&self, goal: &TargetGoal, reset: &ResetState) -> Option<[f64; 2]> {
        towards_target(goal, reset)
    }
    fn carry_target(&self, goal: &TargetGoal, _steps: usize, _box_pos: [f64; 3]) -> [f64; 3] {
        goal.target
    }
}

/// The primary task's goal and the box.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Goal<G> {
    pub primary: G,
    /// Half sizes of the box (m).
    pub half: [f64; 3],
}

/// A foundational task composed with carrying a box (see the module doc).
pub struct WithBox<P: Primary> {
    spec: TaskSpec,
    primary: P,
    /// Width of the primary observation, primary terms, objects.
    p: usize,
    terms: usize,
    objects: usize,
    carry: super::config::CarryConfig,
}

impl<P: Primary> WithBox<P> {
    pub fn new(primary: P, carry: &super::config::CarryConfig) -> Self {
        let ps = primary.spec().clone();
        let p = ps.obs_dim - super::proprio::PROPRIO_DIM;
        let mut terms = ps.term_names.clone();
        let nt = terms.len();
        terms.extend(["pick".to_string(), "total".to_string()]);
        let mut info = ps.info_names.clone();
        info.extend(["half_x", "half_y", "half_z"].map(String::from));
        let mut spec = hsi_spec(P::NAME, 2 * p + 42 + REVISED, ps.max_episode_steps, terms, info);
        spec.token_groups.truncate(1);
        spec.token_groups.extend([
            (ps.name.to_string(), p),
            ("hsi_carry".to_string(), 42),
            (P::NAME.to_string(), p + REVISED),
        ]);
        let objects = primary.objects(&mut ChaCha8Rng::seed_from_u64(0)).len();
        Self { spec, primary, p, terms: nt, objects, carry: carry.clone() }
    }
    /// Body index of the box.
    fn box_body(&self) -> usize {
        NUM_BODIES + self.objects
    }
}

impl<P: Primary> Rule for WithBox<P> {
    type Goal = Goal<P::Goal>;
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<BoxObject> {
        let mut v = self.primary.objects(rng);
        let c = &self.carry;
        let (half, mass) = super::carry::draw_box(rng, c);
        v.push(BoxObject {
            name: "box".into(),
            mass: Some(mass),
            boxes: vec![ObjectBox { center: [0.0; 3], half }],
            rgba: [0.75, 0.55, 0.3, 1.0],
        });
        v.push(BoxObject {
            name: "support".into(),
            mass: None,
            boxes: vec![ObjectBox {
                center: [0.0, 0.0, -0.01],
                half: [half[0] + 0.1, half[1] + 0.1, 0.01],
            }],
            rgba: [0.4, 0.45, 0.5, 1.0],
        });
        v
    }
    fn plan(
        &self,
        scene: &Scene,
        rng: &mut ChaCha8Rng,
        reset: &mut ResetState,
        goal: &mut Self::Goal,
    ) {
        self.primary.plan(scene, rng, reset, &mut goal.primary);
        let half = scene.box_objects()[self.objects].boxes[0].half;
        let d = self.primary.box_direction(&goal.primary, reset).unwrap_or_else(|| {
            let f = reset.root_quat.rotate([1.0, 0.0, 0.0]);
            unit([f[0], f[1]]).unwrap_or([1.0, 0.0])
        });
        let root = reset.root_pos;
        // the first of ahead, left, right, behind whose support keeps clear of the primary object
        // (the object is ≥ 1 m away, so behind always does)
        let reach = (half[0] + 0.1).hypot(half[1] + 0.1);
        let candidates = [d, [-d[1], d[0]], [d[1], -d[0]], [-d[0], -d[1]]];
        let clear = |c: &[f64; 2]| {
            self.primary.keep_out(&goal.primary).is_none_or(|o| {
                !overlaps([root[0] + BOX_DISTANCE * c[0], root[1] + BOX_DISTANCE * c[1]], reach, &o)
            })
        };
        let [dx, dy] = candidates.iter().copied().find(|c| clear(c)).unwrap_or(candidates[3]);
        let h = draw(rng, self.carry.support_height);
        let at = [root[0] + BOX_DISTANCE * dx, root[1] + BOX_DISTANCE * dy, h];
        let yaw = Quat::about_z(dy.atan2(dx));
        reset.objects[self.objects] = ObjectState {
            pos: [at[0], at[1], h + half[2] + 1e-3],
            quat: yaw,
            ..Default::default()
        };
        reset.objects[self.objects + 1] = ObjectState { pos: at, quat: yaw, ..Default::default() };
        goal.half = half;
    }
    fn observe(&self, goal: &Self::Goal, st: &EnvState<'_>, steps: usize, out: &mut [f32]) {
        let p = self.p;
        self.primary.observe(&goal.primary, st, steps, &mut out[..p]);
        let body = self.box_body();
        let target = self.primary.carry_target(&goal.primary, steps, st.pos(body));
        observe_box(target, goal.half, st, body, HsiForm::Supplementary, &mut out[p..p + 42]);
        out.copy_within(0..p, p + 42);
        out.copy_within(p + 3..p + 42, 2 * p + 42);
    }
    fn step(&self, goal: &mut Self::Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>) {
        let nt = self.terms;
        let mut pm = [0.0f32; 2];
        let (fail, finish) = {
            let mut po = TaskOut {
                terms: &mut out.terms[..nt],
                metrics: &mut pm,
                fail: false,
                finish: false,
            };
            self.primary.step(&mut goal.primary, ctx, &mut po);
            (po.fail, po.finish)
        };
        let st = ctx.st;
        let (root, obj) = (st.pos(0), st.pos(self.box_body()));
        let (h0, h1) = (st.pos(HANDS[0]), st.pos(HANDS[1]));
        let hands = [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])];
        let near = dist2d(obj, root) <= CARRY_RADIUS;
        let pick = if near { 0.2 * (-5.0 * dist_sq(obj, hands)).exp() } else { 0.0 };
        let total = if near {
            P::WEIGHT * out.terms[nt - 1] as f64 + (1.0 - P::WEIGHT) * pick
        } else {
            0.0
        };
        out.terms[nt] = pick as f32;
        out.terms[nt + 1] = total as f32;
        out.fail = fail || (self.carry.fall_height > 0.0 && obj[2] < self.carry.fall_height);
        out.finish = finish;
        out.metrics[0] = pm[0];
        out.metrics[1] = f32::from(pm[1] > 0.5 && near);
    }
    fn info(&self, goal: &Self::Goal, steps: usize, out: &mut [f32]) {
        let n = self.spec.info_names.len() - 3;
        self.primary.info(&goal.primary, steps, &mut out[..n]);
        put(out, n, &goal.half);
    }
}

fn build<P: Primary>(
    primary: P,
    cfg: &EnvConfig,
    variants: usize,
) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HsiConfig>().validate()?;
    if cfg.table::<HsiConfig>().carry.support_height[1] > 1.0 {
        return Err(bad(
            "env.hsi.carry.support_height",
            format!("{} puts the box within reach: the support must be at most 1 m high", P::NAME),
        )
        .into());
    }
    let task = WithBox::new(primary, &cfg.table::<HsiConfig>().carry);
    let len = task.spec.max_episode_steps;
    super::build_env(task, cfg, variants, len)
}

/// Registry constructor of `hsi_follow_carry`.
pub fn build_follow_carry(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    let h = cfg.table::<HsiConfig>();
    build(Follow::new(&h.follow, h.random_heading, h.form), cfg, h.object_variants)
}
/// Registry constructor of `hsi_sit_carry`.
pub fn build_sit_carry(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    build(
        Sit::new(
            &cfg.table::<HsiConfig>().sit,
            cfg.table::<HsiConfig>().random_heading,
            cfg.table::<HsiConfig>().form,
        ),
        cfg,
        cfg.table::<HsiConfig>().object_variants,
    )
}
/// Registry constructor of `hsi_climb_carry`.
pub fn build_climb_carry(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    build(
        Climb::new(
            &cfg.table::<HsiConfig>().climb,
            cfg.table::<HsiConfig>().random_heading,
            cfg.table::<HsiConfig>().form,
        ),
        cfg,
        cfg.table::<HsiConfig>().object_variants,
    )
}
