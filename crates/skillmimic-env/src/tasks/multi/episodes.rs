//! `env.multi.assign = "per_episode"`: TokenHSI's released multi-task rule — an environment's
//! task is drawn from the mix (`env.multi.mix`, normalised) every time the environment resets
//! (`_reset_task_indicator` of the released multi-task environment), so over training each task
//! gets its share of the *episodes*, and of the samples in proportion to its episodes' length.
//!
//! Every task's sub-batch holds a row for every environment (`num_envs` rows each, sub-batch k's
//! row r drawing its episode starts from the stream `seed + k · num_envs + r`); the rows of the
//! environments running another task are paused ([`crate::Env::set_paused`]: not simulated, never
//! done), so each environment costs one simulation whatever the number of tasks, at the memory
//! of one MuJoCo data per task and environment. Environment r's combined outputs come from two
//! sub-batches: the observation and task information from the one of the task it runs now
//! (`now[r]`), the step's reward, terms, metrics, done flags and terminal observation from the
//! one that ran its last step (`then[r]`; they differ after an autoreset that changed the task).
//!
//! The draws come from one stream of the batch, seeded from the environments' seed (and reseeded
//! by `reset_all(Some(seed))`), in environment order at each reset, so a run is reproducible and
//! its exact resume continues bit for bit (the stream and both task vectors are saved).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Mixes the environments' seed into the stream of task draws.
const DRAW_SEED: u64 = 0x7461_736b_5f64_7261;

/// The per-episode assignment's state (see the module doc).
pub(super) struct Episodes {
    /// Cumulative normalised mix (last entry 1).
    cum: Vec<f64>,
    /// The task each environment runs now.
    pub(super) now: Vec<u16>,
    /// The task whose sub-batch ran each environment's last step.
    pub(super) then: Vec<u16>,
    pub(super) rng: ChaCha8Rng,
    /// One sub-batch's mask (reused).
    pub(super) scratch: Vec<bool>,
}

impl Episodes {
    /// For `n` environments and the tasks' weights `mix` (empty = equal; checked by `split`).
    pub(super) fn new(mix: &[f64], tasks: usize, n: usize, seed: u64) -> Self {
        let w: Vec<f64> = if mix.is_empty() { vec![1.0; tasks] } else { mix.to_vec() };
        let total: f64 = w.iter().sum();
        let mut at = 0.0;
        let cum = w
            .iter()
            .map(|x| {
                at += x / total;
                at
            })
            .collect();
        Self {
            cum,
            now: vec![0; n],
            then: vec![0; n],
            rng: ChaCha8Rng::seed_from_u64(seed ^ DRAW_SEED),
            scratch: vec![false; n],
        }
    }

    /// Restart the stream of draws from `seed` (a `reset_all` with a seed).
    pub(super) fn reseed(&mut self, seed: u64) {
        self.rng = ChaCha8Rng::seed_from_u64(seed ^ DRAW_SEED);
    }

    /// One task drawn from the mix.
    pub(super) fn draw(&mut self) -> u16 {
        let u: f64 = self.rng.random();
        self.cum.iter().position(|&c| u < c).unwrap_or(self.cum.len() - 1) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::Episodes;

    #[test]
    fn draws_follow_the_mix() {
        let mut e = Episodes::new(&[0.1, 0.3, 0.3, 0.3], 4, 8, 7);
        let mut counts = [0usize; 4];
        let m = 40_000;
        for _ in 0..m {
            counts[e.draw() as usize] += 1;
        }
        for (c, p) in counts.iter().zip([0.1, 0.3, 0.3, 0.3]) {
            // 4.5 standard deviations of a binomial share
            let sd = (p * (1.0 - p) / m as f64).sqrt();
            assert!((*c as f64 / m as f64 - p).abs() < 4.5 * sd, "{counts:?}");
        }
        let mut eq = Episodes::new(&[], 2, 1, 3);
        let ones = (0..10_000).filter(|_| eq.draw() == 1).count();
        assert!((ones as f64 / 1e4 - 0.5).abs() < 0.025, "{ones}");
    }
}
