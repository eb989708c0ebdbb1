//! Configuration of the high-level tasks of SkillMimic (seed 000 §5.4; reference-facts §8):
//! `[env.hlc]` (shared mechanics) and one table per task, `[env.heading]`, `[env.circling]`,
//! `[env.throwing]`, `[env.scoring]`. Defaults reproduce the released code; where the paper's
//! formula differs it is the documented switch `reward = "paper"`.

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, bad};

/// Which formula a task reward uses where the paper and the released code differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Formula {
    /// The released code (reference-facts §8.2), the default.
    #[default]
    Code,
    /// The paper's equations (seed 000 eqs. 8–13).
    Paper,
}

/// When a high-level transition and an episode's observations see what (`env.hlc.timing`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum HlcTiming {
    /// The released SkillMimic loop (reference-facts §8.1; `hrl_agent_discrete.py`,
    /// `humanoid_task.py`), the default: an episode that ends inside the held steps keeps being
    /// simulated to the transition's end, whose reward is the mean over all its steps (those
    /// after the end included), whose flags are set when any step ended the episode and whose
    /// observation is the last step's; the first observation of an episode still shows the
    /// previous episode's goal (and the scoring task's "reached" flag), since the released code
    /// observes before it draws the new goal (the very first episode: a zero goal); after every
    /// step the observation is taken before the reward updates the latches (the scoring task's
    /// observed "reached" flag is one low-level step late).
    #[default]
    Released,
    /// This project's earlier reading: the transition ends at the step that ends the episode
    /// (mean over the steps up to it, its terminal observation), an episode's first observation
    /// shows its own goal, and each observation shows the latches of its own step.
    Cut,
}

/// Options shared by the high-level tasks (`[env.hlc]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct HlcConfig {
    /// The frozen skill policy (`--llc` on the command line; only read): a `gaussian_mlp`
    /// checkpoint of `skillmimic train` on the imitation task (observation 902) — the high-level
    /// policy then picks one of the task's skills (discrete choices) — or a `modular_attention`
    /// checkpoint (ModSkill skill reuse, seed 001 §3.5): the high-level policy's continuous action
    /// is one embedding per body part that drives the checkpoint's frozen part controllers.
    #[schemars(extend("format" = "path"))]
    pub llc: PathBuf,
    /// Low-level steps each high-level choice is held for (3 = 20 Hz at the 60 Hz policy rate).
    #[schemars(range(min = 1))]
    pub llc_steps: usize,
    /// Low-level steps each high-level action is held for when `llc` is a `modular_attention`
    /// checkpoint (1: ModSkill's high-level policy gives the part embeddings at the controllers'
    /// rate).
    #[schemars(range(min = 1))]
    pub latent_steps: usize,
    /// Episode length in low-level steps; an episode is truncated after `episode_length − 1`
    /// steps (the released code resets when its progress counter reaches 799 with 800).
    #[schemars(range(min = 2))]
    pub episode_length: usize,
    /// Early termination when the root (pelvis) is below this height (m) after the first step.
    pub termination_height: f64,
    /// Every episode starts at this frame of a clip drawn from `env.motion` (class-balanced).
    /// The original uses BallPlay-M `run` clips for heading, circling and scoring and
    /// `turnhook` clips for throwing: pass them with `--motion`.
    #[schemars(range(min = 2))]
    pub start_frame: usize,
    /// "released" (the released SkillMimic code's transition and observation timing) or "cut"
    /// (see [`HlcTiming`]); applies to heading, circling, throwing and scoring (ModSkill's
    /// steering and reach always use "cut").
    pub timing: HlcTiming,
}

impl crate::config_table::TaskConfig for HlcConfig {
    const KEY: &'static str = "hlc";
    const DOC: &'static str = "Options shared by the high-level tasks (heading, circling, \
        throwing, scoring, steering, reach).";
}

impl Default for HlcConfig {
    fn default() -> Self {
        Self {
            llc: PathBuf::new(),
            llc_steps: 3,
            latent_steps: 1,
            episode_length: 800,
            termination_height: 0.25,
            start_frame: 2,
            timing: HlcTiming::Released,
        }
    }
}

/// Where heading goals are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GoalSampling {
    /// goal = root + (U(min, max), U(min, max)): always in the world +x, +y quadrant (the code).
    #[default]
    Quadrant,
    /// The same offset turned by a uniform angle in [0, 2π): any direction.
    FullCircle,
}

/// `heading`: dribble the ball to a target (`[env.heading]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct HeadingConfig {
    /// Smallest goal offset per axis (m).
    #[schemars(range(min = 0))]
    pub goal_min: f64,
    /// Largest goal offset per axis (m).
    #[schemars(range(min = 0))]
    pub goal_max: f64,
    /// Goal directions.
    pub goal_sampling: GoalSampling,
    /// Height of the target point the ball is rewarded towards (m).
    pub target_height: f64,
    /// Reward: code exp(−‖ball − target‖), paper exp(−‖ball − target‖²).
    pub reward: Formula,
    /// Success: the ball comes within this distance (m) of the target point (paper = code).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_radius: f64,
}

impl crate::config_table::TaskConfig for HeadingConfig {
    const KEY: &'static str = "heading";
    const DOC: &'static str = "Options of the `heading` task.";
}

impl Default for HeadingConfig {
    fn default() -> Self {
        Self {
            goal_min: 2.0,
            goal_max: 8.0,
            goal_sampling: GoalSampling::Quadrant,
            target_height: 1.0,
            reward: Formula::Code,
            success_radius: 0.5,
        }
    }
}

/// `steering`: move in a commanded direction at a commanded speed (`[env.steering]`; ModSkill
/// supplementary "Steering", after ASE and PULSE).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SteeringConfig {
    /// Slowest commanded speed (m/s).
    #[schemars(range(min = 0))]
    pub speed_min: f64,
    /// Fastest commanded speed (m/s).
    #[schemars(range(min = 0))]
    pub speed_max: f64,
    /// Fewest low-level steps before a new direction and speed are drawn (200 = 3.3 s at 60 Hz).
    #[schemars(range(min = 1))]
    pub change_steps_min: u32,
    /// Most low-level steps before a new direction and speed are drawn (600 = 10 s).
    #[schemars(range(min = 1))]
    pub change_steps_max: u32,
    /// k in the reward exp(−k·‖v*·d − v_root,xy‖²) (1/(m/s)², ASE's velocity-error scale 0.25).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub error_scale: f64,
}

impl crate::config_table::TaskConfig for SteeringConfig {
    const KEY: &'static str = "steering";
    const DOC: &'static str = "Options of the `steering` task (ModSkill's downstream task).";
}

impl Default for SteeringConfig {
    fn default() -> Self {
        Self {
            speed_min: 0.5,
            speed_max: 3.0,
            change_steps_min: 200,
            change_steps_max: 600,
            error_scale: 0.25,
        }
    }
}

impl SteeringConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("env.steering.speed_min", self.speed_min, self.speed_max)?;
        range("env.steering.change_steps_min", self.change_steps_min, self.change_steps_max)
    }
}

/// `reach`: bring the right hand to a 3-D target (`[env.reach]`; ModSkill supplementary
/// "Reach").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ReachConfig {
    /// Side of the target box (m).
    #[schemars(range(min = 0))]
    pub box_size: f64,
    /// Height of the box centre above the floor (m); its xy is the root's start position.
    pub center_height: f64,
    /// The body brought to the target (a body name of the humanoid).
    pub hand_body: String,
    /// k in the reward exp(−k·‖p_hand − c‖²) (1/m²).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub scale: f64,
    /// Fewest low-level steps before a new target is drawn.
    #[schemars(range(min = 1))]
    pub change_steps_min: u32,
    /// Most low-level steps before a new target is drawn.
    #[schemars(range(min = 1))]
    pub change_steps_max: u32,
}

impl crate::config_table::TaskConfig for ReachConfig {
    const KEY: &'static str = "reach";
    const DOC: &'static str = "Options of the `reach` task (ModSkill's downstream task).";
}

impl Default for ReachConfig {
    fn default() -> Self {
        Self {
            box_size: 2.0,
            center_height: 1.0,
            hand_body: "R_Middle1".into(),
            scale: 5.0,
            change_steps_min: 200,
            change_steps_max: 600,
        }
    }
}

impl ReachConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("env.reach.change_steps_min", self.change_steps_min, self.change_steps_max)
    }
}

/// `circling`: dribble around the start point at a given radius (`[env.circling]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CirclingConfig {
    /// Smallest radius (m).
    #[schemars(range(min = 0))]
    pub radius_min: f64,
    /// Largest radius (m).
    #[schemars(range(min = 0))]
    pub radius_max: f64,
    /// Ball speed (m/s) below which the reward is scaled by `slow_factor` (paper: ‖v‖² compared
    /// with this value).
    #[schemars(range(min = 0))]
    pub speed_threshold: f64,
    /// Reward factor when the ball is slow.
    #[schemars(range(min = 0, max = 1))]
    pub slow_factor: f64,
    /// Reward: code exp(−|‖ball_xy − c‖ − r|), paper exp(−|‖ball_xy − c‖² − r|) with the
    /// squared-speed gate.
    pub reward: Formula,
    /// Paper success: a frame is valid when |‖ball_xy − c‖ − r| is below this (m) and the ball
    /// is faster than `speed_threshold`; the success rate is the share of valid frames.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_band: f64,
    /// The code's latch: the ball came within this distance (m) of the centre.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub code_latch_radius: f64,
}

impl crate::config_table::TaskConfig for CirclingConfig {
    const KEY: &'static str = "circling";
    const DOC: &'static str = "Options of the `circling` task.";
}

impl Default for CirclingConfig {
    fn default() -> Self {
        Self {
            radius_min: 2.0,
            radius_max: 5.0,
            speed_threshold: 0.5,
            slow_factor: 0.1,
            reward: Formula::Code,
            success_band: 0.5,
            code_latch_radius: 0.3,
        }
    }
}

/// `throwing`: throw the ball up to a height, catch the rebound, repeat (`[env.throwing]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ThrowingConfig {
    /// Height the reward exp(−|z_ball − h|) pulls the ball to (m).
    pub target_height: f64,
    /// Success (paper): after the first throw the ball stays above `floor_height` for
    /// `success_seconds`. The first throw is the first step on which the ball is above
    /// `throw_height` (m) and touches nothing (our definition; the paper does not give one).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub throw_height: f64,
    /// Height (m) the ball must stay above after the first throw.
    pub floor_height: f64,
    /// Seconds after the first throw (60 low-level steps per second).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_seconds: f64,
}

impl crate::config_table::TaskConfig for ThrowingConfig {
    const KEY: &'static str = "throwing";
    const DOC: &'static str = "Options of the `throwing` task.";
}

impl Default for ThrowingConfig {
    fn default() -> Self {
        Self { target_height: 2.5, throw_height: 1.5, floor_height: 0.3, success_seconds: 10.0 }
    }
}

/// How the scoring task predicts where the ball passes the rim height.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Prediction {
    /// The released code's formula (reference-facts §8.2): t = (√(v_z² + 2g(z − h)) − v_z)/g,
    /// with h = 0 when the apex is below the rim height.
    #[default]
    Code,
    /// True ballistic motion: the descending crossing t = (v_z + √(v_z² + 2g(z − h)))/g; no
    /// prediction (not reached) when the apex stays below h.
    Ballistic,
}

/// `scoring`: dribble to a basket and lay the ball up into it (`[env.scoring]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ScoringConfig {
    /// Smallest basket distance from the start root (m).
    #[schemars(range(min = 0))]
    pub dist_min: f64,
    /// Largest basket distance (m).
    #[schemars(range(min = 0))]
    pub dist_max: f64,
    /// Height of the basket point (m).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub basket_height: f64,
    /// "Reached" latch: predicted crossing within this horizontal distance (m) of the basket.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub reach_radius: f64,
    /// Rim height h of the prediction and the least ball height (m) for "reached".
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub reach_height: f64,
    /// Prediction of the crossing point.
    pub prediction: Prediction,
    /// Any |component| of the ball's net contact force above this (N) counts as touching.
    #[schemars(range(min = 0))]
    pub contact_force: f64,
    /// Speed (m/s) of the gate (code: root speed ≥ it; paper: ball ‖v‖² > it).
    #[schemars(range(min = 0))]
    pub speed_threshold: f64,
    /// Reward factor when the gate is closed.
    #[schemars(range(min = 0, max = 1))]
    pub slow_factor: f64,
    /// Reward: code gate × [exp(−0.5‖ball − basket‖) + 1{reached} + 0.2·exp(−|z − h_b|)];
    /// paper gate × [exp(−‖ball − basket‖²) + 1{scored} + 0.2·exp(−|z − h_b|)].
    pub reward: Formula,
    /// Paper success (and the paper's bonus): the ball is higher than the basket point and
    /// within this distance (m) of it.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_radius: f64,
}

impl crate::config_table::TaskConfig for ScoringConfig {
    const KEY: &'static str = "scoring";
    const DOC: &'static str = "Options of the `scoring` task.";
}

impl Default for ScoringConfig {
    fn default() -> Self {
        Self {
            dist_min: 2.0,
            dist_max: 8.0,
            basket_height: 2.5,
            reach_radius: 0.3,
            reach_height: 2.0,
            prediction: Prediction::Code,
            contact_force: 0.1,
            speed_threshold: 0.5,
            slow_factor: 0.1,
            reward: Formula::Code,
            success_radius: 0.3,
        }
    }
}

/// A `[min, max]` pair of keys in order (each key's own range is checked by
/// [`EnvConfig::validate_driver`](crate::EnvConfig::validate_driver)).
fn range<T: PartialOrd + std::fmt::Display>(field: &str, lo: T, hi: T) -> Result<(), ConfigError> {
    if lo <= hi {
        Ok(())
    } else {
        Err(bad(field, format!("[{lo}, {hi}] is not a range min <= max")))
    }
}

impl HlcConfig {
    /// Check the shared options (each key's own range is checked by `EnvConfig::validate_driver`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.llc.as_os_str().is_empty() {
            return Err(bad(
                "env.hlc.llc",
                "no skill policy given: pass the checkpoint of a skill policy with --llc (or set \
                    env.hlc.llc)",
            ));
        }
        Ok(())
    }
}

impl HeadingConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("env.heading.goal_min", self.goal_min, self.goal_max)
    }
}

impl CirclingConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("env.circling.radius_min", self.radius_min, self.radius_max)
    }
}

impl ThrowingConfig {
    /// Nothing beyond each key's own range (checked by `EnvConfig::validate_driver`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        Ok(())
    }
}

impl ScoringConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("env.scoring.dist_min", self.dist_min, self.dist_max)
    }
}
