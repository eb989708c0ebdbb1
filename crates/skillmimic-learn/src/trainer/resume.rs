//! Exact resume: the part of a training checkpoint that lets a resumed run continue as if it had
//! never stopped — the same episodes, random draws, log rows and checkpoints, bit for bit.
//!
//! The policy, its normalisers, Adam and the extensions' networks are checkpoint tensors already;
//! the tensor [`TENSOR`] (bytes, postcard-encoded) holds the rest:
//! * the environment's whole state ([`skillmimic_env::Env::save_state`]: simulation, every task
//!   slot, the streams of episode starts, the output buffers the next rollout starts from, the
//!   task's shared state such as SkillMimic-V2's ATS tables);
//! * the action-noise stream's position and the running return and length of every current
//!   episode (the log's episode statistics);
//! * every extension's state ([`super::Extension::save_resume`]: the motion prior's window-draw
//!   stream, per-environment windows and replay buffers);
//! * the environment configuration it was saved under (the `env` table without `threads`, which
//!   does not change results, and the history-encoder path, which a fresh run rewrites to its
//!   copy).
//!
//! What needs no saving: minibatch order (drawn from `run.seed` and the iteration), the learning
//! rate (the configuration's), scratch buffers. Resuming with another environment configuration
//! is refused with the keys that differ, unless `run.fresh_episodes` asks for fresh episodes;
//! a checkpoint without the tensor (older versions; data-parallel runs, see below) resumes with
//! fresh episodes and a one-line warning.
//!
//! Data-parallel runs: not saved yet (each rank's environments would have to reach rank 0); their
//! resumes start fresh episodes as before.

use std::path::Path;

use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile};

use super::state::Trainer;
use crate::config::TrainConfig;
use crate::error::{LearnError, bad_checkpoint};

/// Name of the checkpoint tensor.
pub const TENSOR: &str = "resume.state";
/// Version of the encoding.
const FORMAT: u32 = 1;

#[derive(Serialize)]
struct Out<'a> {
    format: u32,
    env_config: String,
    env: Vec<u8>,
    rng: &'a ChaCha8Rng,
    returns: &'a [f64],
    lengths: &'a [u64],
    extensions: Vec<(String, Vec<u8>)>,
}

#[derive(Deserialize)]
struct In {
    format: u32,
    env_config: String,
    env: Vec<u8>,
    rng: ChaCha8Rng,
    returns: Vec<f64>,
    lengths: Vec<u64>,
    extensions: Vec<(String, Vec<u8>)>,
}

/// The environment configuration a saved state belongs to, as `key = value` lines (dotted keys,
/// sorted); see the module doc for the keys left out.
pub fn env_config_lines(cfg: &TrainConfig) -> String {
    let mut e = cfg.env.clone();
    e.threads = 0;
    e.v2.history.encoder = Default::default();
    let text = toml::to_string(&e).expect("the configuration serialises");
    let value: toml::Table = text.parse().expect("serialised TOML parses");
    let mut lines = Vec::new();
    flatten("env", &toml::Value::Table(value), &mut lines);
    lines.sort();
    lines.join("\n")
}

fn flatten(prefix: &str, v: &toml::Value, out: &mut Vec<String>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                flatten(&format!("{prefix}.{k}"), x, out);
            }
        }
        other => out.push(format!("{prefix} = {other}")),
    }
}

/// The keys whose lines differ between two [`env_config_lines`], as `key: saved … here …`.
fn differences(saved: &str, here: &str) -> Vec<String> {
    let split = |s: &str| -> std::collections::BTreeMap<String, String> {
        s.lines()
            .filter_map(|l| l.split_once(" = "))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let (a, b) = (split(saved), split(here));
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    let none = "(unset)".to_string();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            format!("{k}: saved {}, here {}", a.get(k).unwrap_or(&none), b.get(k).unwrap_or(&none))
        })
        .collect()
}

/// The resume tensor of `t` (`None` in a data-parallel run, see the module doc).
pub fn tensor(t: &Trainer) -> Result<Option<OwnedTensor>, LearnError> {
    if t.shard.world > 1 {
        return Ok(None);
    }
    let e = &t.rollouts.episodes;
    let out = Out {
        format: FORMAT,
        env_config: env_config_lines(&t.cfg),
        env: t.env.save_state()?,
        rng: &t.rollouts.rng,
        returns: &e.ret,
        lengths: &e.len,
        extensions: t.extensions.iter().map(|x| (x.name().to_string(), x.save_resume())).collect(),
    };
    let bytes = postcard::to_stdvec(&out)
        .map_err(|e| LearnError::Config(format!("the resume state cannot be encoded: {e}")))?;
    Ok(Some(OwnedTensor::u8(TENSOR, &bytes)))
}

/// Continue `t` (built from the checkpoint `path`, policy and optimiser restored) exactly where
/// the checkpoint's run stopped, when it saved its state; see the module doc for the cases.
/// Returns whether the state was restored.
pub fn apply(t: &mut Trainer, path: &Path) -> Result<bool, LearnError> {
    let bad = |m: String| bad_checkpoint(path)(m);
    let f = TensorFile::open(path).map_err(|e| bad(e.to_string()))?;
    let fresh = t.cfg.run.fresh_episodes;
    if !f.has(TENSOR) || fresh || t.shard.world > 1 {
        if !fresh {
            let why = if t.shard.world > 1 {
                "a data-parallel resume"
            } else {
                "the checkpoint holds no environment state (older version or data-parallel run)"
            };
            tracing::warn!(
                "{}: resuming with fresh episodes: {why}; the run is not exactly the one it \
                    would have been",
                path.display()
            );
        }
        return Ok(false);
    }
    let bytes = f.u8(TENSOR).map_err(|e| bad(e.to_string()))?;
    let s: In = postcard::from_bytes(&bytes)
        .map_err(|e| bad(format!("{}: tensor '{TENSOR}' is unreadable ({e})", path.display())))?;
    let refuse = |what: String| {
        bad(format!(
            "{}: the saved run state does not fit this run: {what}; resume with \
                `--set run.fresh_episodes=true` to start fresh episodes instead",
            path.display()
        ))
    };
    if s.format != FORMAT {
        return Err(refuse(format!("state format {} (this version reads {FORMAT})", s.format)));
    }
    let diff = differences(&s.env_config, &env_config_lines(&t.cfg));
    if !diff.is_empty() {
        return Err(refuse(format!("environment configuration differs: {}", diff.join("; "))));
    }
    let n = t.env.num_envs();
    if s.returns.len() != n || s.lengths.len() != n {
        return Err(refuse(format!("{} episode tallies, {n} environments", s.returns.len())));
    }
    let names: Vec<&str> = t.extensions.iter().map(|x| x.name()).collect();
    let saved: Vec<&str> = s.extensions.iter().map(|x| x.0.as_str()).collect();
    if names != saved {
        return Err(refuse(format!("extensions saved {saved:?}, here {names:?}")));
    }
    t.env.restore_state(&s.env).map_err(|e| refuse(e.to_string()))?;
    for (x, (_, state)) in t.extensions.iter_mut().zip(&s.extensions) {
        x.restore_resume(state).map_err(refuse)?;
    }
    t.rollouts.rng = s.rng;
    t.rollouts.episodes.ret = s.returns;
    t.rollouts.episodes.len = s.lengths;
    Ok(true)
}
