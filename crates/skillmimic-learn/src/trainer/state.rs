//! The trainer's state: the run's configuration, environment, policy and optimiser, and its
//! parts (rollout buffers, update buffers, extensions, the collective). The behaviour is in
//! [`super`] (the iteration), [`super::setup`] (building) and the parts' own modules.

use std::path::PathBuf;

use skillmimic_env::Env;

use super::extension::Extension;
use super::rollout::Rollouts;
use super::update::Updater;
use crate::adam::Adam;
use crate::checkpoint::Progress;
use crate::collective::Timed;
use crate::config::TrainConfig;
use crate::policy::Policy;
use crate::shard::Shard;

/// PPO trainer.
pub struct Trainer {
    pub cfg: TrainConfig,
    pub env: Box<dyn Env>,
    pub policy: Policy,
    pub adam: Adam,
    pub progress: Progress,
    /// This rank's environments and samples.
    pub shard: Shard,
    /// The checkpoint this run resumed from (rank 0; the last good checkpoint until it saves one).
    pub resumed_from: Option<PathBuf>,
    /// A resume that finds the run already at `run.iterations` only does the end-of-run work
    /// (evaluation, hooks, `summary.json`) instead of failing: set for `--resume latest`, where a
    /// restarted job (`torchrun --max-restarts`) can re-enter a run whose last checkpoint was
    /// written before a worker died. An explicit checkpoint path keeps the error.
    pub finish_if_complete: bool,
    pub(super) rollouts: Rollouts,
    pub(super) updater: Updater,
    pub(super) extensions: Vec<Box<dyn Extension>>,
    pub(super) comm: Timed,
    /// The effective configuration saved with checkpoints.
    pub(super) config_toml: String,
}
