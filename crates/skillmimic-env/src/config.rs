//! Typed environment configuration with the paper's defaults (SkillMimic, seed 000 §5–6).
//!
//! Every field can be set from the `[env]` table of a TOML file; unknown keys are errors.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use skillmimic_sim::{BallParams, HandModel, SceneOptions};

/// How the reward combines its terms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RewardVariant {
    /// The unified HOI imitation reward: r = r_b · r_o · r_rel · r_reg · r_cg (P1 eq. 2).
    #[default]
    Skillmimic,
    /// Ablation "w/o contact-graph reward": the same product without r_cg.
    NoContactGraph,
    /// Ablation "w/o multiplication": the mean of r_b (incl. r_reg), r_o, r_rel and r_cg.
    /// The paper gives no weights for this sum; equal weights are our choice.
    Additive,
    /// DeepMimic-style baseline: exp terms with the weights of `[reward.deepmimic]`
    /// (seed 003 Tab. 9: p 40, r 2, rv 0.1, op 40) summed with equal weights, no contact term.
    Deepmimic,
}

/// How simulated contact-graph states are measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactGraphMode {
    /// Exact MuJoCo contact pairs: edges hand–ball (target: the clip label), body–ball,
    /// hand–body and body–floor (targets 0). Body = every humanoid body that is not a hand;
    /// for body–floor, feet are excluded.
    #[default]
    Exact,
    /// Reproduce the reference labels: body node = any |force component| ≥ threshold on a
    /// reference body-node body (target 0); ball node = |F_x| or |F_y| of the ball's net
    /// contact force > threshold (target: the clip label).
    ForceThreshold,
}

/// Weights of the DeepMimic-style baseline (seed 003 Tab. 9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeepMimicWeights {
    pub w_p: f64,
    pub w_r: f64,
    pub w_rv: f64,
    pub w_op: f64,
}

impl Default for DeepMimicWeights {
    fn default() -> Self {
        Self { w_p: 40.0, w_r: 2.0, w_rv: 0.1, w_op: 40.0 }
    }
}

/// Reward weights (exponent scales) and variant. Defaults: SkillMimic yaml.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    pub variant: RewardVariant,
    /// Body position: root + 17 key bodies.
    pub w_p: f64,
    /// Body rotation: root exp map + 156 joint exp-map components.
    pub w_r: f64,
    /// Key-body linear velocity.
    pub w_pv: f64,
    /// Joint velocity.
    pub w_rv: f64,
    /// Velocity regulariser exponent weight.
    pub w_reg: f64,
    /// Scale of the reference velocity in the regulariser denominator 1 + scale·v̂².
    pub reg_scale: f64,
    /// Ball position.
    pub w_op: f64,
    /// Ball rotation (squared rotation angle).
    pub w_or: f64,
    /// Ball linear velocity.
    pub w_opv: f64,
    /// Ball angular velocity.
    pub w_orv: f64,
    /// Relative (interaction-graph) term: root and key bodies minus the ball.
    pub w_ig: f64,
    /// How contact-graph states are measured.
    pub contact_graph: ContactGraphMode,
    /// Exact mode edge weights.
    pub w_cg_hand_ball: f64,
    pub w_cg_body_ball: f64,
    pub w_cg_hand_body: f64,
    pub w_cg_body_floor: f64,
    /// Force-threshold mode node weights (cg1: body node, cg2: ball node).
    pub w_cg1_body: f64,
    pub w_cg2_ball: f64,
    /// Force threshold (N) of the force-threshold mode.
    pub force_threshold: f64,
    /// Weights of the DeepMimic-style variant.
    pub deepmimic: DeepMimicWeights,
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self {
            variant: RewardVariant::Skillmimic,
            w_p: 20.0,
            w_r: 20.0,
            w_pv: 0.0,
            w_rv: 0.0,
            w_reg: 0.1,
            reg_scale: 1e12,
            w_op: 1.0,
            w_or: 0.0,
            w_opv: 0.0,
            w_orv: 0.0,
            w_ig: 20.0,
            contact_graph: ContactGraphMode::Exact,
            w_cg_hand_ball: 5.0,
            w_cg_body_ball: 5.0,
            w_cg_hand_body: 5.0,
            w_cg_body_floor: 5.0,
            w_cg1_body: 5.0,
            w_cg2_ball: 5.0,
            force_threshold: 0.1,
            deepmimic: DeepMimicWeights::default(),
        }
    }
}

/// Scale factors of the ball's physical properties (robustness tests, seed 000 Tab. 2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BallOverrides {
    pub radius_scale: f64,
    pub density_scale: f64,
    pub restitution_scale: f64,
}

impl Default for BallOverrides {
    fn default() -> Self {
        Self { radius_scale: 1.0, density_scale: 1.0, restitution_scale: 1.0 }
    }
}

/// Where episodes start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateInit {
    /// Random clip (class-balanced) and random start frame 2 … T−2 (training).
    #[default]
    Random,
    /// Random clip, fixed start frame (clamped to T−2) — evaluation.
    Frame(usize),
}

/// Environment configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnvConfig {
    /// Clip files or folders (searched recursively for `.pt` and `.safetensors`).
    pub motion: Vec<PathBuf>,
    /// Number of parallel environments.
    pub num_envs: usize,
    /// Simulation threads (0 = one per core).
    pub threads: usize,
    /// Hand model: "full" (156 dofs) or "box" (fingers welded).
    pub hands: String,
    /// Maximum episode length in policy steps (reference frames), 60 = 1 s.
    pub episode_length: usize,
    /// Early termination when the root is below this height (m) after the first step.
    pub termination_height: f64,
    /// Reference-state initialisation.
    pub state_init: StateInit,
    /// Evaluation horizon: when > 0 every episode lasts exactly this many steps (truncation) and
    /// reference frames past the clip end hold the last frame (SkillMimic-V2 success rates are
    /// measured over 10 s = 600 steps). 0 = training behaviour (episodes end with the clip).
    pub fixed_horizon: usize,
    /// Random seed of clip/frame sampling.
    pub seed: u64,
    pub reward: RewardConfig,
    pub ball: BallOverrides,
    /// SkillMimic-V2 options (all off by default = SkillMimic).
    pub v2: V2Config,
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            motion: vec![PathBuf::from("motions")],
            num_envs: 64,
            threads: 0,
            hands: "full".into(),
            episode_length: 60,
            termination_height: 0.3,
            state_init: StateInit::Random,
            fixed_horizon: 0,
            seed: 0,
            reward: RewardConfig::default(),
            ball: BallOverrides::default(),
            v2: V2Config::default(),
        }
    }
}

/// SkillMimic-V2 (seed 003) options. The four parts switch on and off independently — the
/// ablation table of seed 003 Tab. 3 — and with all of them off the environment is SkillMimic.
/// Defaults are P2 Tab. 7.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
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
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HistoryConfig {
    pub enabled: bool,
    /// Encoder weights written by `skillmimic history pretrain` (safetensors; the history length
    /// k and the embedding width μ are read from the file).
    pub encoder: PathBuf,
}

/// Per-component half-widths ε of the neighbourhood (units of each component: m, rad, m/s,
/// rad/s). Every component is drawn uniformly from [−ε, ε] (P2 Tab. 7), except heights, which
/// are moved upward only, U(0, ε), so that neither the feet nor the ball start inside the floor
/// (as the reference code does). Rotations are perturbed by a world-frame rotation vector with
/// components in [−ε, ε].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseEps {
    /// Root x, y (m).
    pub root_pos: f64,
    /// Root height, upward only (m).
    pub root_height: f64,
    /// Root orientation (rad, rotation-vector components).
    pub root_rot: f64,
    /// Root linear velocity (m/s) and angular velocity (rad/s, root frame).
    pub root_linvel: f64,
    pub root_angvel: f64,
    /// Joint exp-map components (rad) and joint velocities (rad/s).
    pub dof_pos: f64,
    pub dof_vel: f64,
    /// Ball x, y (m) and height (upward only, m).
    pub ball_pos: f64,
    pub ball_height: f64,
    /// Ball orientation (rad), linear velocity (m/s), angular velocity (rad/s).
    pub ball_rot: f64,
    pub ball_linvel: f64,
    pub ball_angvel: f64,
}

impl NoiseEps {
    /// Every width zero (no perturbation).
    pub fn zero() -> Self {
        Self {
            root_pos: 0.0,
            root_height: 0.0,
            root_rot: 0.0,
            root_linvel: 0.0,
            root_angvel: 0.0,
            dof_pos: 0.0,
            dof_vel: 0.0,
            ball_pos: 0.0,
            ball_height: 0.0,
            ball_rot: 0.0,
            ball_linvel: 0.0,
            ball_angvel: 0.0,
        }
    }
}

impl Default for NoiseEps {
    fn default() -> Self {
        Self {
            root_pos: 0.1,
            root_height: 0.1,
            root_rot: 0.1,
            root_linvel: 0.1,
            root_angvel: 0.1,
            dof_pos: 0.1,
            dof_vel: 0.1,
            ball_pos: 0.1,
            ball_height: 0.1,
            ball_rot: 0.1,
            ball_linvel: 0.1,
            ball_angvel: 0.1,
        }
    }
}

/// State Transition Field settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StfConfig {
    pub enabled: bool,
    /// p_n: probability that a reset starts from a perturbed state.
    pub prob: f64,
    pub eps: NoiseEps,
}

impl Default for StfConfig {
    fn default() -> Self {
        Self { enabled: false, prob: 0.1, eps: NoiseEps::default() }
    }
}

/// Stitched Trajectory Graph settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StgConfig {
    pub enabled: bool,
    /// p_e: probability that a reset imitates another skill from the sampled state (applied to
    /// resets that were not perturbed by the STF, as in the reference code).
    pub prob: f64,
}

impl Default for StgConfig {
    fn default() -> Self {
        Self { enabled: false, prob: 0.1 }
    }
}

/// How the masked bridging steps enter the reward.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BridgeConfig {
    /// N_max.
    pub max_masked_steps: usize,
    /// τ: similarity floor. STG connections below it are not made; an STF connection below it
    /// gets N_max steps.
    pub tau: f64,
    pub masked_reward: MaskedReward,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        Self { max_masked_steps: 10, tau: 1e-10, masked_reward: MaskedReward::Exclude }
    }
}

/// Adaptive Trajectory Sampling settings (P2 eq. 8).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AtsConfig {
    pub enabled: bool,
    /// λ_s: start-frame weights ∝ exp(−λ_s r̄).
    pub lambda_s: f64,
    /// λ_c: class and clip weights ∝ exp(−λ_c R).
    pub lambda_c: f64,
    /// Mixing with uniform sampling: p = (1 − α)/n + α·p_ATS (1 = pure ATS).
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

/// Invalid configuration value.
#[derive(Debug, thiserror::Error)]
#[error("config field '{field}': {message}")]
pub struct ConfigError {
    pub field: String,
    pub message: String,
}

fn bad(field: &str, message: impl Into<String>) -> ConfigError {
    ConfigError { field: field.into(), message: message.into() }
}

impl EnvConfig {
    /// The hand model named by `hands`.
    pub fn hand_model(&self) -> Result<HandModel, ConfigError> {
        match self.hands.as_str() {
            "full" => Ok(HandModel::Full),
            "box" | "boxhand" => Ok(HandModel::Box),
            other => Err(bad("env.hands", format!("'{other}' is not a hand model, expected \"full\" or \"box\""))),
        }
    }

    /// Scene options after the ball overrides.
    pub fn scene_options(&self) -> Result<SceneOptions, ConfigError> {
        let base = BallParams::default();
        let b = &self.ball;
        let ball = BallParams {
            radius: base.radius * b.radius_scale,
            density: base.density * b.density_scale,
            restitution: base.restitution * b.restitution_scale,
            friction: base.friction,
        };
        Ok(SceneOptions { hands: self.hand_model()?, ball, ..Default::default() })
    }

    /// Check value ranges (called by the environment constructor).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.hand_model()?;
        if self.num_envs == 0 {
            return Err(bad("env.num_envs", "must be at least 1"));
        }
        if self.episode_length < 2 {
            return Err(bad("env.episode_length", "must be at least 2 policy steps"));
        }
        if let StateInit::Frame(f) = self.state_init {
            if f < 2 {
                return Err(bad("env.state_init", format!("start frame {f} is below 2 (frames 0 and 1 have no velocity)")));
            }
        }
        if self.motion.is_empty() {
            return Err(bad("env.motion", "no clip file or folder given"));
        }
        let b = &self.ball;
        for (f, v) in [("env.ball.radius_scale", b.radius_scale), ("env.ball.density_scale", b.density_scale), ("env.ball.restitution_scale", b.restitution_scale)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(f, format!("{v} must be a positive number")));
            }
        }
        if !(b.restitution_scale * BallParams::default().restitution <= 1.0) {
            return Err(bad("env.ball.restitution_scale", "restitution would exceed 1"));
        }
        let r = &self.reward;
        let weights = [
            ("w_p", r.w_p),
            ("w_r", r.w_r),
            ("w_pv", r.w_pv),
            ("w_rv", r.w_rv),
            ("w_reg", r.w_reg),
            ("reg_scale", r.reg_scale),
            ("w_op", r.w_op),
            ("w_or", r.w_or),
            ("w_opv", r.w_opv),
            ("w_orv", r.w_orv),
            ("w_ig", r.w_ig),
            ("w_cg_hand_ball", r.w_cg_hand_ball),
            ("w_cg_body_ball", r.w_cg_body_ball),
            ("w_cg_hand_body", r.w_cg_hand_body),
            ("w_cg_body_floor", r.w_cg_body_floor),
            ("w_cg1_body", r.w_cg1_body),
            ("w_cg2_ball", r.w_cg2_ball),
            ("force_threshold", r.force_threshold),
        ];
        for (name, v) in weights {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(&format!("env.reward.{name}"), format!("{v} must be a finite number >= 0")));
            }
        }
        self.v2.validate()
    }
}

impl V2Config {
    /// True when any V2 part is on.
    pub fn any(&self) -> bool {
        self.history.enabled || self.stf.enabled || self.stg.enabled || self.ats.enabled
    }

    fn validate(&self) -> Result<(), ConfigError> {
        if self.history.enabled && self.history.encoder.as_os_str().is_empty() {
            return Err(bad("env.v2.history.encoder", "history is enabled but no encoder file is given (write one with `skillmimic history pretrain`)"));
        }
        for (f, v) in [("env.v2.stf.prob", self.stf.prob), ("env.v2.stg.prob", self.stg.prob), ("env.v2.ats.alpha", self.ats.alpha)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(bad(f, format!("{v} must be a probability in [0, 1]")));
            }
        }
        let e = &self.stf.eps;
        for (f, v) in [
            ("root_pos", e.root_pos),
            ("root_height", e.root_height),
            ("root_rot", e.root_rot),
            ("root_linvel", e.root_linvel),
            ("root_angvel", e.root_angvel),
            ("dof_pos", e.dof_pos),
            ("dof_vel", e.dof_vel),
            ("ball_pos", e.ball_pos),
            ("ball_height", e.ball_height),
            ("ball_rot", e.ball_rot),
            ("ball_linvel", e.ball_linvel),
            ("ball_angvel", e.ball_angvel),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(&format!("env.v2.stf.eps.{f}"), format!("{v} must be a finite number >= 0")));
            }
        }
        for (f, v) in [("env.v2.ats.lambda_s", self.ats.lambda_s), ("env.v2.ats.lambda_c", self.ats.lambda_c)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(f, format!("{v} must be a finite number >= 0")));
            }
        }
        if !(self.bridge.tau.is_finite() && self.bridge.tau > 0.0 && self.bridge.tau < 1.0) {
            return Err(bad("env.v2.bridge.tau", format!("{} must be in (0, 1)", self.bridge.tau)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_overrides_and_rejects_unknown_keys() {
        let c: EnvConfig = toml::from_str(
            "num_envs = 8\nstate_init = { frame = 5 }\n[reward]\nvariant = \"additive\"\nw_p = 10.0\n[ball]\nradius_scale = 1.2\n",
        )
        .unwrap();
        assert_eq!(c.num_envs, 8);
        assert_eq!(c.state_init, StateInit::Frame(5));
        assert_eq!(c.reward.variant, RewardVariant::Additive);
        assert_eq!(c.reward.w_p, 10.0);
        assert_eq!(c.reward.w_r, 20.0);
        assert!((c.scene_options().unwrap().ball.radius - 0.144).abs() < 1e-12);
        let e = toml::from_str::<EnvConfig>("num_env = 8").unwrap_err().to_string();
        assert!(e.contains("unknown field `num_env`"), "{e}");
        let mut c = EnvConfig::default();
        c.hands = "claws".into();
        assert!(c.validate().unwrap_err().to_string().contains("env.hands"));
        let mut c = EnvConfig::default();
        c.reward.w_ig = -1.0;
        assert!(c.validate().unwrap_err().to_string().contains("env.reward.w_ig"));
    }
}
