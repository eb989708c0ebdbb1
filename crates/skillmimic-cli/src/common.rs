//! Helpers shared by the subcommands: configuration assembly, checkpoints, thread pools.

use std::path::{Path, PathBuf};

use skillmimic_learn::checkpoint::{self, Checkpoint};
use skillmimic_learn::config::TrainConfig;

/// Flags that override configuration fields (shared by train / eval / play).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ConfigFlags {
    /// Task of the registry (`env.task`): imitation (default), stand, heading, circling,
    /// throwing, scoring. A high-level task (the last four) without `--policy` trains the
    /// high-level controller's `categorical_mlp` [1024, 512].
    #[arg(long)]
    pub task: Option<String>,
    /// Skill policy checkpoint driven by a high-level task (`env.hlc.llc`); only read.
    #[arg(long)]
    pub llc: Option<PathBuf>,
    /// Policy family (`ppo.policy`): gaussian_mlp (default), categorical_mlp.
    #[arg(long)]
    pub policy: Option<String>,
    /// Clip files or folders (repeatable); replaces `env.motion`.
    #[arg(long = "motion")]
    pub motion: Vec<PathBuf>,
    /// Number of parallel environments (`env.num_envs`).
    #[arg(long)]
    pub num_envs: Option<usize>,
    /// Simulation threads (`env.threads`, 0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Any config field as `table.field=value` (TOML value syntax), repeatable, applied last.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl ConfigFlags {
    /// Apply the flags to `cfg`.
    pub fn apply(&self, cfg: &mut TrainConfig) -> anyhow::Result<()> {
        if let Some(t) = &self.task {
            cfg.env.task = t.clone();
        }
        if let Some(p) = &self.llc {
            cfg.env.hlc.llc = p.clone();
        }
        if let Some(p) = &self.policy {
            cfg.ppo.policy = p.clone();
        }
        if !self.motion.is_empty() {
            cfg.env.motion = self.motion.clone();
        }
        if let Some(n) = self.num_envs {
            cfg.env.num_envs = n;
        }
        if let Some(t) = self.threads {
            cfg.env.threads = t;
        }
        // a high-level task with the default (Gaussian) family: the high-level controller's
        // settings, unless the family was chosen (file or --policy)
        if skillmimic_env::registry::is_high_level(&cfg.env.task) && cfg.ppo.policy == skillmimic_learn::config::DEFAULT_FAMILY {
            cfg.use_high_level_defaults();
        }
        for s in &self.set {
            cfg.set(s).map_err(anyhow::Error::msg)?;
        }
        Ok(())
    }
}

/// Preset + config file + override flags (shared by train and bench train).
#[derive(clap::Args, Clone, Debug)]
pub struct PresetArgs {
    /// Preset: paper (2048 envs), small (256 envs, paper network and PPO settings), tiny (smoke tests).
    #[arg(long, default_value = "small")]
    pub preset: String,
    /// TOML config file with [env], [ppo] and [run] tables (over the preset).
    #[arg(long)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub flags: ConfigFlags,
}

impl PresetArgs {
    /// The configuration these arguments describe.
    pub fn assemble(&self) -> anyhow::Result<TrainConfig> {
        assemble_config(&self.preset, self.config.as_deref(), &self.flags)
    }
}

/// Preset, then the TOML file, then the flags.
pub fn assemble_config(preset: &str, file: Option<&Path>, flags: &ConfigFlags) -> anyhow::Result<TrainConfig> {
    let base = TrainConfig::preset(preset).map_err(anyhow::Error::msg)?;
    let mut cfg = match file {
        // relative paths in the file are resolved by the rule of `config_file` (shared with Python)
        Some(p) => skillmimic_learn::config_file::load_train_config(&base, p).map_err(anyhow::Error::msg)?,
        None => base,
    };
    flags.apply(&mut cfg)?;
    Ok(cfg)
}

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

/// Size the global rayon pool used by the learner's matrix products (once per process).
pub fn init_learner_threads(n: usize) {
    let mut b = rayon::ThreadPoolBuilder::new().thread_name(|i| format!("skillmimic-learn-{i}"));
    if n > 0 {
        b = b.num_threads(n);
    }
    let _ = b.build_global();
}
