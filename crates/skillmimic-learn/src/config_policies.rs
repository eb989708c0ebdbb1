//! The policy-side tables of `[ppo]` that belong to one architecture or extension:
//! `[ppo.modular]` (ModSkill's modular attention network) and `[ppo.amp]` (the adversarial
//! motion prior). `[ppo.token]` (TokenHSI's transformer) is in [`crate::config_token`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// `[ppo.modular]`: the modular attention network (used when `ppo.policy = "modular_attention"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ModularConfig {
    /// Body split: "five" (ModSkill's: legs, torso, arms with hands) or "seven" (hands separate).
    pub parts: String,
    /// Width of each part embedding z_k (ModSkill: 64).
    #[schemars(range(min = 1))]
    pub embed: usize,
    /// Hidden width of the Q/K/V projections (ModSkill: 256).
    #[schemars(range(min = 1))]
    pub proj_hidden: usize,
    /// Attention heads (ModSkill: 1); `embed` must be a multiple.
    #[schemars(range(min = 1))]
    pub heads: usize,
    /// Scale the attention scores by 1/sqrt(embed/heads): the paper's Eq. 5 does, the released
    /// code does not (default).
    pub scaled: bool,
    /// Hidden widths of every part controller. Default [512, 256] for CPUs; the released code
    /// uses [2048, 1536, 1024, 512] (preset `modskill`).
    #[schemars(inner(range(min = 1)))]
    pub controller: Vec<usize>,
}

impl Default for ModularConfig {
    fn default() -> Self {
        Self {
            parts: "five".into(),
            embed: 64,
            proj_hidden: 256,
            heads: 1,
            scaled: false,
            controller: vec![512, 256],
        }
    }
}

/// Which adversarial loss of the motion prior.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AmpLoss {
    /// Binary cross-entropy on the logits (the released AMP/ASE code).
    Logistic,
    /// Least squares with targets ±1 (the AMP paper).
    LeastSquares,
}

/// When the motion prior's discriminator takes its steps (`ppo.amp.schedule`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AmpSchedule {
    /// After each PPO update, `updates` steps of `batch` buffer windows against `batch` reference
    /// windows; the buffer a ring of `buffer` windows, `buffer / horizon` of them kept per step
    /// (the default; the project's CPU-sized scheme).
    PerIteration,
    /// The released AMP/ASE/TokenHSI agent's scheme: one step in every PPO minibatch, on `batch`
    /// windows of the minibatch's own samples plus as many replay windows against `batch`
    /// reference windows; after the update the rollout's windows go into a replay buffer of
    /// `buffer` windows, every one while it is not yet full, then each with probability
    /// `replay_keep` (released: `amp_minibatch_size` 4 096, `amp_replay_buffer_size` 200 000,
    /// `amp_replay_keep_prob` 0.01).
    PerMinibatch,
}

/// How the discriminator's input normaliser pools a window's entries (`ppo.amp.normalizer`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AmpNormalizer {
    /// One running mean and variance per window entry (the default; ModSkill's released rule).
    PerEntry,
    /// One running mean and variance per frame entry, shared by the window's frames, with a
    /// condition one-hot counted once per frame (TokenHSI's released rule, from CALM).
    PerFrame,
}

/// `[ppo.amp]`: the adversarial motion prior (a style reward from a discriminator over windows of
/// frames; ModSkill and TokenHSI), off by default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AmpConfig {
    /// Add the style reward: r = task_weight · r_task + style_weight · r_style.
    pub enabled: bool,
    /// Frames per window (10 in ModSkill and TokenHSI).
    #[schemars(range(min = 1))]
    pub window: usize,
    /// Hidden widths of the discriminator MLP ([1024, 512]).
    #[schemars(inner(range(min = 1)))]
    pub hidden: Vec<usize>,
    /// Adversarial loss.
    pub loss: AmpLoss,
    /// Gradient-penalty weight on reference windows (5, the AMP code).
    #[schemars(range(min = 0))]
    pub grad_penalty: f64,
    /// Weight of the squared output-layer weights (0.05, the AMP code; ModSkill's and TokenHSI's
    /// released 0.01 in presets `modskill` and `tokenhsi`).
    #[schemars(range(min = 0))]
    pub logit_reg: f64,
    /// Weight of the sum of every layer's squared weights, biases excluded (the AMP/ASE code's
    /// `disc_weight_decay`: 0 here by default; the released 1e-4 in presets `modskill` and
    /// `tokenhsi`).
    #[schemars(range(min = 0))]
    pub weight_decay: f64,
    /// Discriminator Adam learning rate.
    #[schemars(range(min = 0, max = 1000))]
    pub lr: f64,
    /// Style-reward scale (2, the AMP code).
    #[schemars(range(min = 0))]
    pub reward_scale: f64,
    /// Weight of the task reward (0.5 in ModSkill and TokenHSI).
    #[schemars(range(min = 0))]
    pub task_weight: f64,
    /// Weight of the style reward (0.5).
    #[schemars(range(min = 0))]
    pub style_weight: f64,
    /// Simulated windows kept for the discriminator (a ring buffer filled during rollouts; with
    /// `schedule = "per_minibatch"` the replay buffer, released 200 000 in preset `tokenhsi`).
    #[schemars(range(min = 1))]
    pub buffer: usize,
    /// Windows per discriminator minibatch (as many reference windows are drawn). With
    /// `schedule = "per_minibatch"`: the current-rollout windows per PPO minibatch (at most its
    /// samples), with as many replay and reference windows.
    #[schemars(range(min = 1))]
    pub batch: usize,
    /// Discriminator steps per iteration (`schedule = "per_iteration"` only).
    pub updates: usize,
    /// When the discriminator steps: after the PPO update (default) or in every PPO minibatch
    /// with a replay buffer (the released TokenHSI/ASE agent).
    pub schedule: AmpSchedule,
    /// `schedule = "per_minibatch"`: once the replay buffer is full, the probability that a new
    /// window goes in (released 0.01).
    #[schemars(range(min = 0, max = 1))]
    pub replay_keep: f64,
    /// The input normaliser: per window entry (default) or per frame (preset `tokenhsi`).
    pub normalizer: AmpNormalizer,
}

impl Default for AmpConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            window: 10,
            hidden: vec![1024, 512],
            loss: AmpLoss::Logistic,
            grad_penalty: 5.0,
            logit_reg: 0.05,
            weight_decay: 0.0,
            lr: 2e-5,
            reward_scale: 2.0,
            task_weight: 0.5,
            style_weight: 0.5,
            buffer: 8192,
            batch: 512,
            updates: 4,
            schedule: AmpSchedule::PerIteration,
            replay_keep: 0.01,
            normalizer: AmpNormalizer::PerEntry,
        }
    }
}
