//! Raw MuJoCo access to a batch of environments, whatever its character: the model and MJCF text
//! of each environment, its state read-out and raw `qpos`/`qvel` access (rendering, recording,
//! the Python package's state edits). [`BatchSim`](crate::BatchSim) implements it; an
//! environment made of several batches (the multi-task environment) routes each index to its
//! batch.

use std::sync::Arc;

use mujoco_rs::prelude::*;

use crate::error::SimError;

/// Raw MuJoCo access to a batch of environments.
pub trait MjBatch: Send + Sync {
    /// Number of environments.
    fn num_envs(&self) -> usize;
    /// The compiled model of environment `i`.
    fn env_model(&self, i: usize) -> &Arc<MjModel>;
    /// The MJCF text environment `i`'s model was compiled from.
    fn env_xml(&self, i: usize) -> &str;
    /// The state read-out of environment `i`.
    fn env_state(&self, i: usize) -> crate::EnvState<'_>;
    /// Generalised positions of environment `i`.
    fn env_qpos(&self, i: usize) -> &[f64];
    /// Generalised velocities of environment `i`.
    fn env_qvel(&self, i: usize) -> &[f64];
    /// Overwrite environment `i`'s `qpos`/`qvel` (cleared like a reset, then `mj_forward`).
    fn set_env_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError>;
}

impl MjBatch for crate::BatchSim {
    fn num_envs(&self) -> usize {
        crate::BatchSim::num_envs(self)
    }
    fn env_model(&self, i: usize) -> &Arc<MjModel> {
        self.scene_of(i).model()
    }
    fn env_xml(&self, i: usize) -> &str {
        self.scene_of(i).xml()
    }
    fn env_state(&self, i: usize) -> crate::EnvState<'_> {
        self.state().env(i)
    }
    fn env_qpos(&self, i: usize) -> &[f64] {
        self.qpos(i)
    }
    fn env_qvel(&self, i: usize) -> &[f64] {
        self.qvel(i)
    }
    fn set_env_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        self.set_qpos_qvel(i, qpos, qvel)
    }
}
