//! From checkpoint files to ONNX files: what `skillmimic export --format onnx` runs.

use std::path::{Path, PathBuf};

use crate::checkpoint;
use crate::config_file::{config_dir, resolve_path};
use crate::error::LearnError;

use super::meta::{DeployMeta, source_of};
use super::{Exported, fused_model, policy_model, write};
use skillmimic_env::tasks::hlc::config::HlcConfig;

/// What an export wrote.
pub struct Written {
    pub model: PathBuf,
    pub sidecar: PathBuf,
    pub exported: Exported,
}

/// Export the policy of `ckpt` to `out` (+ `out.json`). `fused`: a high-level checkpoint is
/// exported together with its skill policy (over a modular skill policy: its part controllers,
/// [`super::latent::fused_latent_model`]) — `llc`, or the `env.hlc.llc` of its configuration
/// (a relative path there follows the config-file rule of [`crate::config_file`]: next to the
/// checkpoint, else relative to the working directory).
pub fn export_checkpoint(
    ckpt: &Path,
    out: &Path,
    fused: bool,
    llc: Option<&Path>,
) -> Result<Written, LearnError> {
    let (c, cfg) = checkpoint::load_with_config(ckpt)?;
    let latent = skillmimic_env::registry::is_high_level(&cfg.env.task)
        && c.policy.family.name() != "categorical_mlp";
    if latent && !fused {
        let msg = format!(
            "{}: a high-level policy with continuous actions (part embeddings for the frozen \
                controllers of a modular skill policy) outputs embeddings, not PD targets; export \
                it with --fused (and --llc, or the env.hlc.llc of its configuration)",
            ckpt.display()
        );
        return Err(LearnError::Config(msg));
    }
    let source = source_of(ckpt, c.progress.iteration, c.progress.samples)?;
    let act = c.policy.actor.output_dim();
    let meta = DeployMeta::new("", c.policy.family.name(), &cfg, c.policy.obs_dim(), act, source)?;
    let exported = if fused {
        let llc_path = match llc {
            Some(p) => p.to_path_buf(),
            None if cfg.env.table::<HlcConfig>().llc.as_os_str().is_empty() => {
                return Err(LearnError::Config(format!(
                    "{}: its configuration names no skill policy (env.hlc.llc); pass --llc",
                    ckpt.display()
                )));
            }
            None => resolve_path(&cfg.env.table::<HlcConfig>().llc, config_dir(ckpt)),
        };
        let skill = checkpoint::load(&llc_path, None)?;
        let skill_source = source_of(&llc_path, skill.progress.iteration, skill.progress.samples)?;
        if latent {
            super::latent::fused_latent_model(&c.policy, &skill.policy, meta, skill_source)?
        } else {
            fused_model(&c.policy, &skill.policy, meta, skill_source)?
        }
    } else {
        policy_model(&c.policy, meta)?
    };
    let sidecar = write(out, &exported)?;
    Ok(Written { model: out.to_path_buf(), sidecar, exported })
}
