//! `[run.active]`: active skill learning with generative adaptive sampling (ModSkill §3.4) for the
//! `tracking` task — see [`crate::active`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Options of active skill learning (off by default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ActiveConfig {
    /// Run a round (evaluate every clip, generate from the failed ones, re-weight) every `every`
    /// iterations (`env.task = "tracking"`, one process).
    pub enabled: bool,
    /// Iterations between rounds (ModSkill: after each convergence phase, ≈ 2e8 steps).
    pub every: usize,
    /// "model_free" (part recombination, mirroring, time warping — not a learned model),
    /// "command" (an external program, `command`) or the name of a generator registered in this
    /// process (a Python callable: `skillmimic_rs.register_generator`).
    pub generator: String,
    /// The external generator's program and arguments; it is called with two more arguments, the
    /// failed clip (project format) and an empty folder to write new clips into.
    pub command: Vec<String>,
    /// Multiplier of a failed clip's sampling weight per failed round.
    pub failure_weight: f64,
    /// Validity filter: tolerated depth of a body frame below the floor (m).
    pub floor_tol: f64,
    /// Validity filter: fastest joint rotation (rad/s).
    pub max_joint_speed: f64,
    /// Optional filter by the motion prior (needs `ppo.amp.enabled`): a generated clip is kept
    /// only when the mean of sigmoid(D) over its 10-frame windows is at least this (0 = off; the
    /// released ModSkill code keeps samples with a score of 0.5 — not in the paper).
    pub disc_score_min: f64,
}

impl Default for ActiveConfig {
    fn default() -> Self {
        Self { enabled: false, every: 50, generator: "model_free".into(), command: Vec::new(), failure_weight: 2.0, floor_tol: 0.05, max_joint_speed: 60.0, disc_score_min: 0.0 }
    }
}

impl ActiveConfig {
    /// Check the values for the task `task` (errors name the key).
    pub fn validate(&self, task: &str) -> Result<(), String> {
        if !self.enabled {
            return Ok(());
        }
        if task != "tracking" {
            return Err(format!("config field 'run.active.enabled': active skill learning runs on the tracking task, not '{task}'"));
        }
        if self.every == 0 {
            return Err("config field 'run.active.every': must be at least 1".into());
        }
        match self.generator.as_str() {
            "model_free" => {}
            "command" if self.command.is_empty() => return Err("config field 'run.active.command': the \"command\" generator needs a program".into()),
            "command" => {}
            other if skillmimic_motion::generate::registered(other).is_some() => {}
            other => {
                let known: Vec<String> = skillmimic_motion::generate::BUILT_IN.iter().map(|s| s.to_string()).chain(skillmimic_motion::generate::registered_names()).collect();
                return Err(format!("config field 'run.active.generator': '{other}', expected one of {known:?} (a Python generator must be registered with skillmimic_rs.register_generator first)"));
            }
        }
        if !(0.0..1.0).contains(&self.disc_score_min) {
            return Err(format!("config field 'run.active.disc_score_min': {} is outside [0, 1)", self.disc_score_min));
        }
        let v = [self.failure_weight, self.floor_tol, self.max_joint_speed];
        if v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err("config fields 'run.active.failure_weight', 'floor_tol', 'max_joint_speed' must be positive".into());
        }
        Ok(())
    }
}
