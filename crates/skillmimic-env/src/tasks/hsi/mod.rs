//! The TokenHSI tasks (TokenHSI supplementary §B.2): `hsi_follow`, `hsi_sit`, `hsi_climb`,
//! `hsi_carry` on the 32-DoF TokenHSI character ([`skillmimic_core::characters::tokenhsi`]), and
//! the skill-composition tasks `hsi_follow_carry`, `hsi_sit_carry`, `hsi_climb_carry` (§B.3,
//! [`compose`]).
//!
//! Every one of them is an [`Hsi<R>`]: a [`Task`] of the one batched driver
//! ([`crate::vec_env::VecEnv`]) that owns what the TokenHSI tasks share, over a [`Rule`] that says
//! what the task itself is (the way the skill-reuse tasks are `hlc::Rule`s run by
//! `hlc::HighLevel`). Shared ([`Hsi`]):
//! * the observation `[proprioception 222 | task observation]` ([`proprio`]);
//! * the start of the character: the rule's rest pose, or a reference frame
//!   ([`reference_init`], the released reference-state initialisation);
//! * the character-fall termination of the released code: the rule's [`FallRule`] (follow:
//!   [`fallen`], contact and a low body; sit, climb, carry: a low body alone, [`fallen_low`]);
//! * the power penalty `−env.hsi.power_coefficient · Σ|τ·q̇|` added to every task's reward
//!   ([`power`]): the reward terms are the rule's, then `power`, then `total_reward`;
//! * the time limit: as released, an episode of length L (`episode_length` of the task's table)
//!   is truncated after L − 1 steps;
//! * the previous root and object positions, from which the rewards' velocities are the finite
//!   differences over one 1/30 s policy step (as the released InterPhys/TokenHSI code computes
//!   them).
//!
//! A [`Rule`] supplies its objects (one set of sizes per compiled scene variant), the start of an
//! episode, its observation, reward terms, metrics and task-specific ends; rules compose (a
//! foundational rule plus carrying a box, [`compose`]).

pub mod carry;
pub mod climb;
pub mod compose;
pub mod config;
pub mod follow;
pub mod geometry;
pub mod proprio;
pub mod reference_init;
pub mod sit;
pub mod style;

use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::{self, CONTACT_BODIES, NUM_BODIES};
use skillmimic_sim::{BoxObject, EnvState, ResetState, Scene, SceneOptions};

use proprio::{PROPRIO_DIM, write_proprio};

use crate::task::{StepOut, Task, TaskSpec};
use crate::tasks::hsi::config::HsiConfig;
use crate::vec_env::{Env, VecEnv};

/// The `[env.hsi]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<config::HsiConfig>();

/// Policy step (s): 4 physics steps of 1/120 s.
pub const DT: f64 = 1.0 / 30.0;

/// The [`TaskSpec`] of a TokenHSI task: observation `[proprioception 222 | task_obs]`, the
/// character's 32 actions, one environment step per action.
pub fn hsi_spec(
    name: &'static str,
    task_obs: usize,
    episode_length: usize,
    term_names: Vec<String>,
    info_names: Vec<String>,
) -> TaskSpec {
    use skillmimic_core::characters::tokenhsi;
    let obs_blocks = crate::obs_blocks::ObsLayout::Proprio { part: name }
        .blocks(&tokenhsi::spec(), PROPRIO_DIM + task_obs);
    TaskSpec {
        name,
        obs_dim: PROPRIO_DIM + task_obs,
        action_space: crate::task::ActionSpace::Box { dim: tokenhsi::NUM_DOFS },
        max_episode_steps: episode_length,
        term_names,
        metric_names: crate::task::names(&["error_m", "success"]),
        info_names,
        token_groups: vec![("proprio".to_string(), PROPRIO_DIM), (name.to_string(), task_obs)],
        obs_blocks,
        ..TaskSpec::default()
    }
}

/// The batched environment of `rule` from the `[env]` table: `variants` scene variants whose
/// object sizes the rule draws from `env.hsi.object_seed`, the time limit `episode_length`.
pub fn build_env<R: Rule>(
    rule: R,
    cfg: &crate::config::EnvConfig,
    variants: usize,
    episode_length: usize,
) -> Result<Box<dyn Env>, crate::error::EnvError> {
    let h = cfg.table::<HsiConfig>();
    let mut orng = ChaCha8Rng::seed_from_u64(h.object_seed);
    let scenes = (0..variants.clamp(1, cfg.num_envs.max(1)))
        .map(|_| {
            let options = SceneOptions {
                objects: rule.objects(&mut orng),
                ..SceneOptions::bare(tokenhsi::CHARACTER)
            };
            Scene::new(options).map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut spec = rule.spec().clone();
    spec.term_names.extend(["power".to_string(), "total_reward".to_string()]);
    let reference = reference_init::ReferenceInit::from_config(h, spec.name)?;
    let task = Hsi {
        rule,
        spec,
        reference,
        episode_length,
        heights: FallHeights { body: h.termination_height, head: h.head_termination_height },
        power_coefficient: h.power_coefficient,
    };
    Ok(Box::new(VecEnv::with_variants(task, scenes, cfg.num_envs, cfg.threads, cfg.start_seed(0))?))
}

/// What a rule sees of one environment after a step.
pub struct Ctx<'a> {
    pub st: &'a EnvState<'a>,
    /// Root position before the step (world, m).
    pub prev_root: [f64; 3],
    /// Root orientation before the step (world, w x y z).
    pub prev_root_quat: skillmimic_core::math::Quat,
    /// Position of object 0 before the step (world, m).
    pub prev_obj: [f64; 3],
    /// Policy steps taken in this episode (1 after the first step).
    pub steps: usize,
    /// The character fell in this step (the episode terminates): no task counts a fall as a
    /// success.
    pub fallen: bool,
}

/// What a rule writes for one environment after a step.
pub struct TaskOut<'a> {
    /// `[terms]` reward terms (`TaskSpec::term_names`, the last one the total).
    pub terms: &'a mut [f32],
    /// `[metrics]` (`TaskSpec::metric_names`).
    pub metrics: &'a mut [f32],
    /// Task failure (path distance, object fall): terminate.
    pub fail: bool,
    /// Task end without failure (interaction early termination): truncate.
    pub finish: bool,
}

/// What one TokenHSI task is (see the module doc).
pub trait Rule: Send + Sync + 'static {
    /// Per-environment goal of the current episode.
    type Goal: Send + Sync + Clone + Default + serde::Serialize + serde::de::DeserializeOwned;
    /// Sizes and names (`obs_dim` = 222 + the task observation).
    fn spec(&self) -> &TaskSpec;
    /// The objects of one compiled scene variant (sizes drawn from `rng`).
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<BoxObject>;
    /// The start of an episode in `scene`: character and object states, and the goal.
    fn plan(
        &self,
        scene: &Scene,
        rng: &mut ChaCha8Rng,
        reset: &mut ResetState,
        goal: &mut Self::Goal,
    );
    /// The task observation (`obs_dim − 222` entries) at `steps` policy steps into the episode.
    fn observe(&self, goal: &Self::Goal, st: &EnvState<'_>, steps: usize, out: &mut [f32]);
    /// Reward terms, metrics and task ends after a step.
    fn step(&self, goal: &mut Self::Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>);
    /// Task information at `steps` policy steps into the episode (`TaskSpec::info_names`:
    /// targets, object poses and sizes, in world coordinates).
    fn info(&self, goal: &Self::Goal, steps: usize, out: &mut [f32]);
    /// The task's character-fall rule (default: the one of the released `humanoid.py`, which the
    /// follow task uses).
    fn fall_rule(&self) -> FallRule {
        FallRule::ContactAndLow
    }
    /// The object a reference start is placed against (sit: the seat), if the task has one:
    /// clips made against such an object start where they have the character relative to it.
    fn anchor(&self, _goal: &Self::Goal) -> Option<reference_init::Anchor> {
        None
    }
}

/// Which character-fall rule a task uses: the released task files differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FallRule {
    /// `humanoid.py` (ASE) as the follow task uses it: [`fallen`].
    ContactAndLow,
    /// The sit, climb and carry files' own rule: some body other than the feet below its
    /// termination height, no contact test, from step `from_step` on ([`fallen_low`]). Sit
    /// (training and evaluation) and climb (training) test from the first step (`1`); carry and
    /// climb's evaluation from the second (`2`).
    Low { from_step: usize },
}

impl FallRule {
    /// Whether the character fell in `st` after `steps` policy steps.
    pub fn fallen(self, st: &EnvState<'_>, steps: usize, h: FallHeights) -> bool {
        match self {
            Self::ContactAndLow => fallen(st, steps, h),
            Self::Low { from_step } => steps >= from_step && fallen_low(st, h),
        }
    }
}

/// Per-environment state of a TokenHSI task.
#[derive(Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct HsiSlot<G> {
    pub goal: G,
    /// Policy steps taken in this episode.
    pub steps: usize,
    prev_root: [f64; 3],
    prev_root_quat: skillmimic_core::math::Quat,
    prev_obj: [f64; 3],
}

impl<G> HsiSlot<G> {
    /// Take the current root pose and object 0 position as "before the next step".
    fn remember(&mut self, st: &EnvState<'_>) {
        self.prev_root = st.pos(0);
        self.prev_root_quat = st.quat(0);
        if st.body_pos.len() > 3 * NUM_BODIES {
            self.prev_obj = st.pos(NUM_BODIES);
        }
    }
}

/// A TokenHSI task: `rule` with the shared mechanics (see the module doc).
pub struct Hsi<R: Rule> {
    pub rule: R,
    /// The rule's spec with the `power` and `total_reward` terms appended.
    spec: TaskSpec,
    /// Reference-state initialisation (`None`: the rule's rest pose).
    reference: Option<reference_init::ReferenceInit>,
    /// Episode length L (policy steps): truncation after L − 1 steps.
    pub episode_length: usize,
    pub heights: FallHeights,
    /// Weight of the power penalty.
    pub power_coefficient: f64,
}

/// Termination heights of the fall rule (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FallHeights {
    /// Every body but the head.
    pub body: f64,
    /// The head: max(this, `body`).
    pub head: f64,
}

/// The head (its own termination height).
const HEAD: usize = 2;
/// A contact force component above this (N) counts as a contact in the fall rule.
const CONTACT_FORCE: f64 = 0.1;

/// The released fall rule (ASE's `compute_humanoid_reset`), after `steps` policy steps: from the
/// second step on, the character has fallen when some body other than the feet feels a net
/// contact force (floor, objects or its own bodies; |component| > 0.1 N) **and** some body
/// other than the feet — not necessarily the same one — is below its termination height.
pub fn fallen(st: &EnvState<'_>, steps: usize, h: FallHeights) -> bool {
    if steps <= 1 {
        return false;
    }
    let mut others = (0..NUM_BODIES).filter(|b| !CONTACT_BODIES.contains(b));
    let contact = others.any(|b| (0..3).any(|k| st.contact_force[3 * b + k].abs() > CONTACT_FORCE));
    contact && fallen_low(st, h)
}

/// Some body other than the feet is below its termination height (`h.body`; the head
/// max(`h.head`, `h.body`)): the height half of [`fallen`], and the whole fall rule of the
/// released sit, climb and carry files ([`FallRule::Low`]).
pub fn fallen_low(st: &EnvState<'_>, h: FallHeights) -> bool {
    (0..NUM_BODIES).filter(|b| !CONTACT_BODIES.contains(b)).any(|b| {
        let height = if b == HEAD { h.head.max(h.body) } else { h.body };
        st.pos(b)[2] < height
    })
}

/// The released time limit: an episode of length L is over after `steps` ≥ L − 1 steps.
pub fn time_limit_reached(steps: usize, episode_length: usize) -> bool {
    steps + 1 >= episode_length
}

/// `Σ_k |τ_k · q̇_k|` over the character's dofs (W): drive torques times joint rates, the power
/// the released reward penalises ([`EnvState::drive_power`]).
pub fn power(st: &EnvState<'_>) -> f64 {
    st.drive_power()
}

impl<R: Rule> Hsi<R> {
    fn write_obs(&self, slot: &HsiSlot<R::Goal>, st: &EnvState<'_>, obs: &mut [f32]) {
        write_proprio(st, &mut obs[..PROPRIO_DIM]);
        self.rule.observe(&slot.goal, st, slot.steps, &mut obs[PROPRIO_DIM..]);
    }
}

impl<R: Rule> Task for Hsi<R> {
    type Slot = HsiSlot<R::Goal>;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn new_slot(&self) -> Self::Slot {
        HsiSlot::default()
    }
    fn plan_reset(
        &mut self,
        _i: usize,
        slot: &mut Self::Slot,
        rng: &mut ChaCha8Rng,
        scene: &Scene,
        state: &mut ResetState,
    ) {
        self.rule.plan(scene, rng, state, &mut slot.goal);
        if let Some(r) = &self.reference {
            r.apply(rng, state, self.rule.anchor(&slot.goal));
        }
    }
    fn after_reset(&self, _i: usize, slot: &mut Self::Slot, st: &EnvState<'_>, obs: &mut [f32]) {
        slot.steps = 0;
        slot.prev_obj = [0.0; 3];
        slot.remember(st);
        self.write_obs(slot, st, obs);
    }
    fn reset_info(&self, slot: &Self::Slot, info: &mut [f32]) {
        self.rule.info(&slot.goal, 0, info);
    }
    fn step_env(&self, _i: usize, slot: &mut Self::Slot, st: &EnvState<'_>, out: StepOut<'_>) {
        slot.steps += 1;
        let fallen = self.rule.fall_rule().fallen(st, slot.steps, self.heights);
        let ctx = Ctx {
            st,
            prev_root: slot.prev_root,
            prev_root_quat: slot.prev_root_quat,
            prev_obj: slot.prev_obj,
            steps: slot.steps,
            fallen,
        };
        let n = out.terms.len() - 2;
        let (task, shared) = out.terms.split_at_mut(n);
        let mut o = TaskOut { terms: task, metrics: out.metrics, fail: false, finish: false };
        self.rule.step(&mut slot.goal, &ctx, &mut o);
        let penalty = -self.power_coefficient * power(st);
        shared[0] = penalty as f32;
        shared[1] = (f64::from(o.terms[n - 1]) + penalty) as f32;
        *out.reward = shared[1];
        *out.terminated = u8::from(fallen || o.fail || st.unstable);
        *out.truncated = u8::from(
            *out.terminated == 0
                && (o.finish || time_limit_reached(slot.steps, self.episode_length)),
        );
        slot.remember(st);
        self.write_obs(slot, st, out.obs);
        self.rule.info(&slot.goal, slot.steps, out.info);
    }
    /// The released discriminator's features ([`style::released_features`]).
    fn style_dim(&self) -> usize {
        style::RELEASED_STYLE_DIM
    }
    fn style_features(&self, st: &EnvState<'_>, out: &mut [f32]) {
        style::released_features(st, out);
    }
    /// Recompute the observation from the current state (after raw state edits). The previous
    /// root and object positions — between steps always the current ones — are taken anew, so
    /// the next step's finite-difference velocities start from an edited state, not from where
    /// the character was before the edit.
    fn observe(&self, slot: &mut Self::Slot, st: &EnvState<'_>, obs: &mut [f32]) {
        slot.remember(st);
        self.write_obs(slot, st, obs);
    }
}
