//! Configuration of the `tracking` task (`[env.tracking]`): motion tracking without the ball,
//! ModSkill's / PHC's task (modskill-tokenhsi-facts §1.5; seed 001 §4). Defaults are the
//! released ModSkill training config.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, bad};

/// Options of the `tracking` task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TrackingConfig {
    /// Early termination when the mean distance (m) between simulated and reference body
    /// positions exceeds this (0.25 in ModSkill's training config; evaluate with 0.5, the
    /// papers' success threshold).
    pub termination_distance: f64,
    /// An episode is a success when it reaches the end of its clip and the mean body distance
    /// never exceeded this (m; PHC's and ModSkill's 0.5).
    pub success_distance: f64,
    /// Track the 30 finger bodies too (reward, termination, observation, metrics). Off by
    /// default: the 23 remaining bodies are the counterpart of the SMPL bodies ModSkill tracks.
    pub fingers: bool,
    /// Weights of the position, rotation, velocity and angular-velocity terms.
    pub weights: [f64; 4],
    /// Exponent scales k of exp(−k · mean error²) of the same four terms.
    pub scales: [f64; 4],
    /// Coefficient of the power penalty Σ|τ · q̇| (W) subtracted from the reward.
    pub power_coef: f64,
    /// Start episodes at a uniformly random frame (else at frame 0).
    pub random_start: bool,
    /// Sampling-weight multipliers by clip name (active skill learning raises the weights of
    /// clips the policy fails on); a clip not named keeps its library weight.
    pub clip_weights: BTreeMap<String, f64>,
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            termination_distance: 0.25,
            success_distance: 0.5,
            fingers: false,
            weights: [0.5, 0.3, 0.1, 0.1],
            scales: [100.0, 10.0, 0.1, 0.1],
            power_coef: 0.0005,
            random_start: true,
            clip_weights: BTreeMap::new(),
        }
    }
}

impl TrackingConfig {
    /// Check the values (errors name the key).
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (key, v) in [("env.tracking.termination_distance", self.termination_distance), ("env.tracking.success_distance", self.success_distance)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(bad(key, format!("{v} must be a positive distance in metres")));
            }
        }
        if self.weights.iter().chain(&self.scales).any(|v| !(*v >= 0.0 && v.is_finite())) || !(self.power_coef >= 0.0 && self.power_coef.is_finite()) {
            return Err(bad("env.tracking", "weights, scales and power_coef must be finite and non-negative"));
        }
        if let Some((name, w)) = self.clip_weights.iter().find(|(_, w)| !(w.is_finite() && **w > 0.0)) {
            return Err(bad("env.tracking.clip_weights", format!("clip '{name}': {w} must be a positive finite multiplier")));
        }
        Ok(())
    }
}
