//! Skill reuse: the high-level tasks of SkillMimic (seed 000 §5.4, reference-facts §8) over a
//! frozen skill policy.
//!
//! Mechanics (shared by every task, [`HighLevel`]), by the kind of frozen policy `env.hlc.llc`:
//! * a `gaussian_mlp` skill policy (SkillMimic): each high-level step the policy picks one of the
//!   task's `n` choices (discrete action); the task's table maps it to a skill label; the skill
//!   policy's observation is the state part of the observation (entries 0..838, `obs::layout`)
//!   followed by the 64-wide one-hot of that label; the frozen policy (its own normaliser,
//!   deterministic mean, clamped to [−1, 1]) gives the PD targets; held for `llc_steps` (3);
//! * a `modular_attention` checkpoint (ModSkill skill reuse, seed 001 §3.5): the action is
//!   continuous, one E-wide embedding per body part (P·E = 5·64 = 320 by default), each projected
//!   onto the unit sphere and fed to that part's frozen controller
//!   ([`skillmimic_nn::frozen_parts`]); held for `latent_steps` (1).
//!
//! The driver (`vec_env::hold`) holds the action for those low-level steps. Timing
//! (`env.hlc.timing`, [`config::HlcTiming`]; SkillMimic's four tasks):
//! * "released" (default, the released loop): the high-level reward is the mean of all 3
//!   low-level task rewards, also when the episode ended inside them (the ended episode is
//!   simulated to the transition's end and its rewards count); done / terminated when any step
//!   set them; the observation is the 3rd step's; the environment is reset after the transition.
//!   An episode's first observation shows the previous episode's goal and latches (the released
//!   code observes before it draws the new goal), and each step's observation is taken before
//!   the reward updates the latches (the scoring "reached" flag shows one low-level step late).
//! * "cut": the transition ends at the step that ends the episode (mean over the steps up to and
//!   including it, its terminal observation); the first observation shows the new goal, and each
//!   observation the latches of its own step.
//!
//! Observation (high level): the 838 state entries (heading frame, see `obs.rs`) | the task part:
//! * `loc` (2): (goal_xy − root_xy) turned into the heading frame (m);
//! * `bearing` (2): (cos θ, sin θ), θ = atan2(goal − root) in the **world** frame (what the
//!   released code's formula reduces to);
//! * per task: the circling radius (m), the scoring "reached" flag (0/1).
//!
//! Episodes: start at frame `start_frame` (2) of a clip drawn class-balanced from `env.motion`
//! (reference-state initialisation; ball-free clips get a random ball); early termination when the
//! root is below `termination_height` (0.25 m) after the first step; truncation after
//! `episode_length − 1` (799) low-level steps. Info entries: the current episode's goal.
//!
//! A task = one module with a [`Rule`] (choices, task observation, goal sampling, reward and
//! success bookkeeping) and a `build` line in the registry.

pub mod circling;
pub mod config;
pub mod heading;
pub mod reach;
pub mod scoring;
pub mod steering;
pub mod throwing;

use std::sync::Arc;

use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::{Quat, heading_inverse};
use skillmimic_motion::{MotionLibrary, SKILL_WIDTH};
use skillmimic_nn::frozen::FrozenActor;
use skillmimic_nn::frozen_parts::{FrozenParts, policy_family};
use skillmimic_sim::{BALL, EnvState, ResetState, Scene};

use crate::config::EnvConfig;
use crate::episode::{BALL_FREE_SKILLS, fill_from_clip, random_ball};
use crate::error::{EnvError, bad};
use crate::obs::{layout, write_skill, write_state_obs};
use crate::task::{ActionSpace, StepOut, Task, TaskSpec};
use crate::tasks::imitation::load_motion_library;
use crate::vec_env::{Env, VecEnv};
use config::HlcConfig;

/// The `[env.hlc]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<config::HlcConfig>();

/// Low-level steps per second (policy rate).
pub const LL_HZ: f64 = 60.0;

/// The goal redraw clock of the tasks whose command changes within an episode (steering,
/// reach): the low-level step of the next redraw and the episode's seed for the redraws.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Redraw {
    pub next_change: u32,
    pub seed: u64,
}

impl Redraw {
    /// The random stream of a redraw due at low-level step `step` (`None` before
    /// `next_change`): seeded from the episode's seed and the step, so episodes are
    /// reproducible.
    pub fn rng(&self, step: u32) -> Option<ChaCha8Rng> {
        use rand::SeedableRng;
        (step >= self.next_change).then(|| {
            ChaCha8Rng::seed_from_u64(
                self.seed ^ u64::from(step).wrapping_mul(0x9e37_79b9_7f4a_7c15),
            )
        })
    }
}

/// The frozen policy a high-level task drives (see the module doc).
pub enum Driver {
    /// Discrete skill choices over a `gaussian_mlp` skill policy.
    Skills(FrozenActor),
    /// Part embeddings over the part controllers of a `modular_attention` checkpoint.
    Parts(FrozenParts),
}

/// What a high-level task defines (the mechanics are [`HighLevel`]'s).
pub trait Rule: Send + Sync + 'static {
    /// Registry name.
    const NAME: &'static str;
    /// The task's per-episode goal and success bookkeeping (world metres).
    type Goal: Clone
        + std::fmt::Debug
        + Default
        + Send
        + Sync
        + serde::Serialize
        + serde::de::DeserializeOwned
        + 'static;
    /// Skill label of each choice (`control_mapping`).
    fn labels(&self) -> &'static [u32];
    /// Width of the task part of the observation.
    fn task_obs_dim(&self) -> usize;
    /// Reward terms (the last is the task reward).
    fn term_names(&self) -> Vec<&'static str>;
    /// Per-step metrics (success entries are read at the end of an episode).
    fn metric_names(&self) -> Vec<&'static str>;
    /// Goal entries written as task information.
    fn info_names(&self) -> Vec<&'static str>;
    /// The goal of an episode starting with the root at `root` (world, m).
    fn sample_goal(&self, root: [f64; 3], rng: &mut ChaCha8Rng) -> Self::Goal;
    /// The task part of the observation.
    fn task_obs(&self, g: &Self::Goal, st: &EnvState<'_>, out: &mut [f32]);
    /// Reward of the state after low-level step `step` (1-based) with its terms and metrics;
    /// updates the goal's latches.
    fn reward(
        &self,
        g: &mut Self::Goal,
        step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64;
    /// The goal entries (`info_names` order).
    fn info(&self, g: &Self::Goal, out: &mut [f32]);
    /// Set the goal from entries in `info_names` order (interactive play); latches and success
    /// bookkeeping are left as they are.
    fn set_info(&self, g: &mut Self::Goal, values: &[f32]);
    /// Append the task's visual markers for an information row (`info_names` order).
    fn markers(&self, _info: &[f32], _out: &mut Vec<crate::markers::Marker>) {}
    /// Whether `env.hlc.timing` applies: the SkillMimic tasks, whose released loop it describes
    /// (true); ModSkill's steering and reach keep the cut timing (false).
    fn released_loop(&self) -> bool {
        true
    }
    /// The largest reward of one step, when bounded ([`crate::task::TaskSpec::max_step_reward`]).
    fn max_step_reward(&self) -> Option<f64> {
        None
    }
}

/// `loc` and `bearing` of a goal (4 values; see the module doc).
pub fn loc_bearing(goal: [f64; 2], st: &EnvState<'_>, out: &mut [f32]) {
    let root = st.pos(0);
    let d = [goal[0] - root[0], goal[1] - root[1], 0.0];
    let hinv: Quat = heading_inverse(st.quat(0));
    let loc = hinv.rotate(d);
    let theta = d[1].atan2(d[0]);
    out[..4].copy_from_slice(&[
        loc[0] as f32,
        loc[1] as f32,
        theta.cos() as f32,
        theta.sin() as f32,
    ]);
}

/// How the state after low-level step `progress` (1-based) ends the episode: (terminated,
/// truncated). Terminated: the root (pelvis) is below `termination_height` (world z, m) after the
/// first step, or the simulation went unstable. Truncated (only when not terminated): `progress`
/// reached `episode_length − 1`.
pub fn episode_end(cfg: &HlcConfig, progress: u32, st: &EnvState<'_>) -> (bool, bool) {
    let fell = st.pos(0)[2] < cfg.termination_height && progress > 1;
    let terminated = fell || st.unstable;
    (terminated, !terminated && progress as usize >= cfg.episode_length - 1)
}

/// Euclidean norm.
pub fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Ball position minus `p` (world, m).
pub fn ball_to(st: &EnvState<'_>, p: [f64; 3]) -> [f64; 3] {
    let b = st.pos(BALL);
    [b[0] - p[0], b[1] - p[1], b[2] - p[2]]
}

/// Per-environment state: low-level steps of the episode and its goal.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct HlSlot<G> {
    pub progress: u32,
    pub goal: G,
    /// `env.hlc.timing = "released"`: the previous episode's goal, which the episode's first
    /// observation shows (cleared by the first step).
    pub shown: Option<G>,
}

impl<G> HlSlot<G> {
    /// The goal the observation shows now.
    fn observed_goal(&self) -> &G {
        self.shown.as_ref().unwrap_or(&self.goal)
    }
}

/// A high-level task: its calls happen once per low-level (physics) step; the driver holds
/// each high-level action for [`HighLevel::hold_steps`] of them.
pub struct HighLevel<R: Rule> {
    pub rule: R,
    cfg: config::HlcConfig,
    lib: Arc<MotionLibrary>,
    spec: TaskSpec,
    driver: Driver,
    threads: usize,
    ball_radius: f64,
    /// `N × 902` skill-policy observations of the last low-level step.
    llc_obs: Vec<f32>,
    /// Skill label applied in the last low-level step, per environment.
    pub(crate) skills: Vec<u32>,
    /// `env.hlc.timing = "released"` applies to this task.
    released: bool,
}

impl<R: Rule> HighLevel<R> {
    /// The task over `lib` with the frozen policy loaded from `cfg.hlc.llc` (a skill policy or
    /// the part controllers of a modular checkpoint, by its `policy` metadata).
    pub fn new(
        rule: R,
        cfg: &EnvConfig,
        lib: Arc<MotionLibrary>,
        ball_radius: f64,
    ) -> Result<Self, EnvError> {
        let h = cfg.table::<HlcConfig>();
        let driver = if policy_family(&h.llc)?.as_deref() == Some("modular_attention") {
            Driver::Parts(FrozenParts::load(&h.llc)?)
        } else {
            Driver::Skills(FrozenActor::load(&h.llc)?)
        };
        let (trained_config, (obs_dim, act_dim)) = match &driver {
            Driver::Skills(a) => (&a.config, (a.obs_dim(), a.act_dim())),
            Driver::Parts(p) => (&p.config, (layout::OBS_DIM, p.act_dim)),
        };
        if obs_dim != layout::OBS_DIM || act_dim != NUM_DOFS {
            let msg = format!(
                "{}: a skill policy for observations of {} and actions of {}; the high-level \
                    tasks drive a SkillMimic skill policy with observation {} and {NUM_DOFS} \
                    actions (SkillMimic-V2 policies with a history embedding are not supported \
                    here)",
                h.llc.display(),
                obs_dim,
                act_dim,
                layout::OBS_DIM
            );
            return Err(bad("env.hlc.llc", msg).into());
        }
        // the humanoid must be the one the skill policy was trained on
        let trained: Option<toml::Table> = toml::from_str(trained_config).ok();
        let hands =
            trained.as_ref().and_then(|t| t.get("env")?.get("hands")?.as_str().map(str::to_string));
        if let Some(hands) = hands
            && hands != cfg.hands
        {
            let msg = format!(
                "the skill policy {} was trained with hands = \"{hands}\"; set env.hands = \
                    \"{hands}\" (--set env.hands={hands})",
                h.llc.display()
            );
            return Err(bad("env.hands", msg).into());
        }
        let (action_space, choice_labels) = match &driver {
            Driver::Skills(_) => {
                (ActionSpace::Discrete { n: rule.labels().len() }, rule.labels().to_vec())
            }
            Driver::Parts(p) => (ActionSpace::Box { dim: p.latent_dim() }, Vec::new()),
        };
        let hold = if matches!(driver, Driver::Parts(_)) { h.latent_steps } else { h.llc_steps };
        let released = h.timing == config::HlcTiming::Released && rule.released_loop();
        let humanoid = skillmimic_core::characters::skillmimic::spec(Default::default());
        let spec = TaskSpec {
            name: R::NAME,
            obs_dim: layout::STATE_DIM + rule.task_obs_dim(),
            action_space,
            max_episode_steps: (h.episode_length - 1).div_ceil(hold),
            term_names: crate::task::names(&rule.term_names()),
            metric_names: crate::task::names(&rule.metric_names()),
            info_names: rule.info_names().iter().map(|s| s.to_string()).collect(),
            steps_per_action: hold,
            hold_through_end: released,
            choice_labels,
            max_step_reward: rule.max_step_reward(),
            token_groups: [
                ("state".to_string(), layout::STATE_DIM),
                (R::NAME.to_string(), rule.task_obs_dim()),
            ]
            .into_iter()
            .filter(|g| g.1 > 0)
            .collect(),
            obs_blocks: crate::obs_blocks::ObsLayout::BallState { part: R::NAME }
                .blocks(&humanoid, layout::STATE_DIM + rule.task_obs_dim()),
            ..TaskSpec::default()
        };
        let threads = if cfg.threads == 0 { rayon::current_num_threads() } else { cfg.threads };
        Ok(Self {
            rule,
            cfg: h.clone(),
            lib,
            spec,
            driver,
            threads,
            ball_radius,
            llc_obs: Vec::new(),
            skills: vec![0; cfg.num_envs],
            released,
        })
    }

    /// The frozen policy.
    pub fn driver(&self) -> &Driver {
        &self.driver
    }
    /// Whether the action is part embeddings (a modular checkpoint) rather than skill choices.
    pub fn is_latent(&self) -> bool {
        matches!(self.driver, Driver::Parts(_))
    }
    /// Low-level steps each high-level action is held for (`llc_steps` or `latent_steps`).
    pub fn hold_steps(&self) -> usize {
        if self.is_latent() { self.cfg.latent_steps } else { self.cfg.llc_steps }
    }
    /// `N × 902` skill-policy observations of the last low-level step (skill choices only).
    pub fn llc_observations(&self) -> &[f32] {
        &self.llc_obs
    }

    fn write_obs(&self, slot: &HlSlot<R::Goal>, st: &EnvState<'_>, obs: &mut [f32]) {
        write_state_obs(st, &mut obs[..layout::STATE_DIM]);
        self.rule.task_obs(slot.observed_goal(), st, &mut obs[layout::STATE_DIM..]);
    }
}

impl<R: Rule> Task for HighLevel<R> {
    type Slot = HlSlot<R::Goal>;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn new_slot(&self) -> HlSlot<R::Goal> {
        HlSlot::default()
    }

    fn plan_reset(
        &mut self,
        _i: usize,
        slot: &mut HlSlot<R::Goal>,
        rng: &mut ChaCha8Rng,
        _scene: &Scene,
        state: &mut ResetState,
    ) {
        let clip = self.lib.sample_clip(rng);
        let m = self.lib.get(clip);
        let frame = self.cfg.start_frame.min(m.clip.num_frames - 2);
        fill_from_clip(state, m, frame);
        if BALL_FREE_SKILLS.contains(&m.clip.skill) {
            random_ball(state, self.ball_radius, rng);
        }
        let goal = self.rule.sample_goal(state.root_pos, rng);
        let previous = std::mem::replace(&mut slot.goal, goal);
        slot.progress = 0;
        slot.shown = self.released.then_some(previous);
    }

    fn after_reset(
        &self,
        _i: usize,
        slot: &mut HlSlot<R::Goal>,
        st: &EnvState<'_>,
        obs: &mut [f32],
    ) {
        self.write_obs(slot, st, obs);
    }

    /// The new episode's goal.
    fn reset_info(&self, slot: &HlSlot<R::Goal>, info: &mut [f32]) {
        self.rule.info(&slot.goal, info);
    }

    fn set_info(&self, slot: &mut HlSlot<R::Goal>, values: &[f32]) -> bool {
        self.rule.set_info(&mut slot.goal, values);
        slot.shown = None;
        true
    }

    fn markers(&self, info: &[f32], out: &mut Vec<crate::markers::Marker>) {
        self.rule.markers(info, out);
    }

    fn step_env(&self, _i: usize, slot: &mut HlSlot<R::Goal>, st: &EnvState<'_>, out: StepOut<'_>) {
        slot.progress += 1;
        slot.shown = None;
        // the released loop observes before the reward updates the latches
        let released = self.released;
        if released {
            self.write_obs(slot, st, out.obs);
        }
        let r = self.rule.reward(&mut slot.goal, slot.progress, st, out.terms, out.metrics);
        *out.reward = r as f32;
        self.rule.info(&slot.goal, out.info);
        if !released {
            self.write_obs(slot, st, out.obs);
        }
        let (terminated, truncated) = episode_end(&self.cfg, slot.progress, st);
        *out.terminated = u8::from(terminated);
        *out.truncated = u8::from(truncated);
    }

    fn observe(&self, slot: &mut HlSlot<R::Goal>, st: &EnvState<'_>, obs: &mut [f32]) {
        self.write_obs(slot, st, obs);
    }

    fn transforms_actions(&self) -> bool {
        true
    }

    /// Choice → skill label → the frozen skill policy's PD targets; or part embeddings → the
    /// frozen part controllers' PD targets.
    fn actions_to_targets(
        &mut self,
        _slots: &[HlSlot<R::Goal>],
        obs: &[f32],
        actions: &[f32],
        targets: &mut [f32],
    ) -> Result<(), EnvError> {
        let llc = match &mut self.driver {
            Driver::Parts(p) => {
                let n = actions.len() / p.latent_dim();
                p.act(actions, n, self.threads, targets);
                return Ok(());
            }
            Driver::Skills(a) => a,
        };
        let (n, d, labels) = (actions.len(), self.spec.obs_dim, self.rule.labels());
        self.llc_obs.resize(n * layout::OBS_DIM, 0.0);
        self.skills.resize(n, 0);
        for (i, &a) in actions.iter().enumerate() {
            if !(a >= 0.0 && (a as usize) < labels.len() && a.fract() == 0.0) {
                return Err(EnvError::DiscreteAction { env: i, value: a, n: labels.len() });
            }
            let row = &mut self.llc_obs[i * layout::OBS_DIM..(i + 1) * layout::OBS_DIM];
            row[..layout::STATE_DIM].copy_from_slice(&obs[i * d..i * d + layout::STATE_DIM]);
            self.skills[i] = labels[a as usize];
            write_skill(self.skills[i], &mut row[layout::SKILL]);
        }
        debug_assert_eq!(layout::SKILL.len(), SKILL_WIDTH);
        llc.act(&self.llc_obs, n, self.threads, targets);
        Ok(())
    }
}

/// Build the high-level environment of `rule` from `[env]` (driver keys, `motion`), `[env.hlc]`.
pub fn build<R: Rule>(cfg: &EnvConfig, rule: R) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<HlcConfig>().validate()?;
    if cfg.motion.is_empty() {
        return Err(bad(
            "env.motion",
            "no clip file or folder given (the high-level episodes start from clip frames)",
        )
        .into());
    }
    let lib = Arc::new(load_motion_library(&cfg.motion)?);
    let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
    let ball_radius = scene.options().ball.map_or(0.12, |b| b.radius);
    let task = HighLevel::new(rule, cfg, lib, ball_radius)?;
    Ok(Box::new(VecEnv::with_task(task, scene, cfg.num_envs, cfg.threads, cfg.start_seed(0))?))
}
