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
//! a checkpoint without the tensor or with an older layout of it (older versions; see below for
//! data-parallel runs) resumes with fresh episodes and a one-line warning.
//!
//! Data-parallel runs: every rank's part reaches rank 0 at each checkpoint
//! ([`crate::collective::bytes`]), and a resume with the same world size hands each rank its part
//! back, so it is exact too; a resume with another world size starts fresh episodes (with a
//! warning saying so), as a checkpoint written on an interrupt between the regular checkpoint
//! iterations of a data-parallel run does (the ranks cannot agree to gather then).

use std::path::Path;

use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile};

use super::state::Trainer;
use crate::collective::Collective;
use crate::config::TrainConfig;
use crate::error::{LearnError, bad_checkpoint};

/// Name of the checkpoint tensor.
pub const TENSOR: &str = "resume.state";
/// Version of the encoding (2: the high-level tasks' slots hold the goal their first observation
/// shows). A checkpoint of an older version resumes with fresh episodes and a warning.
const FORMAT: u32 = 2;

/// The run's saved state: every rank's part ([`RankOut`]) and what it belongs to.
#[derive(Serialize, Deserialize)]
struct Saved {
    format: u32,
    world: usize,
    env_config: String,
    ranks: Vec<Vec<u8>>,
}

/// One rank's part, borrowed for encoding.
#[derive(Serialize)]
struct RankOut<'a> {
    env: Vec<u8>,
    rng: &'a ChaCha8Rng,
    returns: &'a [f64],
    lengths: &'a [u64],
    extensions: Vec<(String, Vec<u8>)>,
}

/// One rank's part, owned for decoding (the fields of [`RankOut`] in order).
#[derive(Deserialize)]
struct RankIn {
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

fn encode_rank(t: &Trainer) -> Result<Vec<u8>, LearnError> {
    let e = &t.rollouts.episodes;
    let out = RankOut {
        env: t.env.save_state()?,
        rng: &t.rollouts.rng,
        returns: &e.ret,
        lengths: &e.len,
        extensions: t.extensions.iter().map(|x| (x.name().to_string(), x.save_resume())).collect(),
    };
    postcard::to_stdvec(&out).map_err(unencodable)
}

fn unencodable(e: postcard::Error) -> LearnError {
    LearnError::Config(format!("the resume state cannot be encoded: {e}"))
}

/// The checkpoint tensor of every rank's part (`ranks`, in rank order).
fn tensor_of(t: &Trainer, ranks: Vec<Vec<u8>>) -> Result<OwnedTensor, LearnError> {
    let saved =
        Saved { format: FORMAT, world: t.shard.world, env_config: env_config_lines(&t.cfg), ranks };
    Ok(OwnedTensor::u8(TENSOR, &postcard::to_stdvec(&saved).map_err(unencodable)?))
}

/// The resume tensor of a one-process run (`None` in a data-parallel run, see [`collect`], and for
/// an environment that cannot save its state).
pub fn single(t: &Trainer) -> Result<Option<OwnedTensor>, LearnError> {
    if t.shard.world > 1 || !t.env.can_save_state() {
        return Ok(None);
    }
    tensor_of(t, vec![encode_rank(t)?]).map(Some)
}

/// The resume tensor of the run: on rank 0 `Some`, elsewhere `None`. Collective in a
/// data-parallel run: every rank calls it at the same iterations (the runner's checkpoint
/// iterations).
pub fn collect(t: &mut Trainer) -> Result<Option<OwnedTensor>, LearnError> {
    if t.shard.world == 1 || !t.env.can_save_state() {
        return single(t);
    }
    let mine = encode_rank(t)?;
    let ranks = crate::collective::bytes::all_gather_bytes(&mut t.comm, &mine)?;
    if t.shard.rank != 0 {
        return Ok(None);
    }
    tensor_of(t, ranks).map(Some)
}

/// Rank 0's decision about the checkpoint `path` (see the module doc): the ranks' parts to
/// restore, none (fresh episodes, after a warning), or a refusal.
fn decide(t: &Trainer, path: &Path) -> Result<Option<Vec<Vec<u8>>>, LearnError> {
    let bad = |m: String| bad_checkpoint(path)(m);
    let f = TensorFile::open(path).map_err(|e| bad(e.to_string()))?;
    let fresh = t.cfg.run.fresh_episodes;
    let warn = |why: String| {
        tracing::warn!(
            "{}: resuming with fresh episodes: {why}; the run is not exactly the one it would \
                have been",
            path.display()
        )
    };
    if fresh {
        return Ok(None);
    }
    if !f.has(TENSOR) {
        warn("the checkpoint holds no run state (written by an older version)".into());
        return Ok(None);
    }
    let bytes = f.u8(TENSOR).map_err(|e| bad(e.to_string()))?;
    let s: Saved = postcard::from_bytes(&bytes)
        .map_err(|e| bad(format!("{}: tensor '{TENSOR}' is unreadable ({e})", path.display())))?;
    let refuse = |what: String| {
        bad(format!(
            "{}: the saved run state does not fit this run: {what}; resume with \
                `--set run.fresh_episodes=true` to start fresh episodes instead",
            path.display()
        ))
    };
    if s.format < FORMAT {
        warn(format!(
            "its run state has an older layout ({}; this version reads {FORMAT})",
            s.format
        ));
        return Ok(None);
    }
    if s.format != FORMAT {
        return Err(refuse(format!("state format {} (this version reads {FORMAT})", s.format)));
    }
    let diff = differences(&s.env_config, &env_config_lines(&t.cfg));
    if !diff.is_empty() {
        return Err(refuse(format!("environment configuration differs: {}", diff.join("; "))));
    }
    if s.world != t.shard.world || s.ranks.len() != s.world {
        warn(format!(
            "it was saved by {} rank(s) and resumes on {}; only the same world size resumes exactly",
            s.world, t.shard.world
        ));
        return Ok(None);
    }
    Ok(Some(s.ranks))
}

/// Restore this rank's part.
fn restore_rank(t: &mut Trainer, bytes: &[u8], path: &str) -> Result<(), LearnError> {
    let refuse = |what: String| {
        LearnError::Config(format!(
            "{path}: the saved run state of rank {} does not fit this run: {what}; resume with \
                `--set run.fresh_episodes=true` to start fresh episodes instead",
            t.shard.rank
        ))
    };
    let s: RankIn = postcard::from_bytes(bytes).map_err(|e| refuse(format!("unreadable ({e})")))?;
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
        x.restore_resume(state).map_err(&refuse)?;
    }
    t.rollouts.rng = s.rng;
    t.rollouts.episodes.ret = s.returns;
    t.rollouts.episodes.len = s.lengths;
    Ok(())
}

/// Continue `t`, resumed from a checkpoint at a later iteration (policy and optimiser restored;
/// `path` on rank 0, which alone reads it), exactly where the checkpoint's run stopped when it
/// saved its state; see the module doc for the other cases. Collective in a data-parallel run:
/// every rank calls it. Returns whether the state was restored.
pub fn apply(t: &mut Trainer, path: Option<&Path>) -> Result<bool, LearnError> {
    let (rank, world) = (t.shard.rank, t.shard.world);
    let decision = match path.filter(|_| rank == 0) {
        Some(p) => decide(t, p),
        None => Ok(None),
    };
    let shown = path.map_or("the checkpoint".to_string(), |p| p.display().to_string());
    if world == 1 {
        return match decision? {
            Some(parts) => restore_rank(t, &parts[0], &shown).map(|()| true),
            None => Ok(false),
        };
    }
    // rank 0 tells the others: 1 = restore, 0 = fresh episodes, -1 = refused
    let mut flag = [match &decision {
        Ok(Some(_)) => 1.0,
        Ok(None) => 0.0,
        Err(_) => -1.0,
    }];
    t.comm.broadcast_f64(&mut flag)?;
    if flag[0] < 0.0 {
        return Err(decision.err().unwrap_or_else(|| {
            LearnError::Config("rank 0 refused the checkpoint's saved run state".into())
        }));
    }
    if flag[0] == 0.0 {
        return Ok(false);
    }
    let parts = decision.ok().flatten().unwrap_or_default();
    let mine = crate::collective::bytes::scatter_bytes(&mut t.comm, &parts)?;
    restore_rank(t, &mine, &shown)?;
    Ok(true)
}
