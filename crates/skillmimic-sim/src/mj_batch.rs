//! What every batch of MuJoCo environments offers, whatever its character: the model and MJCF
//! text of each environment and raw `qpos`/`qvel` access (rendering, recording, the Python
//! package's state edits). [`BatchSim`](crate::BatchSim) (SkillMimic humanoid + ball) and
//! [`HsiBatch`](crate::HsiBatch) (TokenHSI character + objects) implement it.

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
    fn env_model(&self, _i: usize) -> &Arc<MjModel> {
        self.scene().model()
    }
    fn env_xml(&self, _i: usize) -> &str {
        self.scene().xml()
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

impl MjBatch for crate::HsiBatch {
    fn num_envs(&self) -> usize {
        crate::HsiBatch::num_envs(self)
    }
    fn env_model(&self, i: usize) -> &Arc<MjModel> {
        self.scene(i).model()
    }
    fn env_xml(&self, i: usize) -> &str {
        self.scene(i).xml()
    }
    fn env_qpos(&self, i: usize) -> &[f64] {
        self.data(i).qpos()
    }
    fn env_qvel(&self, i: usize) -> &[f64] {
        self.data(i).qvel()
    }
    fn set_env_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        self.set_qpos_qvel(i, qpos, qvel)
    }
}
