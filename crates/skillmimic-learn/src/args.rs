//! Command-line arguments of training, shared by the `skillmimic` command and the Python
//! package's trainer (`python -m skillmimic_rs.train`, the entry point torchrun launches), so both
//! accept the same flags with the same meaning. Behind the `args` feature (clap).

use std::path::{Path, PathBuf};

use crate::config::TrainConfig;
use skillmimic_env::tasks::hlc::config::HlcConfig;

/// Flags that override configuration fields (shared by train / eval / play).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ConfigFlags {
    /// Task of the registry (`env.task`; the list is generated from the registry).
    #[arg(long, help = task_help())]
    pub task: Option<String>,
    /// Frozen policy driven by a high-level task (`env.hlc.llc`): a skill policy (discrete skill
    /// choices) or a `modular_attention` checkpoint (part embeddings); only read.
    #[arg(long)]
    pub llc: Option<PathBuf>,
    /// Policy family (`ppo.policy`; the list is generated from the families).
    #[arg(long, help = policy_help())]
    pub policy: Option<String>,
    /// Clip files or folders (repeatable); replaces `env.motion`.
    #[arg(long = "motion")]
    pub motion: Vec<PathBuf>,
    /// Number of parallel environments (`env.num_envs`; in a data-parallel run the total of all
    /// ranks).
    #[arg(long)]
    pub num_envs: Option<usize>,
    /// Simulation threads (`env.threads`, 0 = one per core; at most 1024, and more than four per
    /// core are capped to four per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Any config field as `table.field=value` (TOML value syntax), repeatable, applied last.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// `--task` help: every registered task, the high-level ones marked.
fn task_help() -> String {
    let tasks = skillmimic_env::registry::TASKS;
    let all: Vec<&str> = tasks.iter().map(|t| t.name).collect();
    let high: Vec<&str> = tasks.iter().filter(|t| t.high_level.is_some()).map(|t| t.name).collect();
    format!(
        "Task of the registry (`env.task`): {} (default imitation). A high-level task ({}) \
            without `--policy` trains the high-level controller's `categorical_mlp` [1024, 512] \
            over a skill policy, a `gaussian_mlp` over a modular one",
        all.join(", "),
        high.join(", ")
    )
}

/// `--policy` help: every policy family.
fn policy_help() -> String {
    let names: Vec<&str> = crate::policies::FAMILIES.iter().map(|f| f.name()).collect();
    format!(
        "Policy family (`ppo.policy`): {} (default {})",
        names.join(", "),
        crate::config::DEFAULT_FAMILY
    )
}

impl ConfigFlags {
    /// Apply the flags to `cfg`, then check every number against its range.
    pub fn apply(&self, cfg: &mut TrainConfig) -> anyhow::Result<()> {
        if let Some(t) = &self.task {
            cfg.env.task = t.clone();
        }
        if let Some(p) = &self.llc {
            cfg.env.table_mut::<HlcConfig>().llc = p.clone();
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
        if skillmimic_env::registry::is_high_level(&cfg.env.task)
            && cfg.ppo.policy == crate::config::DEFAULT_FAMILY
        {
            cfg.use_high_level_defaults();
        }
        for s in &self.set {
            cfg.set(s).map_err(anyhow::Error::msg)?;
        }
        // every number in its range at once (train, eval, play), before threads or networks exist
        cfg.validate_ranges().map_err(anyhow::Error::msg)?;
        Ok(())
    }
}

/// Preset + config file + override flags (shared by train and bench train).
#[derive(clap::Args, Clone, Debug)]
pub struct PresetArgs {
    /// Preset: paper (2048 envs), small (256 envs, paper network and PPO settings), cpu (time to
    /// skill on a CPU: 128 envs, [512, 256, 256], 2 mini-epochs, lr 1e-4), tiny (smoke tests),
    /// modskill (ModSkill's released sizes), tokenhsi (TokenHSI's released single-skill sizes and
    /// its motion-prior schedule).
    #[arg(long, default_value = "small")]
    pub preset: String,
    /// TOML config file with `[env]`, `[ppo]` and `[run]` tables (over the preset).
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
pub fn assemble_config(
    preset: &str,
    file: Option<&Path>,
    flags: &ConfigFlags,
) -> anyhow::Result<TrainConfig> {
    let base = TrainConfig::preset(preset).map_err(anyhow::Error::msg)?;
    let mut cfg = match file {
        // relative paths in the file are resolved by the rule of `config_file` (shared with Python)
        Some(p) => crate::config_file::load_train_config(&base, p).map_err(anyhow::Error::msg)?,
        None => base,
    };
    flags.apply(&mut cfg)?;
    Ok(cfg)
}

/// The arguments of `skillmimic train` (and of `python -m skillmimic_rs.train`).
#[derive(clap::Args, Clone, Debug)]
pub struct TrainArgs {
    #[command(flatten)]
    pub base: PresetArgs,
    /// Training iterations (`run.iterations`).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Seed of everything (`run.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder (`run.out_dir`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Learner threads (`run.learner_threads`, 0 = all cores; at most 1024, capped to four per
    /// core).
    #[arg(long)]
    pub learner_threads: Option<usize>,
    /// Continue from a training checkpoint (optimizer and normaliser state included), or
    /// `latest`: the output folder's `latest.safetensors` when it exists, else a fresh start
    /// (what a restarted job wants, e.g. under `torchrun --max-restarts`); a run `latest` finds
    /// already at `--iterations` is only finished (evaluation, summary).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Skip the end-of-training video.
    #[arg(long)]
    pub no_video: bool,
}

impl TrainArgs {
    /// The configuration: preset, file, flags, then the run flags; every number is checked
    /// against its range at once ([`TrainConfig::validate_ranges`]), before any thread starts.
    pub fn config(&self) -> anyhow::Result<TrainConfig> {
        let mut cfg = self.base.assemble()?;
        if let Some(v) = self.iterations {
            cfg.run.iterations = v;
        }
        if let Some(v) = self.seed {
            cfg.run.seed = v;
        }
        if let Some(v) = &self.out {
            cfg.run.out_dir = v.clone();
        }
        if let Some(v) = self.learner_threads {
            cfg.run.learner_threads = v;
        }
        if self.no_video {
            cfg.run.final_video = false;
        }
        cfg.validate_ranges().map_err(anyhow::Error::msg)?;
        Ok(cfg)
    }

    /// The checkpoint to resume from (`latest` resolved in `out_dir`).
    pub fn resume_path(&self, out_dir: &Path) -> Option<PathBuf> {
        match &self.resume {
            Some(p) if p.as_os_str() == "latest" => {
                Some(out_dir.join("latest.safetensors")).filter(|p| p.is_file())
            }
            other => other.clone(),
        }
    }

    /// Whether the resume is `latest`: a finished run is then completed (evaluation and summary)
    /// instead of refused ([`crate::trainer::Trainer::finish_if_complete`]).
    pub fn resume_is_latest(&self) -> bool {
        self.resume.as_ref().is_some_and(|p| p.as_os_str() == "latest")
    }
}

/// Size the global rayon pool used by the learner's matrix products (once per process); `n`
/// = 0 is one thread per core, and a count far above the cores is capped
/// ([`capped_threads`](skillmimic_env::config_range::capped_threads)).
pub fn init_learner_threads(n: usize) {
    let n = skillmimic_env::config_range::capped_threads(n, "run.learner_threads");
    let mut b = rayon::ThreadPoolBuilder::new().thread_name(|i| format!("skillmimic-learn-{i}"));
    if n > 0 {
        b = b.num_threads(n);
    }
    let _ = b.build_global();
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: TrainArgs,
    }

    #[test]
    fn resume_latest_takes_the_newest_checkpoint_or_starts_fresh() {
        let dir = std::env::temp_dir().join(format!("sm-args-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let parse = |v: &[&str]| {
            Cli::try_parse_from(std::iter::once("train").chain(v.iter().copied())).unwrap().args
        };
        let a = parse(&["--resume", "latest", "--out", dir.to_str().unwrap(), "--iterations", "7"]);
        let cfg = a.config().unwrap();
        assert_eq!((cfg.run.iterations, cfg.run.out_dir.as_path()), (7, dir.as_path()));
        assert_eq!(a.resume_path(&dir), None, "no checkpoint yet: fresh start");
        std::fs::write(dir.join("latest.safetensors"), b"x").unwrap();
        assert_eq!(a.resume_path(&dir), Some(dir.join("latest.safetensors")));
        assert_eq!(
            parse(&["--resume", "a/b.safetensors"]).resume_path(&dir),
            Some(PathBuf::from("a/b.safetensors"))
        );
        assert!(Cli::try_parse_from(["train", "--bogus"]).is_err());
    }
}
