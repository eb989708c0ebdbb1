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
    #[schemars(range(min = 1))]
    pub every: usize,
    /// "model_free" (part recombination, mirroring, time warping — not a learned model),
    /// "command" (an external program, `command`) or the name of a generator registered in this
    /// process (a Python callable: `skillmimic_rs.register_generator`).
    pub generator: String,
    /// The external generator's program and arguments; it is called with two more arguments, the
    /// failed clip (project format) and an empty folder to write new clips into.
    pub command: Vec<String>,
    /// What a round does with the failed clips, as the released code's three modes:
    /// `"generative"` (`auto_pmcp_generative`, ModSkill's: they feed the generator and their
    /// weights are multiplied by `failure_weight`), `"hard"` (`auto_pmcp`: no generation; until
    /// the next round only this round's failed clips are drawn, all equally; a round without
    /// failures draws every clip equally) or `"soft"` (`auto_pmcp_soft`: no generation; a clip's
    /// weight is the number of rounds it has failed so far, from `active.jsonl`, so clips that
    /// never failed are not drawn; a round without failures draws every clip equally).
    pub mode: ActiveMode,
    /// Multiplier of a failed clip's sampling weight per failed round of the generative mode: 1
    /// keeps the weights (the released generative mode: failed clips only feed the generator).
    /// A value above 1 raises a clip that keeps failing geometrically (2: this project's rule
    /// before issue 39).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub failure_weight: f64,
    /// Validity filter: tolerated depth of a body frame below the floor (m).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub floor_tol: f64,
    /// Validity filter: fastest joint rotation (rad/s).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub max_joint_speed: f64,
    /// Optional filter by the motion prior (needs `ppo.amp.enabled`): a generated clip is kept
    /// only when the mean of sigmoid(D) over its 10-frame windows is at least this (0 = off; the
    /// released ModSkill code keeps samples with a score of 0.5 — not in the paper).
    #[schemars(range(min = 0), extend("exclusiveMaximum" = 1))]
    pub disc_score_min: f64,
}

/// The released code's re-weighting modes ([`ActiveConfig::mode`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ActiveMode {
    #[default]
    Generative,
    Hard,
    Soft,
}

impl Default for ActiveConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            every: 50,
            generator: "model_free".into(),
            command: Vec::new(),
            mode: ActiveMode::Generative,
            failure_weight: 1.0,
            floor_tol: 0.05,
            max_joint_speed: 60.0,
            disc_score_min: 0.0,
        }
    }
}

impl ActiveConfig {
    /// Check the values for the task `task` (errors name the key; each number's own range is
    /// checked by `TrainConfig::validate_ranges`).
    pub fn validate(&self, task: &str) -> Result<(), String> {
        if !self.enabled {
            return Ok(());
        }
        if !skillmimic_env::registry::entry(task).is_some_and(|e| e.active_learning) {
            let able: Vec<&str> = skillmimic_env::registry::TASKS
                .iter()
                .filter(|e| e.active_learning)
                .map(|e| e.name)
                .collect();
            return Err(format!(
                "config field 'run.active.enabled': active skill learning runs on the task(s) {}, \
                    not '{task}'",
                able.join(", ")
            ));
        }
        match self.generator.as_str() {
            "model_free" => {}
            "command" if self.command.is_empty() => {
                return Err(
                    "config field 'run.active.command': the \"command\" generator needs a program"
                        .into(),
                );
            }
            "command" => {}
            other if skillmimic_motion::generate::registered(other).is_some() => {}
            other => {
                let known: Vec<String> = skillmimic_motion::generate::BUILT_IN
                    .iter()
                    .map(|s| s.to_string())
                    .chain(skillmimic_motion::generate::registered_names())
                    .collect();
                return Err(format!(
                    "config field 'run.active.generator': '{other}', expected one of {known:?} (a \
                        Python generator must be registered with skillmimic_rs.register_generator \
                        first)"
                ));
            }
        }
        Ok(())
    }
}
