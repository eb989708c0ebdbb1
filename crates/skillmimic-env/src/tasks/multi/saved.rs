//! The multi-task environment's saved state (exact resume): each task's sub-batch state
//! ([`Env::save_state`]) in order, behind the combined batch's name and size; the combined
//! buffers are rebuilt from the sub-batches', as after every step.

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
    let saved = Saved { task: m.spec.name.to_string(), num_envs: m.n, subs };
    postcard::to_stdvec(&saved)
        .map_err(|e| EnvError::Unsupported(format!("multi-task state cannot be encoded: {e}")))
}

fn restore(m: &mut MultiEnv, bytes: &[u8]) -> Result<(), EnvError> {
    let bad = |x: String| EnvError::Unsupported(format!("saved environment state: {x}"));
    let s: Saved = postcard::from_bytes(bytes).map_err(|e| {
        bad(format!("unreadable as the state of multi-task environment '{}' ({e})", m.spec.name))
    })?;
    let here: Vec<(String, usize)> =
        m.subs.iter().map(|x| (x.env.spec().name.to_string(), x.env.num_envs())).collect();
    let saved: Vec<(String, usize)> = s.subs.iter().map(|x| (x.0.clone(), x.1)).collect();
    if s.task != m.spec.name || s.num_envs != m.n || saved != here {
        return Err(bad(format!(
            "task: saved '{}' with {} environments as (task, environments) {saved:?}, here \
                '{}' with {} as {here:?}",
            s.task, s.num_envs, m.spec.name, m.n
        )));
    }
    for (sub, (_, _, state)) in m.subs.iter_mut().zip(&s.subs) {
        sub.env.restore_state(state)?;
    }
    m.gather();
    Ok(())
}
