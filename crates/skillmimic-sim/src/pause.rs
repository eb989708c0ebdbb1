//! Paused environments: a batch row that [`BatchSim::step`] leaves as it is (no physics, its
//! state and read-out unchanged) until it is resumed. A multi-task batch whose environments change
//! task between episodes (TokenHSI's released multi-task training) keeps one row per environment
//! in every task's batch and pauses the rows of the tasks an environment does not run, so each
//! environment costs one simulation whatever the number of tasks. Resets still apply to a paused
//! row.

use crate::batch::BatchSim;
use crate::error::SimError;

impl BatchSim {
    /// Pause (`true`) or resume (`false`) environment `i`. A paused environment's instability flag
    /// reads 0.
    pub fn set_paused(&mut self, i: usize, paused: bool) -> Result<(), SimError> {
        let n = self.num_envs();
        let Some(slot) = self.envs.get_mut(i) else {
            return Err(SimError::Config(format!(
                "environment index {i} out of range (num_envs = {n})"
            )));
        };
        slot.paused = paused;
        if paused {
            self.state.unstable[i] = 0;
        }
        Ok(())
    }

    /// Whether environment `i` is paused (false for an index out of range).
    pub fn is_paused(&self, i: usize) -> bool {
        self.envs.get(i).is_some_and(|s| s.paused)
    }
}
