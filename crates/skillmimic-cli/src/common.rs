//! Helpers shared by the subcommands: configuration assembly, checkpoints, thread pools.

use std::path::Path;

use skillmimic_learn::checkpoint::{self, Checkpoint};
use skillmimic_learn::config::TrainConfig;

pub use skillmimic_learn::args::{ConfigFlags, PresetArgs, init_learner_threads};

/// Load a checkpoint and the training configuration stored in it.
pub fn load_checkpoint(path: &Path) -> anyhow::Result<(Checkpoint, TrainConfig)> {
    checkpoint::load_with_config(path).map_err(anyhow::Error::msg)
}
