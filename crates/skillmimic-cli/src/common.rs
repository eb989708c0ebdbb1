//! Helpers shared by the subcommands: configuration assembly, checkpoints, thread pools.

use std::path::Path;

use skillmimic_learn::checkpoint::{self, Checkpoint};
use skillmimic_learn::config::TrainConfig;

pub use skillmimic_learn::args::{ConfigFlags, PresetArgs, init_learner_threads};

/// Load a checkpoint and the training configuration stored in it.
pub fn load_checkpoint(path: &Path) -> anyhow::Result<(Checkpoint, TrainConfig)> {
    let ckpt = checkpoint::load(path, None).map_err(anyhow::Error::msg)?;
    let cfg = if ckpt.config.is_empty() {
        TrainConfig::default()
    } else {
        TrainConfig::from_toml_over(&TrainConfig::default(), &ckpt.config, path).map_err(anyhow::Error::msg)?
    };
    Ok((ckpt, cfg))
}
