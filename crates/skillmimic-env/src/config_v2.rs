//! SkillMimic-V2 options (`[env.v2]` and its sub-tables) with the paper's defaults (P2 Tab. 7).

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, bad};

/// SkillMimic-V2 (seed 003) options. The four parts switch on and off independently — the
/// ablation table of seed 003 Tab. 3 — and with all of them off the environment is SkillMimic.
/// Defaults are P2 Tab. 7.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct V2Config {
    /// History encoder (§4.6): the frozen embedding is appended to the observation (902 → 905).
    pub history: HistoryConfig,
    /// State Transition Field (§4.3): ε-neighbourhood initialisation connected to the most
    /// similar reference state of the same clip.
    pub stf: StfConfig,
    /// Stitched Trajectory Graph (§4.4): start from a skill's state while imitating another
    /// skill's most similar (aligned) state.
    pub stg: StgConfig,
    /// Adaptive Trajectory Sampling (§4.5).
    pub ats: AtsConfig,
    /// Masked bridging steps after an STF/STG connection of similarity β:
    /// N = min(−⌈log10 β⌉, N_max), N = N_max when β < τ, N = 0 when β ≥ 1.
    pub bridge: BridgeConfig,
}

/// History-encoder settings.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct HistoryConfig {
    /// Use the history encoder.
    pub enabled: bool,
    /// Encoder weights written by `skillmimic history pretrain` (safetensors; the history length
    /// k and the embedding width μ are read from the file).
    #[schemars(extend("format" = "path"))]
    pub encoder: PathBuf,
}

/// Per-component half-widths ε of the neighbourhood (units of each component: m, rad, m/s,
/// rad/s). Every component is drawn uniformly from [−ε, ε] (P2 Tab. 7), except heights, which
/// are moved upward only, U(0, ε), so that neither the feet nor the ball start inside the floor
/// (as the reference code does). Rotations are perturbed by a world-frame rotation vector with
/// components in [−ε, ε].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseEps {
    /// Root x, y (m).
    #[schemars(range(min = 0))]
    pub root_pos: f64,
    /// Root height, upward only (m).
    #[schemars(range(min = 0))]
    pub root_height: f64,
    /// Root orientation (rad, rotation-vector components).
    #[schemars(range(min = 0))]
    pub root_rot: f64,
    /// Root linear velocity (m/s).
    #[schemars(range(min = 0))]
    pub root_linvel: f64,
    /// Root angular velocity (rad/s, root frame).
    #[schemars(range(min = 0))]
    pub root_angvel: f64,
    /// Joint exp-map components (rad).
    #[schemars(range(min = 0))]
    pub dof_pos: f64,
    /// Joint velocities (rad/s).
    #[schemars(range(min = 0))]
    pub dof_vel: f64,
    /// Ball x, y (m).
    #[schemars(range(min = 0))]
    pub ball_pos: f64,
    /// Ball height, upward only (m).
    #[schemars(range(min = 0))]
    pub ball_height: f64,
    /// Ball orientation (rad).
    #[schemars(range(min = 0))]
    pub ball_rot: f64,
    /// Ball linear velocity (m/s).
    #[schemars(range(min = 0))]
    pub ball_linvel: f64,
    /// Ball angular velocity (rad/s).
    #[schemars(range(min = 0))]
    pub ball_angvel: f64,
}

impl NoiseEps {
    /// Every half-width equal to `eps` (m, rad, m/s, rad/s by component).
    pub fn uniform(eps: f64) -> Self {
        Self {
            root_pos: eps,
            root_height: eps,
            root_rot: eps,
            root_linvel: eps,
            root_angvel: eps,
            dof_pos: eps,
            dof_vel: eps,
            ball_pos: eps,
            ball_height: eps,
            ball_rot: eps,
            ball_linvel: eps,
            ball_angvel: eps,
        }
    }

    /// Every width zero (no perturbation).
    pub fn zero() -> Self {
        Self::uniform(0.0)
    }
}

/// ε = 0.1 for every component, the BallPlay setting of SkillMimic-V2 (P2 Tab. 7).
impl Default for NoiseEps {
    fn default() -> Self {
        Self::uniform(0.1)
    }
}

/// State Transition Field settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct StfConfig {
    /// Use the State Transition Field.
    pub enabled: bool,
    /// p_n: probability that a reset starts from a perturbed state.
    #[schemars(range(min = 0, max = 1))]
    pub prob: f64,
    /// Per-component half-widths ε of the neighbourhood.
    pub eps: NoiseEps,
}

impl Default for StfConfig {
    fn default() -> Self {
        Self { enabled: false, prob: 0.1, eps: NoiseEps::default() }
    }
}

/// Stitched Trajectory Graph settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct StgConfig {
    /// Use the Stitched Trajectory Graph.
    pub enabled: bool,
    /// p_e: probability that a reset imitates another skill from the sampled state (applied to
    /// resets that were not perturbed by the STF, as in the reference code).
    #[schemars(range(min = 0, max = 1))]
    pub prob: f64,
}

impl Default for StgConfig {
    fn default() -> Self {
        Self { enabled: false, prob: 0.1 }
    }
}

/// How the masked bridging steps enter the reward.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MaskedReward {
    /// Paper (P2 App. B.4): the N steps are inserted before the connected reference frame (the
    /// reference holds that frame meanwhile) and their reward is excluded (0, not counted in
    /// metrics or ATS).
    #[default]
    Exclude,
    /// Reference-code compatibility: the reference advances during the N steps and their reward
    /// is replaced by the mean reward of the environments currently on the same clip.
    ReplaceWithClipMean,
}

/// Bridging-step settings shared by STF and STG.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BridgeConfig {
    /// N_max.
    pub max_masked_steps: usize,
    /// τ: similarity floor. STG connections below it are not made; an STF connection below it
    /// gets N_max steps.
    #[schemars(extend("exclusiveMinimum" = 0, "exclusiveMaximum" = 1))]
    pub tau: f64,
    /// How the masked bridging steps enter the reward; unset (the default) = follow `env.compat`
    /// (`paper` → "exclude", `code` → "replace_with_clip_mean").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub masked_reward: Option<MaskedReward>,
}

impl BridgeConfig {
    /// The masked-reward rule in effect under `compat`.
    pub fn masked_reward(&self, compat: crate::compat::Compat) -> MaskedReward {
        self.masked_reward.unwrap_or(if compat.is_code() {
            MaskedReward::ReplaceWithClipMean
        } else {
            MaskedReward::Exclude
        })
    }
}

impl Default for BridgeConfig {
    fn default() -> Self {
        Self { max_masked_steps: 10, tau: 1e-10, masked_reward: None }
    }
}

/// Adaptive Trajectory Sampling settings (P2 eq. 8).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AtsConfig {
    /// Use Adaptive Trajectory Sampling.
    pub enabled: bool,
    /// λ_s: start-frame weights ∝ exp(−λ_s r̄).
    #[schemars(range(min = 0))]
    pub lambda_s: f64,
    /// λ_c: class and clip weights ∝ exp(−λ_c R).
    #[schemars(range(min = 0))]
    pub lambda_c: f64,
    /// Mixing with uniform sampling: p = (1 − α)/n + α·p_ATS (1 = pure ATS).
    #[schemars(range(min = 0, max = 1))]
    pub alpha: f64,
    /// Vectorised environment steps between two recomputations of the distributions;
    /// 0 = 5 × (sum of the clip lengths), the reference code's interval.
    pub update_interval: usize,
}

impl Default for AtsConfig {
    fn default() -> Self {
        Self { enabled: false, lambda_s: 10.0, lambda_c: 5.0, alpha: 1.0, update_interval: 0 }
    }
}

impl V2Config {
    /// True when any V2 part is on.
    pub fn any(&self) -> bool {
        self.history.enabled || self.stf.enabled || self.stg.enabled || self.ats.enabled
    }

    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        if self.history.enabled && self.history.encoder.as_os_str().is_empty() {
            return Err(bad(
                "env.v2.history.encoder",
                "history is enabled but no encoder file is given (write one with `skillmimic \
                    history pretrain`)",
            ));
        }
        Ok(())
    }
}
