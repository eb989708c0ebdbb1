//! The one batched driver of every task and every character: simulation step, parallel
//! per-environment task calls, resets and the only autoreset, output buffers sized from the
//! task's [`TaskSpec`].
//!
//! [`VecEnv<T>`] is generic over the task (static dispatch inside the per-environment loops);
//! [`Env`] (`face`) is its object-safe face, used by the learner and the Python package for any
//! registered task (`Box<dyn Env>` from [`crate::registry::make`]).
//!
//! Each [`step`](VecEnv::step) advances all environments one policy step: the task's actions
//! (or the PD targets a task computes from them) drive one physics step of the batch, then, in
//! parallel on the simulation threads, the task computes every environment's observation,
//! reward, terms, metrics and done flags. A task declaring `steps_per_action = k > 1` (the
//! high-level tasks) has its action held for `k` such steps (`hold`). Finished environments
//! are reset either explicitly ([`reset_done`](VecEnv::reset_done), the reference learner's
//! loop) or automatically in the same call (`autoreset`, gymnasium's SAME_STEP semantics,
//! terminal observations kept in `final_obs`).

mod buffers;
mod face;
mod hold;
mod pause;
pub mod saved;

use std::any::Any;
use std::sync::Arc;

use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use skillmimic_sim::{BatchSim, MjBatch, ResetState, Scene};

pub use buffers::{StepBuffers, env_streams};
pub(crate) use buffers::{copy_row, rows};
pub use face::Env;

use crate::error::EnvError;
use crate::task::{StepOut, Task, TaskSpec};
use hold::Hold;

/// The batched environment of task `T`.
pub struct VecEnv<T: Task> {
    pub(crate) task: T,
    pub(crate) slots: Vec<T::Slot>,
    sim: BatchSim,
    /// One stream of episode starts per environment ([`env_streams`]).
    rngs: Vec<ChaCha8Rng>,
    /// What the task writes after each physics step.
    buf: StepBuffers,
    /// The held-action aggregation of a task with `steps_per_action > 1` (its buffers are the
    /// ones the caller sees).
    hold: Option<Hold>,
    autoreset: bool,
    reset_mask: Vec<bool>,
    reset_states: Vec<ResetState>,
    /// `N × dofs` PD targets of tasks that transform their actions.
    targets: Vec<f32>,
}

impl<T: Task> VecEnv<T> {
    /// Build the batch of `num_envs` environments of `scene` for `task`, then reset every
    /// environment. `seed` seeds the streams of episode starts; `threads` = simulation threads
    /// (0 = one per core).
    pub fn with_task(
        task: T,
        scene: Arc<Scene>,
        num_envs: usize,
        threads: usize,
        seed: u64,
    ) -> Result<Self, EnvError> {
        Self::with_variants(task, vec![scene], num_envs, threads, seed)
    }

    /// [`with_task`](Self::with_task) over scene variants (environment `i` uses variant
    /// `i % variants.len()`; e.g. objects of different sizes).
    pub fn with_variants(
        task: T,
        variants: Vec<Arc<Scene>>,
        num_envs: usize,
        threads: usize,
        seed: u64,
    ) -> Result<Self, EnvError> {
        let n = num_envs;
        let threads = crate::config_range::capped_threads(threads, "env.threads");
        let sim = BatchSim::with_variants(variants, n, threads)?;
        let spec = task.spec().clone();
        let slots = (0..n).map(|_| task.new_slot()).collect();
        let buf = StepBuffers::for_spec(n, &spec);
        let hold = (spec.steps_per_action > 1).then(|| Hold::new(n, &spec));

        let rest = ResetState::rest(sim.scene());
        let mut env = Self {
            task,
            slots,
            sim,
            rngs: env_streams(seed, n),
            buf,
            hold,
            autoreset: false,
            reset_mask: vec![false; n],
            reset_states: vec![rest; n],
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
        self.hold.as_ref().map_or(&self.buf, |h| &h.out)
    }
    /// The buffers of the last physics step (for a task with `steps_per_action = 1` the same as
    /// [`buffers`](Self::buffers)).
    pub fn physics_step_buffers(&self) -> &StepBuffers {
        &self.buf
    }
    /// PD targets (`N × dofs`, [−1, 1]) the task's action transform gave in the last physics
    /// step (empty for tasks whose actions are the targets).
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
            (slots.par_iter_mut(), buf.obs.par_chunks_mut(d))
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (slot, obs))| task.observe(slot, &state.env(i), obs));
        });
        if let Some(h) = &mut self.hold {
            h.out.obs.copy_from_slice(&self.buf.obs);
        }
    }

    /// Reseed (if `seed` is given) and reset every environment.
    pub fn reset_all(&mut self, seed: Option<u64>) {
        if let Some(s) = seed {
            self.rngs = env_streams(s, self.num_envs());
        }
        if let Some(h) = &mut self.hold {
            h.out.final_mask.fill(0);
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
                self.plan(i);
            }
        }
        self.apply_resets(true);
    }

    /// Reset the environments that terminated or were truncated in the last step.
    pub fn reset_done(&mut self) {
        let mut any = false;
        for i in 0..self.num_envs() {
            let done = self.buffers().done(i) && !self.sim.is_paused(i);
            self.reset_mask[i] = done;
            if done {
                any = true;
                self.task.end_episode(i, &self.slots[i]);
                self.plan(i);
            }
        }
        if any {
            self.apply_resets(true);
        }
    }

    /// Close the episodes of the environments in `mask` (the task's end-of-episode bookkeeping)
    /// without resetting them.
    pub fn end_episodes(&mut self, mask: &[bool]) {
        for (i, _) in mask.iter().enumerate().filter(|m| *m.1) {
            self.task.end_episode(i, &self.slots[i]);
        }
    }

    /// Overwrite environment `i`'s task information and recompute its observation.
    pub fn set_task_info(&mut self, i: usize, values: &[f32]) -> Result<(), EnvError> {
        let (n, ni) = (self.num_envs(), self.task.spec().info_names.len());
        if i >= n || values.len() != ni || values.iter().any(|v| !v.is_finite()) {
            return Err(EnvError::Unsupported(format!(
                "set_task_info: environment {i} of {n} needs {ni} finite values ({}), got {}",
                self.task.spec().info_names.join(", "),
                values.len()
            )));
        }
        if !self.task.set_info(&mut self.slots[i], values) {
            return Err(EnvError::Unsupported(format!(
                "task '{}' has no settable task information",
                self.task.spec().name
            )));
        }
        let d = self.obs_dim();
        let st = self.sim.state().env(i);
        self.task.observe(&mut self.slots[i], &st, &mut self.buf.obs[i * d..(i + 1) * d]);
        self.task.reset_info(&self.slots[i], &mut self.buf.info[i * ni..(i + 1) * ni]);
        if let Some(h) = &mut self.hold {
            copy_row(&mut h.out.obs, &self.buf.obs, i, d);
            copy_row(&mut h.out.info, &self.buf.info, i, ni);
        }
        Ok(())
    }

    /// Plan environment `i`'s next episode.
    fn plan(&mut self, i: usize) {
        let scene = Arc::clone(self.sim.scene_of(i));
        let (slot, rng, state) = (&mut self.slots[i], &mut self.rngs[i], &mut self.reset_states[i]);
        self.task.plan_reset(i, slot, rng, &scene, state);
    }

    /// Reset the simulation of the environments in `reset_mask` to the planned states, let the
    /// task finish them and write their observations and information (and clear the done flags
    /// if asked).
    fn apply_resets(&mut self, clear_flags: bool) {
        self.sim
            .reset(&self.reset_mask, &self.reset_states)
            .expect("reset states are planned by the task from validated data");
        let Self { sim, slots, buf, reset_mask, task, hold, .. } = self;
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
            if !m {
                continue;
            }
            if ni > 0 {
                task.reset_info(&slots[i], &mut buf.info[i * ni..(i + 1) * ni]);
            }
            if clear_flags {
                buf.terminated[i] = 0;
                buf.truncated[i] = 0;
            }
            if let Some(h) = hold.as_mut() {
                h.after_reset(buf, i, d, ni, clear_flags);
            }
        }
    }

    /// One physics step of every environment with `actions` (`N × act_dim`), written into the
    /// physics-step buffers.
    fn physics_step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        let n = self.num_envs();
        if self.act_dim() == self.sim.num_dofs() && !self.task.transforms_actions() {
            // the actions are the PD targets (checked by the simulation)
            self.sim.step(actions)?;
        } else {
            if actions.len() != n * self.act_dim() {
                return Err(EnvError::ActionShape {
                    expected: n * self.act_dim(),
                    got: actions.len(),
                });
            }
            self.targets.resize(n * self.sim.num_dofs(), 0.0);
            self.task.actions_to_targets(&self.slots, &self.buf.obs, actions, &mut self.targets)?;
            self.sim.step(&self.targets)?;
        }
        let Self { sim, slots, buf, task, .. } = self;
        let spec = task.spec();
        let (d, nt, ni, nm) =
            (spec.obs_dim, spec.term_names.len(), spec.info_names.len(), spec.metric_names.len());
        let (state, t, sim) = (sim.state(), &*task, &*sim);
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
                        if sim.is_paused(i) {
                            return;
                        }
                        let out =
                            StepOut { obs, reward, terms, info, metrics, terminated, truncated };
                        t.step_env(i, slot, &state.env(i), out);
                    },
                );
        });
        buf.unstable.copy_from_slice(&state.unstable);
        self.task.after_step(&self.slots, &mut self.buf.reward, &self.buf.terms);
        Ok(())
    }

    /// One transition of a held action: `h.steps()` physics steps aggregated by `h`.
    fn held_step(&mut self, h: &mut Hold, actions: &[f32]) -> Result<(), EnvError> {
        let n = self.num_envs();
        let spec = self.task.spec();
        if actions.len() != n * spec.act_dim() {
            return Err(EnvError::ActionShape { expected: n * spec.act_dim(), got: actions.len() });
        }
        let widths =
            [spec.obs_dim, spec.term_names.len(), spec.info_names.len(), spec.metric_names.len()];
        h.begin();
        for k in 0..h.steps() {
            self.physics_step(actions)?;
            if h.accumulate(&self.buf, widths, k + 1 == h.steps()) {
                break;
            }
        }
        h.finish(widths[1]);
        Ok(())
    }

    /// Advance all environments by one policy step with `actions` (`N × act_dim`, clamped to
    /// [−1, 1]).
    pub fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        match self.hold.take() {
            None => self.physics_step(actions)?,
            Some(mut h) => {
                let r = self.held_step(&mut h, actions);
                self.hold = Some(h);
                r?;
            }
        }
        if self.autoreset {
            let (n, d) = (self.num_envs(), self.obs_dim());
            let mut any = false;
            for i in 0..n {
                let done = self.buffers().done(i) && !self.sim.is_paused(i);
                self.reset_mask[i] = done;
                any |= done;
            }
            let out = match self.hold.as_mut() {
                Some(h) => &mut h.out,
                None => &mut self.buf,
            };
            for i in 0..n {
                out.final_mask[i] = u8::from(self.reset_mask[i]);
                if self.reset_mask[i] {
                    out.final_obs[i * d..(i + 1) * d].copy_from_slice(&out.obs[i * d..(i + 1) * d]);
                }
            }
            if any {
                for i in 0..n {
                    if self.reset_mask[i] {
                        self.task.end_episode(i, &self.slots[i]);
                        self.plan(i);
                    }
                }
                // the flags describe the finished step: keep them
                self.apply_resets(false);
            }
        }
        Ok(())
    }
}

impl<T: Task> Env for VecEnv<T> {
    fn spec(&self) -> &TaskSpec {
        self.task.spec()
    }
    fn num_envs(&self) -> usize {
        VecEnv::num_envs(self)
    }
    fn buffers(&self) -> &StepBuffers {
        VecEnv::buffers(self)
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
        VecEnv::end_episodes(self, mask)
    }
    fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }
    fn refresh_observations(&mut self) {
        VecEnv::refresh_observations(self)
    }
    fn mujoco(&self) -> &dyn MjBatch {
        &self.sim
    }
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch {
        &mut self.sim
    }
    fn set_task_info(&mut self, i: usize, values: &[f32]) -> Result<(), EnvError> {
        VecEnv::set_task_info(self, i, values)
    }
    fn set_paused(&mut self, i: usize, paused: bool) -> Result<(), EnvError> {
        VecEnv::set_paused(self, i, paused)
    }
    fn pd_targets(&self) -> &[f32] {
        &self.targets
    }
    fn episode_info(&self, i: usize) -> Vec<i64> {
        let mut v = vec![0; self.task.spec().episode_names.len()];
        self.task.episode_info(&self.slots[i], &mut v);
        v
    }
    fn library(&self) -> Option<&std::sync::Arc<skillmimic_motion::MotionLibrary>> {
        self.task.library()
    }
    fn history_window(&self, i: usize) -> Option<Vec<f32>> {
        self.task.history_window(&self.slots[i])
    }
    fn reference_state(&self, clip: usize, frame: usize) -> Option<ResetState> {
        let mut state = ResetState::rest(self.sim.scene());
        self.task.reference_state(clip, frame, &mut state).then_some(state)
    }
    fn style_dim(&self) -> usize {
        self.task.style_dim()
    }
    fn style_features(&self, out: &mut [f32]) {
        let k = self.task.style_dim();
        if k == 0 {
            return;
        }
        let state = self.sim.state();
        // a paused row's entries are left as they are (`pause`)
        for (i, row) in out.chunks_exact_mut(k).enumerate().filter(|(i, _)| !self.sim.is_paused(*i))
        {
            self.task.style_features(&state.env(i), row);
        }
    }
    fn can_save_state(&self) -> bool {
        true
    }
    fn save_state(&self) -> Result<Vec<u8>, EnvError> {
        VecEnv::save_state(self)
    }
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), EnvError> {
        VecEnv::restore_state(self, bytes)
    }
    fn markers(&self, info: &[f32]) -> Vec<crate::markers::Marker> {
        let mut out = Vec::new();
        self.task.markers(info, &mut out);
        out.truncate(crate::markers::MAX_MARKERS);
        out
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
