//! A [`VecEnv`]'s whole state, saved with training checkpoints so that a resumed run continues
//! exactly where it stopped (the same observations, episodes and random draws).
//!
//! What is saved: the task's name and sizes (to refuse another environment), the simulation
//! batch ([`skillmimic_sim::SimSnapshot`]), every environment's stream of episode starts (its
//! position in the ChaCha8 stream), the output buffers of the last step (observations, done
//! flags: the next rollout starts from them), the held-action buffers, the last PD targets, the
//! planned reset states, every task slot (episode progress, clip and frame, goals, latches,
//! history windows) and the task's shared state ([`Task::save_shared`]). Scratch that every step
//! rewrites before reading it (reset masks, the held-action counters) is not.
//!
//! Encoding: [postcard](https://docs.rs/postcard) of serde's data model, little endian, floats
//! bit for bit. The format is versioned by [`FORMAT`]; an encoding of another version is refused.

use serde::{Deserialize, Serialize};
use skillmimic_sim::{ResetState, SimSnapshot};

use super::{StepBuffers, VecEnv};
use crate::error::EnvError;
use crate::task::Task;

/// Version of the encoding.
pub const FORMAT: u32 = 1;

/// What identifies an environment: a saved state restores only into the same.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Identity {
    pub format: u32,
    pub task: String,
    pub num_envs: usize,
    pub obs_dim: usize,
    pub act_dim: usize,
    pub scene_variants: usize,
}

impl Identity {
    /// The differences of `saved` from `this`, one phrase each (empty: the same).
    pub fn differences(saved: &Identity, this: &Identity) -> Vec<String> {
        let mut out = Vec::new();
        let mut cmp = |what: &str, a: String, b: String| {
            if a != b {
                out.push(format!("{what}: saved {a}, here {b}"));
            }
        };
        cmp("state format", saved.format.to_string(), this.format.to_string());
        cmp("task", saved.task.clone(), this.task.clone());
        cmp("environments", saved.num_envs.to_string(), this.num_envs.to_string());
        cmp("observation width", saved.obs_dim.to_string(), this.obs_dim.to_string());
        cmp("action width", saved.act_dim.to_string(), this.act_dim.to_string());
        cmp("scene variants", saved.scene_variants.to_string(), this.scene_variants.to_string());
        out
    }
}

/// The saved state, borrowed for encoding.
#[derive(Serialize)]
struct Out<'a, S: Serialize> {
    id: Identity,
    sim: SimSnapshot,
    rngs: &'a [rand_chacha::ChaCha8Rng],
    buf: &'a StepBuffers,
    hold: Option<&'a StepBuffers>,
    autoreset: bool,
    targets: &'a [f32],
    reset_states: &'a [ResetState],
    slots: &'a [S],
    shared: Vec<u8>,
}

/// The saved state, owned for decoding (the same fields in the same order as [`Out`]).
#[derive(Deserialize)]
struct In<S> {
    id: Identity,
    sim: SimSnapshot,
    rngs: Vec<rand_chacha::ChaCha8Rng>,
    buf: StepBuffers,
    hold: Option<StepBuffers>,
    autoreset: bool,
    targets: Vec<f32>,
    reset_states: Vec<ResetState>,
    slots: Vec<S>,
    shared: Vec<u8>,
}

/// The identity of `env`.
pub fn identity<T: Task>(env: &VecEnv<T>) -> Identity {
    let spec = env.task.spec();
    Identity {
        format: FORMAT,
        task: spec.name.to_string(),
        num_envs: env.num_envs(),
        obs_dim: spec.obs_dim,
        act_dim: spec.act_dim(),
        scene_variants: env.sim.variants().len(),
    }
}

impl<T: Task> VecEnv<T> {
    /// The environment's whole state ([`Env::save_state`](crate::vec_env::Env::save_state); see
    /// the module doc).
    pub fn save_state(&self) -> Result<Vec<u8>, EnvError> {
        save(self)
    }
    /// Restore a [`save_state`](Self::save_state) of an environment of the same task and size.
    pub fn restore_state(&mut self, bytes: &[u8]) -> Result<(), EnvError> {
        restore(self, bytes)
    }
}

/// Encode the identity first, so that a mismatch can be named before the rest is decoded.
fn save<T: Task>(env: &VecEnv<T>) -> Result<Vec<u8>, EnvError> {
    let out = Out {
        id: identity(env),
        sim: env.sim.snapshot(),
        rngs: &env.rngs,
        buf: &env.buf,
        hold: env.hold.as_ref().map(|h| &h.out),
        autoreset: env.autoreset,
        targets: &env.targets,
        reset_states: &env.reset_states,
        slots: &env.slots,
        shared: env.task.save_shared(),
    };
    postcard::to_stdvec(&out).map_err(|e| {
        EnvError::Unsupported(format!("task '{}': cannot encode its state: {e}", out.id.task))
    })
}

/// Restore `bytes` (from [`save`]) into `env`: refused with the differences named when the
/// identity or any buffer size differs; nothing changes before every check has passed.
fn restore<T: Task>(env: &mut VecEnv<T>, bytes: &[u8]) -> Result<(), EnvError> {
    let here = identity(env);
    let bad = |m: String| EnvError::Unsupported(format!("saved environment state: {m}"));
    let (saved_id, _) = postcard::take_from_bytes::<Identity>(bytes)
        .map_err(|e| bad(format!("unreadable ({e})")))?;
    let diff = Identity::differences(&saved_id, &here);
    if !diff.is_empty() {
        return Err(bad(diff.join("; ")));
    }
    let s: In<T::Slot> = postcard::from_bytes(bytes)
        .map_err(|e| bad(format!("unreadable for task '{}' ({e})", here.task)))?;
    debug_assert_eq!(s.id, here);
    let n = here.num_envs;
    let sizes = |b: &StepBuffers| {
        [b.obs.len(), b.reward.len(), b.terms.len(), b.info.len(), b.metrics.len()]
            .into_iter()
            .chain([b.terminated.len(), b.truncated.len(), b.unstable.len()])
            .chain([b.final_obs.len(), b.final_mask.len()])
            .collect::<Vec<_>>()
    };
    let checks = [
        ("episode-start streams", s.rngs.len(), n),
        ("task slots", s.slots.len(), n),
        ("reset states", s.reset_states.len(), n),
        ("held-action buffers", usize::from(s.hold.is_some()), usize::from(env.hold.is_some())),
    ];
    for (what, got, want) in checks {
        if got != want {
            return Err(bad(format!("{what}: saved {got}, here {want}")));
        }
    }
    if sizes(&s.buf) != sizes(&env.buf)
        || s.hold.as_ref().zip(env.hold.as_ref()).is_some_and(|(a, b)| sizes(a) != sizes(&b.out))
    {
        return Err(bad("output buffer sizes differ from this environment's".into()));
    }
    // the task's shared state first: its check may refuse the state
    env.task.restore_shared(&s.shared).map_err(bad)?;
    env.sim.restore(&s.sim)?;
    env.rngs = s.rngs;
    env.buf = s.buf;
    if let (Some(h), Some(out)) = (env.hold.as_mut(), s.hold) {
        h.out = out;
    }
    env.autoreset = s.autoreset;
    env.targets = s.targets;
    env.reset_states = s.reset_states;
    env.slots = s.slots;
    Ok(())
}
