//! [`HoldEnv`]: the high-level environment — holds every choice for `llc_steps` low-level
//! steps of a [`HighLevel`] task (the rules are in the parent module's doc).
//!
//! Buffers (high level): observation = the last low-level observation of the transition (the
//! terminal one for an environment that finished inside it); reward and terms = means over the
//! transition's low-level steps; metrics = those of its last counted low-level step; info = the
//! goal of the current episode (after a reset: the new one); flags = any low-level step done.

use std::any::Any;

use skillmimic_sim::BatchSim;

use super::{HighLevel, Rule};
use crate::error::EnvError;
use crate::task::{Task, TaskSpec};
use crate::vec_env::{Env, StepBuffers, VecEnv};

/// A [`HighLevel`] task at 1/`llc_steps` of the policy rate.
pub struct HoldEnv<R: Rule> {
    inner: VecEnv<HighLevel<R>>,
    spec: TaskSpec,
    llc_steps: usize,
    buf: StepBuffers,
    autoreset: bool,
    /// Low-level steps counted in the current transition, per environment (0 after a reset).
    counted: Vec<usize>,
    done: Vec<bool>,
}

impl<R: Rule> HoldEnv<R> {
    /// Wrap the low-level environment `inner`.
    pub fn new(inner: VecEnv<HighLevel<R>>, llc_steps: usize) -> Self {
        let mut spec = inner.task().spec().clone();
        spec.max_episode_steps = spec.max_episode_steps.div_ceil(llc_steps);
        spec.steps_per_action = llc_steps;
        let n = inner.num_envs();
        let b = inner.buffers();
        let buf = StepBuffers { final_obs: b.obs.clone(), final_mask: vec![0; n], ..b.clone() };
        let mut env = Self {
            inner,
            spec,
            llc_steps,
            buf,
            autoreset: false,
            counted: vec![0; n],
            done: vec![false; n],
        };
        env.sync_after_reset(&vec![true; n], true);
        env
    }

    /// The low-level environment (task, slots, frozen skill policy).
    pub fn inner(&self) -> &VecEnv<HighLevel<R>> {
        &self.inner
    }
    /// Low-level steps per high-level step.
    pub fn llc_steps(&self) -> usize {
        self.llc_steps
    }
    /// Skill label applied in the last low-level step, per environment.
    pub fn skills(&self) -> &[u32] {
        &self.inner.task().skills
    }
    /// PD targets (`N × 156`) of the last low-level step.
    pub fn last_targets(&self) -> &[f32] {
        self.inner.last_targets()
    }

    fn row(v: &mut [f32], src: &[f32], i: usize, w: usize) {
        v[i * w..(i + 1) * w].copy_from_slice(&src[i * w..(i + 1) * w]);
    }

    /// Copy observation and info of the environments in `mask` after their reset (and clear
    /// their done flags when `clear_flags`).
    fn sync_after_reset(&mut self, mask: &[bool], clear_flags: bool) {
        let (d, ni) = (self.spec.obs_dim, self.spec.info_names.len());
        let inner = self.inner.buffers();
        for (i, &m) in mask.iter().enumerate() {
            if m {
                Self::row(&mut self.buf.obs, &inner.obs, i, d);
                if clear_flags {
                    self.buf.terminated[i] = 0;
                    self.buf.truncated[i] = 0;
                }
                let g = &self.inner.slots()[i].goal;
                self.inner.task().rule.info(g, &mut self.buf.info[i * ni..(i + 1) * ni]);
            }
        }
    }

    fn reset_mask_inner(&mut self, mask: &[bool]) {
        self.inner.reset_envs(mask);
        self.sync_after_reset(mask, true);
    }
}

impl<R: Rule> Env for HoldEnv<R> {
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn buffers(&self) -> &StepBuffers {
        &self.buf
    }

    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        let n = self.num_envs();
        if actions.len() != n * self.spec.act_dim() {
            return Err(EnvError::ActionShape {
                expected: n * self.spec.act_dim(),
                got: actions.len(),
            });
        }
        let (d, nt, ni, nm) = (
            self.spec.obs_dim,
            self.spec.term_names.len(),
            self.spec.info_names.len(),
            self.spec.metric_names.len(),
        );
        self.counted.fill(0);
        self.done.fill(false);
        self.buf.reward.fill(0.0);
        self.buf.terms.fill(0.0);
        self.buf.unstable.fill(0);
        for k in 0..self.llc_steps {
            let last = k + 1 == self.llc_steps;
            self.inner.step(actions)?;
            let b = self.inner.buffers();
            for i in 0..n {
                if self.done[i] {
                    continue;
                }
                self.counted[i] += 1;
                self.buf.reward[i] += b.reward[i];
                for k in 0..nt {
                    self.buf.terms[i * nt + k] += b.terms[i * nt + k];
                }
                self.buf.terminated[i] = b.terminated[i];
                self.buf.truncated[i] = b.truncated[i];
                // any instability among the transition's counted simulation steps
                self.buf.unstable[i] |= b.unstable[i];
                self.done[i] = b.terminated[i] != 0 || b.truncated[i] != 0;
                // the rows of the transition's last counted step only
                if self.done[i] || last {
                    Self::row(&mut self.buf.obs, &b.obs, i, d);
                    Self::row(&mut self.buf.metrics, &b.metrics, i, nm);
                    Self::row(&mut self.buf.info, &b.info, i, ni);
                }
            }
            if self.done.iter().all(|&x| x) {
                break;
            }
        }
        for i in 0..n {
            let c = self.counted[i].max(1) as f32;
            self.buf.reward[i] /= c;
            for k in 0..nt {
                self.buf.terms[i * nt + k] /= c;
            }
        }
        if self.autoreset {
            let StepBuffers { obs, final_obs, final_mask, .. } = &mut self.buf;
            for i in 0..n {
                final_mask[i] = u8::from(self.done[i]);
                if self.done[i] {
                    final_obs[i * d..(i + 1) * d].copy_from_slice(&obs[i * d..(i + 1) * d]);
                }
            }
            if self.done.iter().any(|&m| m) {
                let mask = std::mem::take(&mut self.done);
                self.inner.reset_envs(&mask);
                // the flags describe the finished transition: keep them
                self.sync_after_reset(&mask, false);
                self.done = mask;
            }
        }
        Ok(())
    }

    fn reset_all(&mut self, seed: Option<u64>) {
        self.inner.reset_all(seed);
        let n = self.num_envs();
        self.buf.final_mask.fill(0);
        self.sync_after_reset(&vec![true; n], true);
    }
    fn reset_envs(&mut self, mask: &[bool]) {
        self.reset_mask_inner(mask);
    }
    fn reset_done(&mut self) {
        let mask: Vec<bool> = (0..self.num_envs())
            .map(|i| self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0)
            .collect();
        if mask.iter().any(|&m| m) {
            self.reset_mask_inner(&mask);
        }
    }
    fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }
    fn refresh_observations(&mut self) {
        self.inner.refresh_observations();
        self.buf.obs.copy_from_slice(&self.inner.buffers().obs);
    }
    fn humanoid_sim(&self) -> Option<&BatchSim> {
        Some(self.inner.sim())
    }
    fn mujoco(&self) -> &dyn skillmimic_sim::MjBatch {
        self.inner.sim()
    }
    fn mujoco_mut(&mut self) -> &mut dyn skillmimic_sim::MjBatch {
        self.inner.sim_mut()
    }
    fn set_task_info(&mut self, i: usize, values: &[f32]) -> Result<(), EnvError> {
        let ni = self.spec.info_names.len();
        if i >= self.num_envs() || values.len() != ni || values.iter().any(|v| !v.is_finite()) {
            return Err(EnvError::Unsupported(format!(
                "set_task_info: environment {i} of {} needs {ni} finite values ({}), got {}",
                self.num_envs(),
                self.spec.info_names.join(", "),
                values.len()
            )));
        }
        let mut goal = self.inner.slots[i].goal.clone();
        self.inner.task().rule.set_info(&mut goal, values);
        self.inner.slots[i].goal = goal;
        self.inner.refresh_observations();
        let d = self.spec.obs_dim;
        let Self { inner, buf, .. } = self;
        Self::row(&mut buf.obs, &inner.buffers().obs, i, d);
        inner.task().rule.info(&inner.slots[i].goal, &mut buf.info[i * ni..(i + 1) * ni]);
        Ok(())
    }
    fn pd_targets(&self) -> &[f32] {
        self.inner.last_targets()
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
