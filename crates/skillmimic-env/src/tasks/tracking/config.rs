//! Configuration of the `tracking` task (`[env.tracking]`): motion tracking without the ball,
//! ModSkill's / PHC's task (modskill-tokenhsi-facts §1.5; seed 001 §4). Defaults are the
//! released ModSkill training config.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// Options of the `tracking` task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TrackingConfig {
    /// Early termination when the mean distance (m) between simulated and reference body
    /// positions exceeds this (0.25 in ModSkill's training config; evaluate with 0.5, the
    /// papers' success threshold).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub termination_distance: f64,
    /// An episode is a success when it reaches the end of its clip and the mean body distance
    /// never exceeded this (m; PHC's and ModSkill's 0.5).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Track the 30 finger bodies too (reward, termination, observation, metrics). Off by
    /// default: the 23 remaining bodies are the counterpart of the SMPL bodies ModSkill tracks.
    pub fingers: bool,
    /// Weights of the position, rotation, velocity and angular-velocity terms.
    #[schemars(inner(range(min = 0)))]
    pub weights: [f64; 4],
    /// Exponent scales k of exp(−k · mean error²) of the same four terms.
    #[schemars(inner(range(min = 0)))]
    pub scales: [f64; 4],
    /// Bodies (by name) whose mean distance to the reference decides termination and success;
    /// empty = the character's default (SMPL: the released 20 `reset_bodies`, all but the ankles
    /// and toes; otherwise the tracked bodies).
    ///
    /// The metrics (E_g-mpjpe, …) stay over all tracked bodies.
    pub termination_bodies: Vec<String>,
    /// How the position, velocity and angular-velocity errors are averaged (the rotation error
    /// is one angle per body either way).
    pub error_mean: ErrorMean,
    /// Coefficient of the power penalty Σ|τ · q̇| (W) subtracted from the reward.
    #[schemars(range(min = 0))]
    pub power_coef: f64,
    /// The first steps of an episode whose power penalty is zero (the released code:
    /// `progress_buf <= 3` → steps 1, 2 and 3 after a reset, whose drive forces can still carry
    /// the jump into the reset state).
    pub power_free_steps: usize,
    /// The first steps of an episode that the distance rule never terminates (the released
    /// code: `has_fallen *= progress_buf > 1` → step 1 after a reset). The same grace applies to
    /// the success threshold. An unstable simulation ends the episode at any step.
    pub termination_grace: usize,
    /// Start episodes at a uniformly random frame (else at frame 0).
    pub random_start: bool,
    /// Sampling-weight multipliers by clip name (active skill learning raises the weights of
    /// clips the policy fails on); a clip not named keeps its library weight. 0 leaves a clip out
    /// of the draw (the released `auto_pmcp` modes); at least one clip must keep a weight.
    #[schemars(extend("additionalProperties" = {"type": "number", "format": "double", "minimum": 0}))]
    pub clip_weights: BTreeMap<String, f64>,
}

/// How the tracking reward averages a vector error (Δp, Δv, Δω) over the tracked bodies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ErrorMean {
    /// The released ModSkill/PHC code (`(d**2).mean(-1).mean(-1)`): the mean over bodies *and*
    /// over x, y, z of the squared components, i.e. mean ‖Δp‖² / 3.
    #[default]
    Components,
    /// The paper's equation (seed 001 §3.1, ‖p − p̂‖²): the mean over bodies of the squared
    /// vector norm, 3× the released value (this project's form before issue 39).
    Vector,
}

impl ErrorMean {
    /// The divisor of a mean squared vector norm.
    pub fn divisor(self) -> f64 {
        match self {
            Self::Components => 3.0,
            Self::Vector => 1.0,
        }
    }
}

impl crate::config_table::TaskConfig for TrackingConfig {
    const KEY: &'static str = "tracking";
    const DOC: &'static str =
        "Options of the `tracking` task (motion tracking without the ball; ModSkill).";
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            termination_distance: 0.25,
            success_distance: 0.5,
            fingers: false,
            weights: [0.5, 0.3, 0.1, 0.1],
            scales: [100.0, 10.0, 0.1, 0.1],
            termination_bodies: Vec::new(),
            error_mean: ErrorMean::Components,
            power_coef: 0.0005,
            power_free_steps: 3,
            termination_grace: 1,
            random_start: true,
            clip_weights: BTreeMap::new(),
        }
    }
}

impl TrackingConfig {
    /// Check the values: nothing beyond each key's own range (checked by
    /// `EnvConfig::validate_driver`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        Ok(())
    }
}
