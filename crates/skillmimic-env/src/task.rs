//! The task seam: what every task (imitation, stand, tracking, the high-level tasks, the
//! TokenHSI tasks) supplies to the one batched driver [`VecEnv`](crate::vec_env::VecEnv).
//!
//! The driver owns the simulation batch, the random stream of episode starts, the output buffers
//! and the reset/autoreset logic; a task owns its per-environment state (`Slot`: episode
//! bookkeeping, buffers of frozen networks) and the formulas: observation, reward and its terms,
//! termination, per-step metrics and where episodes start. Calls happen in this order:
//!
//! * sequential, environment index ascending: [`Task::end_episode`] then [`Task::plan_reset`]
//!   for every environment being reset (they draw from the driver's seeded stream, so results do
//!   not depend on the thread count);
//! * parallel over the environments (one call per environment, on the simulation threads):
//!   [`Task::after_reset`] after the simulation was reset to the planned states, and
//!   [`Task::step_env`] after every physics step;
//! * sequential, once per step: [`Task::after_step`] (batch-level edits such as a reward shared by
//!   all environments on the same clip).
//!
//! A task whose spec declares `steps_per_action = k > 1` (the high-level tasks) has each of its
//! actions held for `k` physics steps by the driver ([`crate::vec_env`]); the calls above then
//! happen once per physics step.

use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{EnvState, ResetState, Scene};

/// Sizes and names a task declares; every buffer of the driver is sized from it.
#[derive(Clone, Debug, PartialEq)]
pub struct TaskSpec {
    /// Registry name (`imitation`, `stand`, …).
    pub name: &'static str,
    /// Observation width (float32 per environment).
    pub obs_dim: usize,
    /// What the policy sends each step.
    pub action_space: ActionSpace,
    /// Longest episode in policy steps (time limit; gymnasium's `max_episode_steps`).
    pub max_episode_steps: usize,
    /// Names of the reward terms written per step (the last one is usually the total).
    pub term_names: Vec<String>,
    /// Names of the per-step metrics (units in each task's doc).
    pub metric_names: Vec<String>,
    /// Names of the per-step task information entries (imitation: the contact-graph states;
    /// high-level tasks: the goal of the current episode).
    pub info_names: Vec<String>,
    /// Simulation (low-level) steps per action: 1 for the physical tasks, `llc_steps` (3) for
    /// the high-level tasks, whose samples the papers count in low-level steps.
    pub steps_per_action: usize,
    /// With `steps_per_action > 1`: every environment runs all the held steps, and an episode
    /// that ends inside them counts the steps simulated after its end (reward and terms: mean
    /// over all steps; terminated / truncated: set when any step set them; observation, metrics
    /// and information: the last step's) — the released SkillMimic high-level loop. `false`: the
    /// transition of such an environment ends at the step that ends its episode.
    pub hold_through_end: bool,
    /// Skill label of each discrete choice (high-level tasks: `control_mapping`); empty otherwise.
    pub choice_labels: Vec<u32>,
    /// The largest reward one policy step can earn, when the task's reward is bounded by
    /// construction (ModSkill's steering and reach: 1). Evaluations then report ModSkill's
    /// normalised return: an episode's undiscounted return over `max_step_reward ×
    /// max_episode_steps`, so an episode cut short by a fall scores less (seed 001 §4, Tab. 4).
    pub max_step_reward: Option<f64>,
    /// Observation columns after the proprioception that describe one body of the character
    /// (`tracking`: each tracked body's reference block), as (body, columns); empty otherwise. A
    /// part-wise policy (ModSkill's part tokens) gives them to the part of their body.
    pub body_blocks: Vec<(usize, std::ops::Range<usize>)>,
    /// The observation as named groups in column order, `(name, width)`, widths summing to
    /// `obs_dim`: the character/state part first, then one group per task observation and, for
    /// a multi-task environment, `("mask", K)` last (one 0/1 entry per task group, 1 = the
    /// group is active). A token policy gives each group but the mask one token. Empty: the
    /// task declares no groups.
    pub token_groups: Vec<(String, usize)>,
    /// The observation's named blocks in column order, with their bounds where the values are
    /// bounded by construction (rotation columns, one-hot entries): documentation, the ONNX
    /// metadata and the gymnasium observation space read them. Empty: one unnamed block.
    pub obs_blocks: Vec<crate::obs_blocks::ObsBlock>,
    /// The key under which the per-step task information (`info_names`) is reported to Python:
    /// `"contact_graph"` (the imitation task's simulated contact-graph states) or `"task_info"`.
    pub info_label: &'static str,
    /// Per-environment episode fields a task reports ([`crate::vec_env::Env::episode_info`],
    /// e.g. the clip, frame and skill of the imitation task); empty: none.
    pub episode_names: Vec<&'static str>,
}

impl Default for TaskSpec {
    fn default() -> Self {
        Self {
            name: "",
            obs_dim: 0,
            action_space: ActionSpace::Box { dim: 0 },
            max_episode_steps: 0,
            term_names: Vec::new(),
            metric_names: Vec::new(),
            info_names: Vec::new(),
            steps_per_action: 1,
            hold_through_end: false,
            choice_labels: Vec::new(),
            max_step_reward: None,
            body_blocks: Vec::new(),
            token_groups: Vec::new(),
            obs_blocks: Vec::new(),
            info_label: "task_info",
            episode_names: Vec::new(),
        }
    }
}

/// What an evaluation asks of the episode starts (`skillmimic eval --horizon H --start-frame
/// F`): each task applies it to its configuration in its own terms, or refuses it
/// (`TaskEntry::episode_starts`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EpisodeStarts {
    /// Episode length in policy steps.
    pub horizon: Option<usize>,
    /// The reference frame every episode starts from.
    pub start_frame: Option<usize>,
}

impl EpisodeStarts {
    /// The refusal of a task whose episodes start and end by its own rules (the default of
    /// tasks that declare nothing).
    pub fn refuse(cfg: &mut crate::config::EnvConfig, s: EpisodeStarts) -> Result<(), String> {
        if s == EpisodeStarts::default() {
            return Ok(());
        }
        Err(format!(
            "--horizon and --start-frame set up episodes of the tasks that start from clip frames \
                (imitation, tracking); task '{}' starts and ends its episodes by its own rules",
            cfg.task
        ))
    }
}

/// Owned names from literals (term, metric names).
pub fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The action space of a task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActionSpace {
    /// `dim` floats in [−1, 1] per environment (the physical tasks: PD targets × π rad of the
    /// humanoid's 156 dofs; values outside are clamped).
    Box { dim: usize },
    /// One choice among `n` per environment, sent as its index in a single float (0, 1, … n−1).
    Discrete { n: usize },
}

impl ActionSpace {
    /// Floats per environment in an action batch.
    pub fn width(&self) -> usize {
        match *self {
            ActionSpace::Box { dim } => dim,
            ActionSpace::Discrete { .. } => 1,
        }
    }
}

impl TaskSpec {
    /// Floats per environment in an action batch.
    pub fn act_dim(&self) -> usize {
        self.action_space.width()
    }
}

/// Per-environment outputs of one step, slices of the driver's buffers.
pub struct StepOut<'a> {
    /// `[obs_dim]`
    pub obs: &'a mut [f32],
    pub reward: &'a mut f32,
    /// `[term_names.len()]`
    pub terms: &'a mut [f32],
    /// `[info_names.len()]`
    pub info: &'a mut [f32],
    /// `[metric_names.len()]`
    pub metrics: &'a mut [f32],
    /// 1 = early termination (fall, instability).
    pub terminated: &'a mut u8,
    /// 1 = time limit reached.
    pub truncated: &'a mut u8,
}

/// A task of the batched environment (see the module doc for the call order).
pub trait Task: Send + Sync + 'static {
    /// Per-environment state (serde: saved with training checkpoints for an exact resume,
    /// [`crate::vec_env::Env::save_state`]).
    type Slot: Send + Sync + Clone + serde::Serialize + serde::de::DeserializeOwned;

    /// Sizes and names.
    fn spec(&self) -> &TaskSpec;
    /// The initial state of one environment's slot (before its first reset).
    fn new_slot(&self) -> Self::Slot;
    /// Choose the start of a new episode of environment `i` in `scene` (its scene variant): fill
    /// `state` (the simulation state to reset to, preallocated for the scene: write it in place)
    /// and `slot`. Random draws come from `rng`, the driver's seeded stream.
    fn plan_reset(
        &mut self,
        i: usize,
        slot: &mut Self::Slot,
        rng: &mut ChaCha8Rng,
        scene: &Scene,
        state: &mut ResetState,
    );
    /// Bookkeeping of environment `i`'s finished episode, before its next reset is planned.
    fn end_episode(&mut self, _i: usize, _slot: &Self::Slot) {}
    /// After the simulation reset: finish the slot from the actual state and write the first
    /// observation.
    fn after_reset(&self, i: usize, slot: &mut Self::Slot, st: &EnvState<'_>, obs: &mut [f32]);
    /// Task information of a freshly reset environment (default: left as it is until the next
    /// step writes it).
    fn reset_info(&self, _slot: &Self::Slot, _info: &mut [f32]) {}
    /// After a physics step: observation, reward, terms, info, metrics and done flags.
    fn step_env(&self, i: usize, slot: &mut Self::Slot, st: &EnvState<'_>, out: StepOut<'_>);
    /// Recompute the observation from the current state (after raw state edits), keeping any
    /// entries that only a step can compute; bookkeeping that describes "the state before the
    /// next step" (e.g. previous positions for finite differences) is taken anew.
    fn observe(&self, slot: &mut Self::Slot, st: &EnvState<'_>, obs: &mut [f32]);
    /// Set the episode's task information (`TaskSpec::info_names` order; e.g. move the goal in
    /// interactive play). Returns `false` for a task without settable information (the
    /// default).
    fn set_info(&self, _slot: &mut Self::Slot, _values: &[f32]) -> bool {
        false
    }
    /// Whether [`Task::actions_to_targets`] is used (default: no — the actions are the PD targets,
    /// which needs a `Box` action space as wide as the character's dof vector).
    fn transforms_actions(&self) -> bool {
        false
    }
    /// Turn the policy's actions (`N × act_dim`) into PD targets of the character (`N × dofs`,
    /// [−1, 1]) before each physics step; `obs` (`N × obs_dim`) are the current observations.
    /// Tasks that run a frozen skill policy inside the step, or take discrete actions, do it here
    /// (and return `true` from `transforms_actions`); invalid actions are an error.
    fn actions_to_targets(
        &mut self,
        _slots: &[Self::Slot],
        _obs: &[f32],
        _actions: &[f32],
        _targets: &mut [f32],
    ) -> Result<(), crate::error::EnvError> {
        Ok(())
    }
    /// Batch-level work after every environment stepped.
    fn after_step(&mut self, _slots: &[Self::Slot], _reward: &mut [f32], _terms: &[f32]) {}
    /// The episode fields of one environment in [`TaskSpec::episode_names`] order (`out` is as
    /// long as those names; default: none declared).
    fn episode_info(&self, _slot: &Self::Slot, _out: &mut [i64]) {}
    /// The motion library the task plays, where it loads one: environments of the same task
    /// built for evaluation or videos share it ([`crate::registry::make_sharing`]).
    fn library(&self) -> Option<&std::sync::Arc<skillmimic_motion::MotionLibrary>> {
        None
    }
    /// Write the reference state of frame `frame` of clip `clip` (the values of the `clip` and
    /// `ref_frame` episode fields) into `state`, a state of the task's scene, and return `true`,
    /// where the task plays reference clips of any character (videos draw it as a ghost); the
    /// default: `false`, none.
    fn reference_state(&self, _clip: usize, _frame: usize, _state: &mut ResetState) -> bool {
        false
    }
    /// The SkillMimic-V2 history window (`k × 316`, oldest first) of one environment, where the
    /// task keeps one (default: none).
    fn history_window(&self, _slot: &Self::Slot) -> Option<Vec<f32>> {
        None
    }
    /// Append the visual markers of an information row (`info_names` order; world metres) to
    /// `out`: what videos and the interactive viewer draw for the task (default: none).
    fn markers(&self, _info: &[f32], _out: &mut Vec<crate::markers::Marker>) {}
    /// Width of the per-frame style features the task computes from the simulation state for a
    /// motion prior (default 0: none; the prior then reads the observation).
    fn style_dim(&self) -> usize {
        0
    }
    /// Write the style features (`style_dim` wide) of the state `st` into `out`.
    fn style_features(&self, _st: &EnvState<'_>, _out: &mut [f32]) {}
    /// The task's own state that changes while it runs and that later steps depend on (e.g. the
    /// SkillMimic-V2 sampler's tables), encoded for [`Task::restore_shared`]; scratch buffers
    /// rewritten before every use are not part of it. Default: none (empty).
    fn save_shared(&self) -> Vec<u8> {
        Vec::new()
    }
    /// Restore what [`Task::save_shared`] wrote; an encoding of another task or size is an error
    /// saying what differs.
    fn restore_shared(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "task '{}' keeps no shared state, got {} bytes",
                self.spec().name,
                bytes.len()
            ))
        }
    }
}
