//! The statistics of one training iteration (one JSON line of `log.jsonl`).

use serde::Serialize;

/// Statistics of one iteration (one JSON line of `log.jsonl`).
#[derive(Clone, Debug, Default, Serialize, serde::Deserialize)]
#[serde(default)]
pub struct IterationStats {
    pub iteration: u64,
    pub samples: u64,
    /// `samples` in simulation (low-level) steps: × the task's `steps_per_action` (3 for the
    /// high-level tasks, whose papers count samples this way; equal to `samples` otherwise).
    pub low_level_samples: u64,
    /// Wall-clock seconds of this iteration: rollout, update, total.
    pub rollout_s: f64,
    pub update_s: f64,
    /// Parts of `rollout_s`: environment stepping (simulation, observations, rewards, resets)
    /// and policy inference (network, action sampling, bootstrap values).
    pub env_s: f64,
    pub inference_s: f64,
    pub samples_per_s: f64,
    /// Mean reward per environment step over the rollout.
    pub mean_reward: f64,
    /// Means of each reward term over the rollout (`reward::TERM_NAMES`).
    pub reward_terms: Vec<(String, f64)>,
    /// Episodes finished in this rollout, their mean length (steps) and mean return.
    pub episodes: usize,
    pub episode_length: f64,
    pub episode_return: f64,
    /// Fraction of finished episodes that ended early (fall or instability).
    pub early_terminations: f64,
    /// Environment steps of the rollout (all ranks) in which MuJoCo reported a numerical
    /// instability (the environments' `unstable` flag; each such step also ended its episode).
    pub unstable_steps: u64,
    pub actor_loss: f64,
    pub critic_loss: f64,
    pub bounds_loss: f64,
    pub clip_frac: f64,
    pub approx_kl: f64,
    pub value_mean: f64,
    /// Ranks of a data-parallel run (1: one process).
    pub world_size: usize,
    /// Seconds this rank spent in collective operations (waiting for the others included).
    pub allreduce_s: f64,
    /// Motion prior (`ppo.amp`): the discriminator's mean loss over this iteration's steps and
    /// its mean logits on reference and simulated windows (0 when off).
    pub disc_loss: f64,
    pub disc_ref: f64,
    pub disc_sim: f64,
}

impl IterationStats {
    /// The TensorBoard scalars of the iteration (tag, value): rewards, episodes, instability,
    /// losses, PPO diagnostics, throughput, then every reward term as `reward_terms/<name>`.
    pub fn scalars(&self) -> Vec<(String, f32)> {
        let mut v: Vec<(String, f32)> = [
            ("reward/mean_step", self.mean_reward),
            ("episode/length", self.episode_length),
            ("episode/return", self.episode_return),
            ("episode/early_termination", self.early_terminations),
            ("sim/unstable_steps", self.unstable_steps as f64),
            ("loss/actor", self.actor_loss),
            ("loss/critic", self.critic_loss),
            ("loss/bounds", self.bounds_loss),
            ("ppo/clip_frac", self.clip_frac),
            ("ppo/approx_kl", self.approx_kl),
            ("perf/samples_per_s", self.samples_per_s),
            ("perf/allreduce_s", self.allreduce_s),
        ]
        .into_iter()
        .map(|(k, x)| (k.to_string(), x as f32))
        .collect();
        v.extend(self.reward_terms.iter().map(|(k, x)| (format!("reward_terms/{k}"), *x as f32)));
        v
    }
}
