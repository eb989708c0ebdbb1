//! The driver's output buffers and per-environment row views.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::iter::Either;
use rayon::prelude::*;

use crate::task::TaskSpec;

/// Output buffers of the last step (environment-major, float32).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepBuffers {
    /// `[N][obs_dim]`
    pub obs: Vec<f32>,
    /// `[N]`
    pub reward: Vec<f32>,
    /// `[N][terms]` reward terms in `TaskSpec::term_names` order.
    pub terms: Vec<f32>,
    /// `[N][info]` task information (`TaskSpec::info_names`; imitation: the simulated
    /// contact-graph entries).
    pub info: Vec<f32>,
    /// `[N][metrics]` per-step metrics (`TaskSpec::metric_names`).
    pub metrics: Vec<f32>,
    /// `[N]` 1 = early termination (fall or instability).
    pub terminated: Vec<u8>,
    /// `[N]` 1 = time limit reached.
    pub truncated: Vec<u8>,
    /// `[N]` 1 = MuJoCo reported a numerical instability (non-finite or huge `qpos`, `qvel` or
    /// `qacc`; MuJoCo then reset that environment's physics) during the last `step` call; such a
    /// step also ends the episode (`terminated`). Set by every step, left as is by resets.
    pub unstable: Vec<u8>,
    /// `[N][obs_dim]` terminal observations of environments auto-reset in the last step.
    pub final_obs: Vec<f32>,
    /// `[N]` 1 where `final_obs` is valid.
    pub final_mask: Vec<u8>,
}

impl StepBuffers {
    /// Zeroed buffers for `n` environments of a task declaring `spec`.
    pub fn for_spec(n: usize, spec: &TaskSpec) -> Self {
        Self {
            obs: vec![0.0; n * spec.obs_dim],
            reward: vec![0.0; n],
            terms: vec![0.0; n * spec.term_names.len()],
            info: vec![0.0; n * spec.info_names.len()],
            metrics: vec![0.0; n * spec.metric_names.len()],
            terminated: vec![0; n],
            truncated: vec![0; n],
            unstable: vec![0; n],
            final_obs: vec![0.0; n * spec.obs_dim],
            final_mask: vec![0; n],
        }
    }

    /// Whether environment `i`'s episode ended in the last step.
    pub fn done(&self, i: usize) -> bool {
        self.terminated[i] != 0 || self.truncated[i] != 0
    }
}

/// Per-environment rows of a `[N][width]` buffer, also for width 0 (N empty rows: a zero-width
/// buffer must not shorten the zipped per-environment iteration).
pub(crate) fn rows(
    buf: &mut [f32],
    n: usize,
    width: usize,
) -> impl IndexedParallelIterator<Item = &mut [f32]> {
    if width == 0 {
        Either::Left((0..n).into_par_iter().map(|_| <&mut [f32]>::default()))
    } else {
        Either::Right(buf.par_chunks_mut(width))
    }
}

/// Copy row `i` of a `[N][w]` buffer.
pub(crate) fn copy_row(dst: &mut [f32], src: &[f32], i: usize, w: usize) {
    dst[i * w..(i + 1) * w].copy_from_slice(&src[i * w..(i + 1) * w]);
}

/// The random streams of episode starts of `n` environments: environment `i` draws from its own
/// ChaCha8 stream seeded `seed + i` (wrapping). This is gymnasium's convention for a vector
/// environment reset with `seed` (sub-environment `i` gets `seed + i`), so a batch of `n`
/// environments plans the same episodes as `n` single environments seeded `seed`, `seed + 1`, …,
/// whatever the autoreset mode, the order of resets or the thread count. (A task with state
/// shared across environments, such as SkillMimic-V2's adaptive trajectory sampling, still couples
/// them through that state.)
pub fn env_streams(seed: u64, n: usize) -> Vec<ChaCha8Rng> {
    (0..n as u64).map(|i| ChaCha8Rng::seed_from_u64(seed.wrapping_add(i))).collect()
}
