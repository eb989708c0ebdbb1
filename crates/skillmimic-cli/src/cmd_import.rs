//! `skillmimic import-rlgames`: an rl_games `.pth` checkpoint (skill or high-level policy) into
//! this project's checkpoint format (policy only, with a configuration), without running pickle
//! code (`skillmimic_learn::rlgames`).

use std::path::PathBuf;

use anyhow::Context;
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::rlgames::{self, Kind};

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum KindArg {
    /// The skill policy (902 or 905 observations, 156 actions).
    Skill,
    /// A high-level controller (838 + task observations, 3 or 7 choices).
    Hlc,
}

#[derive(clap::Args)]
pub struct Args {
    /// The rl_games checkpoint (`torch.save` archive).
    pub file: PathBuf,
    /// What it holds.
    #[arg(long, value_enum)]
    pub kind: KindArg,
    /// Output checkpoint (default: FILE with the extension `.safetensors`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// High-level task the controller was trained for (`env.task` of the saved configuration:
    /// heading, circling, throwing, scoring).
    #[arg(long)]
    pub task: Option<String>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let kind = match a.kind {
        KindArg::Skill => Kind::Skill,
        KindArg::Hlc => Kind::Hlc,
    };
    let imp = rlgames::import(&a.file, kind).map_err(anyhow::Error::msg)?;
    let mut cfg = TrainConfig::default();
    if kind == Kind::Hlc {
        cfg.use_high_level_defaults();
        if let Some(t) = &a.task {
            anyhow::ensure!(
                skillmimic_env::registry::is_high_level(t),
                "--task: '{t}' is not a high-level task ({})",
                skillmimic_env::registry::TASKS
                    .iter()
                    .filter(|e| e.high_level.is_some())
                    .map(|e| e.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            cfg.env.task = t.clone();
        }
    }
    cfg.ppo.policy.clone_from(&imp.ppo.policy);
    cfg.ppo.hidden.clone_from(&imp.ppo.hidden);
    cfg.ppo.normalize_value = imp.ppo.normalize_value;
    if let Some(s) = imp.policy.log_std.first() {
        cfg.ppo.log_std = *s as f64;
    }
    let out = a.out.unwrap_or_else(|| a.file.with_extension("safetensors"));
    let progress = Progress { iteration: imp.epoch, samples: imp.frame };
    checkpoint::save(&out, &imp.policy, None, &progress, &cfg.to_toml())
        .with_context(|| format!("cannot write {}", out.display()))?;
    let toml = out.with_extension("toml");
    skillmimic_core::tensorfile::write_bytes_atomic(&toml, cfg.to_toml().as_bytes())
        .with_context(|| format!("cannot write {}", toml.display()))?;
    println!(
        "imported {} -> {} ({}, observations {}, {} {}, hidden {:?}, epoch {}, frame {})",
        a.file.display(),
        out.display(),
        imp.policy.family.name(),
        imp.policy.obs_dim(),
        imp.policy.actor_outputs(),
        if kind == Kind::Skill { "actions" } else { "choices" },
        cfg.ppo.hidden,
        imp.epoch,
        imp.frame
    );
    if imp.policy.obs_dim() == 905 {
        println!(
            "note: 905 observations = a SkillMimic-V2 policy; evaluate it with \
                env.v2.history.enabled = true and the history encoder it was trained with"
        );
    }
    Ok(())
}
