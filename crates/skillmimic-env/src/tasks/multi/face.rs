//! The multi-task environment's [`Env`] and [`MjBatch`] faces: each call goes to the task
//! sub-batches (see the module doc of [`super`]; per-episode tasks: `super::episodes`).

use std::any::Any;
use std::sync::Arc;

use mujoco_rs::prelude::MjModel;
use skillmimic_sim::{MjBatch, SimError};

use super::MultiEnv;
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::vec_env::{Env, StepBuffers};

impl Env for MultiEnv {
    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn num_envs(&self) -> usize {
        self.n
    }
    fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        let a = self.spec.act_dim();
        if actions.len() != self.n * a {
            return Err(EnvError::ActionShape { expected: self.n * a, got: actions.len() });
        }
        if let Some(ep) = self.episodes.as_mut() {
            ep.then.clone_from(&ep.now);
        }
        for s in self.subs.iter_mut() {
            let n = s.env.num_envs();
            s.env.step(&actions[s.start * a..(s.start + n) * a])?;
        }
        self.gather();
        if self.autoreset && self.episodes.is_some() {
            // the sub-batches started new episodes in the old tasks: draw each one's task, and
            // start the moved ones in their new task (the step's outputs stay the old task's)
            let mut mask = std::mem::take(&mut self.mask);
            mask.clear();
            mask.extend(self.buf.final_mask.iter().map(|&f| f != 0));
            if self.redraw(&mask) {
                if let Some(ep) = &self.episodes {
                    for (m, (a, b)) in mask.iter_mut().zip(ep.now.iter().zip(&ep.then)) {
                        *m = a != b;
                    }
                }
                self.reset_in_place(&mask, false);
                self.gather();
            }
            self.mask = mask;
        }
        Ok(())
    }
    fn reset_all(&mut self, seed: Option<u64>) {
        if let (Some(ep), Some(x)) = (self.episodes.as_mut(), seed) {
            ep.reseed(x);
        }
        self.draw_all();
        self.apply_pauses().expect("every sub-batch pauses environments (checked at construction)");
        let per_episode = self.episodes.is_some();
        for (k, s) in self.subs.iter_mut().enumerate() {
            let offset = if per_episode { k * self.n } else { s.start };
            s.env.reset_all(seed.map(|x| x.wrapping_add(offset as u64)));
        }
        self.gather();
    }
    fn reset_envs(&mut self, mask: &[bool]) {
        if self.episodes.is_some() {
            self.redraw(mask);
            self.reset_in_place(mask, true);
        } else {
            for s in self.subs.iter_mut() {
                let n = s.env.num_envs();
                s.env.reset_envs(&mask[s.start..s.start + n]);
            }
        }
        self.gather();
    }
    fn reset_done(&mut self) {
        if self.episodes.is_some() {
            let mut done = std::mem::take(&mut self.mask);
            done.clear();
            done.extend((0..self.n).map(|r| self.buf.done(r)));
            if done.iter().any(|&d| d) {
                self.end_in_place(&done);
                self.redraw(&done);
                self.reset_in_place(&done, true);
            }
            self.mask = done;
        } else {
            for s in self.subs.iter_mut() {
                s.env.reset_done();
            }
        }
        self.gather();
    }
    fn end_episodes(&mut self, mask: &[bool]) {
        if self.episodes.is_some() {
            self.end_in_place(mask);
            return;
        }
        for s in self.subs.iter_mut() {
            let n = s.env.num_envs();
            s.env.end_episodes(&mask[s.start..s.start + n]);
        }
    }
    fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
        for s in self.subs.iter_mut() {
            s.env.set_autoreset(on);
        }
    }
    fn refresh_observations(&mut self) {
        for s in self.subs.iter_mut() {
            s.env.refresh_observations();
        }
        self.gather();
    }
    fn mujoco(&self) -> &dyn MjBatch {
        self
    }
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch {
        self
    }
    fn pd_targets(&self) -> &[f32] {
        &[]
    }
    /// The sub-environments' width when they all have the same (TokenHSI tasks: 129), else 0.
    fn style_dim(&self) -> usize {
        let k = self.subs.first().map_or(0, |s| s.env.style_dim());
        if self.subs.iter().all(|s| s.env.style_dim() == k) { k } else { 0 }
    }
    fn style_features(&self, out: &mut [f32]) {
        let k = self.style_dim();
        if k == 0 {
            return;
        }
        let Some(ep) = &self.episodes else {
            for s in &self.subs {
                let n = s.env.num_envs();
                s.env.style_features(&mut out[s.start * k..(s.start + n) * k]);
            }
            return;
        };
        // each environment's features from the sub-batch holding its current state
        let mut rows = self.style_rows.lock().unwrap_or_else(|e| e.into_inner());
        rows.resize(self.n * k, 0.0);
        for (t, s) in self.subs.iter().enumerate() {
            s.env.style_features(&mut rows);
            for (r, _) in ep.now.iter().enumerate().filter(|x| *x.1 as usize == t) {
                out[r * k..(r + 1) * k].copy_from_slice(&rows[r * k..(r + 1) * k]);
            }
        }
    }
    fn can_save_state(&self) -> bool {
        true
    }
    fn save_state(&self) -> Result<Vec<u8>, EnvError> {
        MultiEnv::save_state(self)
    }
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), EnvError> {
        MultiEnv::restore_state(self, bytes)
    }
    fn task_rows(&self) -> Vec<(String, std::ops::Range<usize>)> {
        self.subs
            .iter()
            .zip(&self.split_rows)
            .map(|(s, rows)| (s.env.spec().name.to_string(), rows.clone()))
            .collect()
    }
    fn row_tasks(&self) -> &[u16] {
        self.episodes.as_ref().map_or(&[], |e| &e.now)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// MuJoCo access routed to the sub-batch of each environment.
impl MjBatch for MultiEnv {
    fn num_envs(&self) -> usize {
        self.n
    }
    fn env_model(&self, i: usize) -> &Arc<MjModel> {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco().env_model(j)
    }
    fn env_xml(&self, i: usize) -> &str {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco().env_xml(j)
    }
    fn env_state(&self, i: usize) -> skillmimic_sim::EnvState<'_> {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco().env_state(j)
    }
    fn env_qpos(&self, i: usize) -> &[f64] {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco().env_qpos(j)
    }
    fn env_qvel(&self, i: usize) -> &[f64] {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco().env_qvel(j)
    }
    fn set_env_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        let (k, j) = self.locate(i);
        self.subs[k].env.mujoco_mut().set_env_qpos_qvel(j, qpos, qvel)
    }
}
