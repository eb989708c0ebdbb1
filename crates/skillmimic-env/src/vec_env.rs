//! The batched driver shared by every task: simulation step, parallel per-environment task calls,
//! resets and SAME_STEP autoreset, output buffers sized from the task's [`TaskSpec`].
//!
//! [`VecEnv<T>`] is generic over the task (static dispatch inside the per-environment loops);
//! [`Env`] is its object-safe face, used by the learner and the Python package for any
//! registered task (`Box<dyn Env>` from [`crate::registry::make`]).
//!
//! Each [`step`](VecEnv::step) advances all environments one policy step, then, in parallel on the
//! simulation threads, lets the task compute every environment's observation, reward, terms,
//! metrics and done flags. Finished environments are reset either explicitly
//! ([`reset_done`](VecEnv::reset_done), the reference learner's loop) or automatically in the same
//! call (`autoreset`, gymnasium's SAME_STEP semantics, terminal observations kept in `final_obs`).

use std::any::Any;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::iter::Either;
use rayon::prelude::*;
use skillmimic_core::skeleton::NUM_DOFS;
use skillmimic_sim::{BatchSim, MjBatch, ResetState, Scene};

use crate::error::EnvError;
use crate::task::{StepOut, Task, TaskSpec};

/// Output buffers of the last step (environment-major, float32).
#[derive(Clone, Debug, Default)]
pub struct StepBuffers {
    /// `[N][obs_dim]`
    pub obs: Vec<f32>,
    /// `[N]`
    pub reward: Vec<f32>,
    /// `[N][terms]` reward terms in `TaskSpec::term_names` order.
    pub terms: Vec<f32>,
    /// `[N][info]` task information (`TaskSpec::info_names`; imitation: the simulated
    /// contact-graph entries).
    pub info: Vec<f32>,
    /// `[N][metrics]` per-step metrics (`TaskSpec::metric_names`).
    pub metrics: Vec<f32>,
    /// `[N]` 1 = early termination (fall or instability).
    pub terminated: Vec<u8>,
    /// `[N]` 1 = time limit reached.
    pub truncated: Vec<u8>,
    /// `[N]` 1 = MuJoCo reported a numerical instability (non-finite or huge `qpos`, `qvel` or
    /// `qacc`; MuJoCo then reset that environment's physics) during the last `step` call; such a
    /// step also ends the episode (`terminated`). Set by every step, left as is by resets.
    pub unstable: Vec<u8>,
    /// `[N][obs_dim]` terminal observations of environments auto-reset in the last step.
    pub final_obs: Vec<f32>,
    /// `[N]` 1 where `final_obs` is valid.
    pub final_mask: Vec<u8>,
}

impl StepBuffers {
    /// Zeroed buffers for `n` environments of a task declaring `spec`.
    pub fn for_spec(n: usize, spec: &TaskSpec) -> Self {
        Self {
            obs: vec![0.0; n * spec.obs_dim],
            reward: vec![0.0; n],
            terms: vec![0.0; n * spec.term_names.len()],
            info: vec![0.0; n * spec.info_names.len()],
            metrics: vec![0.0; n * spec.metric_names.len()],
            terminated: vec![0; n],
            truncated: vec![0; n],
            unstable: vec![0; n],
            final_obs: vec![0.0; n * spec.obs_dim],
            final_mask: vec![0; n],
        }
    }
}

/// Per-environment rows of a `[N][width]` buffer, also for width 0 (N empty rows: a zero-width
/// buffer must not shorten the zipped per-environment iteration).
pub(crate) fn rows(
    buf: &mut [f32],
    n: usize,
    width: usize,
) -> impl IndexedParallelIterator<Item = &mut [f32]> {
    if width == 0 {
        Either::Left((0..n).into_par_iter().map(|_| <&mut [f32]>::default()))
    } else {
        Either::Right(buf.par_chunks_mut(width))
    }
}

/// The random streams of episode starts of `n` environments: environment `i` draws from its own
/// ChaCha8 stream seeded `seed + i` (wrapping). This is gymnasium's convention for a vector
/// environment reset with `seed` (sub-environment `i` gets `seed + i`), so a batch of `n`
/// environments plans the same episodes as `n` single environments seeded `seed`, `seed + 1`, …,
/// whatever the autoreset mode, the order of resets or the thread count. (A task with state
/// shared across environments, such as SkillMimic-V2's adaptive trajectory sampling, still couples
/// them through that state.)
pub fn env_streams(seed: u64, n: usize) -> Vec<ChaCha8Rng> {
    (0..n as u64).map(|i| ChaCha8Rng::seed_from_u64(seed.wrapping_add(i))).collect()
}

/// The batched environment of task `T`.
pub struct VecEnv<T: Task> {
    pub(crate) task: T,
    pub(crate) slots: Vec<T::Slot>,
    sim: BatchSim,
    /// One stream of episode starts per environment ([`env_streams`]).
    rngs: Vec<ChaCha8Rng>,
    buf: StepBuffers,
    autoreset: bool,
    reset_mask: Vec<bool>,
    reset_states: Vec<ResetState>,
    /// `N × 156` PD targets of tasks that transform their actions.
    targets: Vec<f32>,
}

impl<T: Task> VecEnv<T> {
    /// Build the scene and the batch for `task`, then reset every environment. `seed` seeds the
    /// stream of episode starts; `threads` = simulation threads (0 = one per core).
    pub fn with_task(
        task: T,
        scene: Arc<Scene>,
        num_envs: usize,
        threads: usize,
        seed: u64,
    ) -> Result<Self, EnvError> {
        let n = num_envs;
        let sim =
            BatchSim::new(scene, n, crate::config_range::capped_threads(threads, "env.threads"))?;
        let spec = task.spec().clone();
        let slots = (0..n).map(|_| task.new_slot()).collect();
        let buf = StepBuffers::for_spec(n, &spec);
        let mut env = Self {
            task,
            slots,
            sim,
            rngs: env_streams(seed, n),
            buf,
            autoreset: false,
            reset_mask: vec![false; n],
            reset_states: vec![ResetState::default(); n],
            targets: Vec::new(),
        };
        env.reset_all(None);
        Ok(env)
    }

    /// The task.
    pub fn task(&self) -> &T {
        &self.task
    }
    /// Mutable access to the task (evaluation options).
    pub fn task_mut(&mut self) -> &mut T {
        &mut self.task
    }
    /// All per-environment task slots.
    pub fn slots(&self) -> &[T::Slot] {
        &self.slots
    }
    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.slots.len()
    }
    /// Observation width.
    pub fn obs_dim(&self) -> usize {
        self.task.spec().obs_dim
    }
    /// Action width.
    pub fn act_dim(&self) -> usize {
        self.task.spec().act_dim()
    }
    /// The simulation batch (state read-out, raw MuJoCo data).
    pub fn sim(&self) -> &BatchSim {
        &self.sim
    }
    /// Mutable access to the simulation batch (advanced use: raw state edits).
    pub fn sim_mut(&mut self) -> &mut BatchSim {
        &mut self.sim
    }
    /// Output buffers of the last step or reset.
    pub fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    /// PD targets (`N × 156`, [−1, 1]) the task's action transform gave in the last step (empty
    /// for tasks whose actions are the targets).
    pub fn last_targets(&self) -> &[f32] {
        &self.targets
    }
    /// SAME_STEP autoreset on or off (default off: call [`reset_done`](Self::reset_done)).
    pub fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }

    /// Recompute every observation from the current simulation state (after raw state edits).
    pub fn refresh_observations(&mut self) {
        let Self { sim, slots, buf, task, .. } = self;
        let (state, task, d) = (sim.state(), &*task, task.spec().obs_dim);
        sim.install(|| {
            (slots.par_iter(), buf.obs.par_chunks_mut(d))
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (slot, obs))| task.observe(slot, &state.env(i), obs));
        });
    }

    /// Reseed (if `seed` is given) and reset every environment.
    pub fn reset_all(&mut self, seed: Option<u64>) {
        if let Some(s) = seed {
            self.rngs = env_streams(s, self.num_envs());
        }
        let mask = vec![true; self.num_envs()];
        self.reset_envs(&mask);
    }

    /// Reset the environments selected by `mask` to newly planned starts.
    pub fn reset_envs(&mut self, mask: &[bool]) {
        assert_eq!(mask.len(), self.num_envs(), "reset mask length");
        for (i, &m) in mask.iter().enumerate() {
            self.reset_mask[i] = m;
            if m {
                self.task.plan_reset(
                    i,
                    &mut self.slots[i],
                    &mut self.rngs[i],
                    &mut self.reset_states[i],
                );
            }
        }
        self.apply_resets(true);
    }

    /// Reset the environments that terminated or were truncated in the last step.
    pub fn reset_done(&mut self) {
        let mut any = false;
        for i in 0..self.num_envs() {
            let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
            self.reset_mask[i] = done;
            if done {
                any = true;
                self.task.end_episode(i, &self.slots[i]);
                self.task.plan_reset(
                    i,
                    &mut self.slots[i],
                    &mut self.rngs[i],
                    &mut self.reset_states[i],
                );
            }
        }
        if any {
            self.apply_resets(true);
        }
    }

    /// Reset the simulation of the environments in `reset_mask` to the planned states, let the
    /// task finish them and write their observations (and clear the done flags if asked).
    fn apply_resets(&mut self, clear_flags: bool) {
        self.sim
            .reset(&self.reset_mask, &self.reset_states)
            .expect("reset states are planned by the task from validated data");
        let Self { sim, slots, buf, reset_mask, task, .. } = self;
        let (state, task, mask, d) = (sim.state(), &*task, &*reset_mask, task.spec().obs_dim);
        sim.install(|| {
            (slots.par_iter_mut(), buf.obs.par_chunks_mut(d)).into_par_iter().enumerate().for_each(
                |(i, (slot, obs))| {
                    if mask[i] {
                        task.after_reset(i, slot, &state.env(i), obs);
                    }
                },
            );
        });
        let ni = task.spec().info_names.len();
        for (i, &m) in mask.iter().enumerate() {
            if m && ni > 0 {
                task.reset_info(&slots[i], &mut buf.info[i * ni..(i + 1) * ni]);
            }
        }
        if clear_flags {
            for (i, &m) in mask.iter().enumerate() {
                if m {
                    buf.terminated[i] = 0;
                    buf.truncated[i] = 0;
                }
            }
        }
    }

    /// Advance all environments by one policy step with `actions` (`N × act_dim`, clamped to
    /// [−1, 1]).
    pub fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        let n = self.num_envs();
        if self.act_dim() == NUM_DOFS && !self.task.transforms_actions() {
            // the actions are the PD targets (checked by the simulation)
            self.sim.step(actions)?;
        } else {
            if actions.len() != n * self.act_dim() {
                return Err(EnvError::ActionShape {
                    expected: n * self.act_dim(),
                    got: actions.len(),
                });
            }
            self.targets.resize(n * NUM_DOFS, 0.0);
            self.task.actions_to_targets(&self.slots, &self.buf.obs, actions, &mut self.targets)?;
            self.sim.step(&self.targets)?;
        }
        let Self { sim, slots, buf, task, .. } = self;
        let spec = task.spec();
        let (d, nt, ni, nm) =
            (spec.obs_dim, spec.term_names.len(), spec.info_names.len(), spec.metric_names.len());
        let (state, t) = (sim.state(), &*task);
        sim.install(|| {
            (
                slots.par_iter_mut(),
                rows(&mut buf.obs, n, d),
                buf.reward.par_iter_mut(),
                rows(&mut buf.terms, n, nt),
                rows(&mut buf.info, n, ni),
                rows(&mut buf.metrics, n, nm),
                buf.terminated.par_iter_mut(),
                buf.truncated.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(
                    |(i, (slot, obs, reward, terms, info, metrics, terminated, truncated))| {
                        t.step_env(
                            i,
                            slot,
                            &state.env(i),
                            StepOut { obs, reward, terms, info, metrics, terminated, truncated },
                        );
                    },
                );
        });
        buf.unstable.copy_from_slice(&state.unstable);
        self.task.after_step(&self.slots, &mut self.buf.reward, &self.buf.terms);
        if self.autoreset {
            let n = self.num_envs();
            let mut any = false;
            for i in 0..n {
                let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
                self.buf.final_mask[i] = u8::from(done);
                self.reset_mask[i] = done;
                if done {
                    any = true;
                    self.buf.final_obs[i * d..(i + 1) * d]
                        .copy_from_slice(&self.buf.obs[i * d..(i + 1) * d]);
                }
            }
            if any {
                for i in 0..n {
                    if self.reset_mask[i] {
                        self.task.end_episode(i, &self.slots[i]);
                        self.task.plan_reset(
                            i,
                            &mut self.slots[i],
                            &mut self.rngs[i],
                            &mut self.reset_states[i],
                        );
                    }
                }
                // the flags describe the finished step: keep them
                self.apply_resets(false);
            }
        }
        Ok(())
    }
}

/// The object-safe face of [`VecEnv`] for any task.
pub trait Env: Send + Sync {
    /// The task's sizes and names.
    fn spec(&self) -> &TaskSpec;
    fn num_envs(&self) -> usize;
    fn obs_dim(&self) -> usize {
        self.spec().obs_dim
    }
    fn act_dim(&self) -> usize {
        self.spec().act_dim()
    }
    fn buffers(&self) -> &StepBuffers;
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError>;
    fn reset_all(&mut self, seed: Option<u64>);
    fn reset_envs(&mut self, mask: &[bool]);
    fn reset_done(&mut self);
    /// Close the episodes of the environments in `mask` without resetting them: the task's
    /// end-of-episode bookkeeping (SkillMimic-V2's ATS statistics), as `reset_done` and SAME_STEP
    /// autoreset do before a reset. For callers that reset through
    /// [`reset_envs`](Env::reset_envs) (gymnasium's NEXT_STEP and DISABLED modes).
    fn end_episodes(&mut self, _mask: &[bool]) {}
    fn set_autoreset(&mut self, on: bool);
    fn refresh_observations(&mut self);
    /// The SkillMimic humanoid batch (`None` for tasks of another character, e.g. TokenHSI's).
    fn humanoid_sim(&self) -> Option<&BatchSim>;
    /// Raw MuJoCo access, whatever the character (rendering, recording, state edits).
    fn mujoco(&self) -> &dyn MjBatch;
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch;
    /// Overwrite environment `i`'s task information entries (`TaskSpec::info_names`; the
    /// high-level tasks: move the goal, e.g. in interactive play) and recompute its observation.
    fn set_task_info(&mut self, _i: usize, _values: &[f32]) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(format!(
            "task '{}' has no settable task information",
            self.spec().name
        )))
    }
    /// PD targets (`N × 156`, [−1, 1]) a task's action transform gave in the last simulation
    /// step (high-level tasks: the frozen skill policy's actions); empty when the actions are the
    /// targets.
    fn pd_targets(&self) -> &[f32];
    /// The tasks of a multi-task environment with their environment rows (empty: one task); the
    /// motion prior keeps one discriminator per entry.
    fn task_rows(&self) -> Vec<(String, std::ops::Range<usize>)> {
        Vec::new()
    }
    /// Downcast to the concrete `VecEnv<T>` (task-specific accessors).
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Task> Env for VecEnv<T> {
    fn spec(&self) -> &TaskSpec {
        self.task.spec()
    }
    fn num_envs(&self) -> usize {
        VecEnv::num_envs(self)
    }
    fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        VecEnv::step(self, actions)
    }
    fn reset_all(&mut self, seed: Option<u64>) {
        VecEnv::reset_all(self, seed)
    }
    fn reset_envs(&mut self, mask: &[bool]) {
        VecEnv::reset_envs(self, mask)
    }
    fn reset_done(&mut self) {
        VecEnv::reset_done(self)
    }
    fn end_episodes(&mut self, mask: &[bool]) {
        for (i, _) in mask.iter().enumerate().filter(|m| *m.1) {
            self.task.end_episode(i, &self.slots[i]);
        }
    }
    fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }
    fn refresh_observations(&mut self) {
        VecEnv::refresh_observations(self)
    }
    fn humanoid_sim(&self) -> Option<&BatchSim> {
        Some(&self.sim)
    }
    fn mujoco(&self) -> &dyn MjBatch {
        &self.sim
    }
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch {
        &mut self.sim
    }
    fn pd_targets(&self) -> &[f32] {
        &self.targets
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
