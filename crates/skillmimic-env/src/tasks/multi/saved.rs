//! The multi-task environment's saved state (exact resume): each task's sub-batch state
//! ([`Env::save_state`]) in order, behind the combined batch's name and size; the combined
//! buffers are rebuilt from the sub-batches', as after every step. Per-episode tasks
//! (`env.multi.assign = "per_episode"`) add each environment's current and last-step task and
//! the stream of task draws (a different encoding: a state saved under one rule is refused
//! under the other).

use serde::{Deserialize, Serialize};

use super::MultiEnv;
use crate::error::EnvError;

#[derive(Serialize, Deserialize)]
struct Saved {
    task: String,
    num_envs: usize,
    /// (task, environments, state) per sub-batch.
    subs: Vec<(String, usize, Vec<u8>)>,
}

/// The per-episode rule's state beside the sub-batches'.
#[derive(Serialize, Deserialize)]
struct SavedEpisodes {
    base: Saved,
    now: Vec<u16>,
    then: Vec<u16>,
    rng: rand_chacha::ChaCha8Rng,
}

impl MultiEnv {
    /// Every sub-batch's state ([`crate::vec_env::Env::save_state`]; see the module doc).
    pub fn save_state(&self) -> Result<Vec<u8>, EnvError> {
        save(self)
    }
    /// Restore a [`save_state`](Self::save_state) of the same tasks and sizes.
    pub fn restore_state(&mut self, bytes: &[u8]) -> Result<(), EnvError> {
        restore(self, bytes)
    }
}

fn save(m: &MultiEnv) -> Result<Vec<u8>, EnvError> {
    let mut subs = Vec::with_capacity(m.subs.len());
    for s in &m.subs {
        subs.push((s.env.spec().name.to_string(), s.env.num_envs(), s.env.save_state()?));
    }
    let base = Saved { task: m.spec.name.to_string(), num_envs: m.n, subs };
    let encoded = match &m.episodes {
        None => postcard::to_stdvec(&base),
        Some(ep) => postcard::to_stdvec(&SavedEpisodes {
            base,
            now: ep.now.clone(),
            then: ep.then.clone(),
            rng: ep.rng.clone(),
        }),
    };
    encoded.map_err(|e| EnvError::Unsupported(format!("multi-task state cannot be encoded: {e}")))
}

fn restore(m: &mut MultiEnv, bytes: &[u8]) -> Result<(), EnvError> {
    let bad = |x: String| EnvError::Unsupported(format!("saved environment state: {x}"));
    let unreadable = |e: postcard::Error| {
        bad(format!(
            "unreadable as the state of multi-task environment '{}' with env.multi.assign = \
                \"{}\" ({e})",
            m.spec.name,
            rule(m)
        ))
    };
    let (s, episodes) = if m.episodes.is_some() {
        let e: SavedEpisodes = postcard::from_bytes(bytes).map_err(unreadable)?;
        if e.now.len() != m.n
            || e.then.len() != m.n
            || e.now.iter().chain(&e.then).any(|&t| t as usize >= m.subs.len())
        {
            return Err(bad(format!(
                "the tasks of {} environments of {} tasks, here {} environments of {}",
                e.now.len(),
                e.now.iter().chain(&e.then).max().map_or(0, |&t| t as usize + 1),
                m.n,
                m.subs.len()
            )));
        }
        (e.base, Some((e.now, e.then, e.rng)))
    } else {
        (postcard::from_bytes::<Saved>(bytes).map_err(unreadable)?, None)
    };
    let here: Vec<(String, usize)> =
        m.subs.iter().map(|x| (x.env.spec().name.to_string(), x.env.num_envs())).collect();
    let saved: Vec<(String, usize)> = s.subs.iter().map(|x| (x.0.clone(), x.1)).collect();
    if s.task != m.spec.name || s.num_envs != m.n || saved != here {
        return Err(bad(format!(
            "task: saved '{}' with {} environments as (task, environments) {saved:?}, here \
                '{}' with {} as {here:?} (env.multi.assign = \"{}\"; under \"per_episode\" \
                every task holds every environment)",
            s.task,
            s.num_envs,
            m.spec.name,
            m.n,
            rule(m)
        )));
    }
    for (sub, (_, _, state)) in m.subs.iter_mut().zip(&s.subs) {
        sub.env.restore_state(state)?;
    }
    if let (Some(ep), Some((now, then, rng))) = (m.episodes.as_mut(), episodes) {
        (ep.now, ep.then, ep.rng) = (now, then, rng);
        m.apply_pauses()?;
    }
    m.gather();
    Ok(())
}

/// The `env.multi.assign` value of `m` (error messages).
fn rule(m: &MultiEnv) -> &'static str {
    if m.episodes.is_some() { "per_episode" } else { "fixed" }
}
