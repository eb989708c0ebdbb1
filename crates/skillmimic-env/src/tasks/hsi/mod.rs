//! The TokenHSI tasks (TokenHSI supplementary §B.2): `hsi_follow`, `hsi_sit`, `hsi_climb`,
//! `hsi_carry` on the 32-DoF TokenHSI character ([`skillmimic_core::hsi_character`]), and the
//! skill-composition tasks `hsi_follow_carry`, `hsi_sit_carry`, `hsi_climb_carry` (§B.3,
//! [`compose`]).
//!
//! [`HsiVecEnv<T>`] is the batched driver of these tasks, the TokenHSI character's counterpart of
//! [`VecEnv`](crate::VecEnv) with the same [`Env`] face and the same semantics (buffers, explicit
//! or SAME_STEP autoreset, terminal observations). It owns what every TokenHSI task shares:
//! * the observation `[proprioception 222 | task observation]` ([`proprio`]);
//! * the character-fall termination (a body other than the feet touching the floor or an object
//!   below `env.hsi.termination_height`, from the second step on — ASE's rule);
//! * the time limit (`episode_length` of the task's table, truncation) and the random stream of
//!   episode starts (seeded, sequential over environments: independent of the thread count);
//! * the previous root and object positions, from which the rewards' velocities are the finite
//!   differences over one 1/30 s policy step (as the released InterPhys/TokenHSI code computes
//!   them).
//!
//! A task ([`HsiTask`]) supplies its objects (one set of sizes per compiled variant), the start of
//! an episode, its observation, reward terms, metrics and task-specific ends.

pub mod carry;
pub mod climb;
pub mod compose;
pub mod driver;
pub mod follow;
pub mod geometry;
pub mod proprio;
pub mod sit;
pub mod style;

use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{HsiEnvState, HsiObject, HsiReset, HsiScene};

pub use driver::HsiVecEnv;

use crate::task::TaskSpec;

/// Policy step (s): 4 physics steps of 1/120 s.
pub const DT: f64 = 1.0 / 30.0;

/// The [`TaskSpec`] of a TokenHSI task: observation `[proprioception 222 | task_obs]`, the
/// character's 32 actions, one environment step per action.
pub fn hsi_spec(
    name: &'static str,
    task_obs: usize,
    episode_length: usize,
    term_names: Vec<&'static str>,
    info_names: Vec<String>,
) -> TaskSpec {
    TaskSpec {
        name,
        obs_dim: proprio::PROPRIO_DIM + task_obs,
        action_space: crate::task::ActionSpace::Box {
            dim: skillmimic_core::hsi_character::NUM_DOFS,
        },
        max_episode_steps: episode_length,
        term_names,
        metric_names: vec!["error_m", "success"],
        info_names,
        steps_per_action: 1,
        choice_labels: Vec::new(),
        token_groups: vec![
            ("proprio".to_string(), proprio::PROPRIO_DIM),
            (name.to_string(), task_obs),
        ],
    }
}

/// The batched environment of `task` from the `[env]` table (`variants` compiled object
/// variants): what every TokenHSI registry constructor does after building its task.
pub fn build_env<T: HsiTask>(
    task: T,
    cfg: &crate::config::EnvConfig,
    variants: usize,
    episode_length: usize,
) -> Result<Box<dyn crate::vec_env::Env>, crate::error::EnvError> {
    let h = &cfg.hsi;
    Ok(Box::new(HsiVecEnv::new(
        task,
        variants,
        h.object_seed,
        cfg.num_envs,
        cfg.threads,
        cfg.start_seed(0),
        episode_length,
        h.termination_height,
    )?))
}

/// What a task sees of one environment after a step.
pub struct Ctx<'a> {
    pub st: &'a HsiEnvState<'a>,
    /// Root position before the step (world, m).
    pub prev_root: [f64; 3],
    /// Position of object 0 before the step (world, m).
    pub prev_obj: [f64; 3],
    /// Policy steps taken in this episode (1 after the first step).
    pub steps: usize,
    /// The character fell in this step (the episode terminates): no task counts a fall as a
    /// success.
    pub fallen: bool,
}

/// What a task writes for one environment after a step.
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

/// One TokenHSI task.
pub trait HsiTask: Send + Sync + 'static {
    /// Per-environment goal of the current episode.
    type Goal: Send + Sync + Clone + Default;
    /// Sizes and names (`obs_dim` = 222 + the task observation).
    fn spec(&self) -> &TaskSpec;
    /// The objects of one compiled variant (sizes drawn from `rng`).
    fn objects(&self, rng: &mut ChaCha8Rng) -> Vec<HsiObject>;
    /// The start of an episode in `scene`: character and object states, and the goal.
    fn plan(
        &self,
        scene: &HsiScene,
        rng: &mut ChaCha8Rng,
        reset: &mut HsiReset,
        goal: &mut Self::Goal,
    );
    /// The task observation (`obs_dim − 222` entries) at `steps` policy steps into the episode.
    fn observe(&self, goal: &Self::Goal, st: &HsiEnvState<'_>, steps: usize, out: &mut [f32]);
    /// Reward terms, metrics and task ends after a step.
    fn step(&self, goal: &mut Self::Goal, ctx: &Ctx<'_>, out: &mut TaskOut<'_>);
    /// Task information at `steps` policy steps into the episode (`TaskSpec::info_names`:
    /// targets, object poses and sizes, in world coordinates).
    fn info(&self, goal: &Self::Goal, steps: usize, out: &mut [f32]);
}
