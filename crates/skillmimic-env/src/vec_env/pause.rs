//! Paused environments of a batch ([`skillmimic_sim::BatchSim::set_paused`]): a paused row is
//! neither simulated nor observed by [`VecEnv::step`] (nor are its style features computed), and
//! neither `reset_done` nor the autoreset resets it; its outputs keep the values of the last step
//! it ran (done flags included) until it is resumed and reset. The multi-task environment pauses,
//! in each task's batch, the rows of the environments that run another task
//! (`env.multi.assign = "per_episode"`).

use super::VecEnv;
use crate::error::EnvError;
use crate::task::Task;

impl<T: Task> VecEnv<T> {
    /// Pause (`true`) or resume (`false`) environment `i` (see the module doc). Resuming does not
    /// reset: reset the environment ([`VecEnv::reset_envs`]) before its outputs are used.
    pub fn set_paused(&mut self, i: usize, paused: bool) -> Result<(), EnvError> {
        self.sim.set_paused(i, paused).map_err(|e| EnvError::Unsupported(e.to_string()))
    }
}
