//! Configuration of the TokenHSI tasks (`[env.hsi]` and its `follow`, `sit`, `climb`, `carry`
//! sub-tables): TokenHSI supplementary §B.2 and Tab. A, modskill-tokenhsi-facts §2.2. Episode
//! lengths are in 30 Hz policy steps.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, bad};

/// Options shared by the TokenHSI tasks, and each task's table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct HsiConfig {
    /// Compiled object variants per run: environment i uses variant i mod this (each variant
    /// samples the task's object sizes once, like the original's per-environment assets).
    #[schemars(range(min = 1))]
    pub object_variants: usize,
    /// Seed of the object sizes of the variants.
    pub object_seed: u64,
    /// Character-fall termination (the released rule): after the first step, the episode ends
    /// when some body other than the feet feels a contact force (> 0.1 N on an axis) while some
    /// body other than the feet is below its termination height — this height (m) for every body
    /// but the head.
    #[schemars(range(min = 0))]
    pub termination_height: f64,
    /// The head's termination height (m): max(this, `termination_height`), as released.
    #[schemars(range(min = 0))]
    pub head_termination_height: f64,
    /// Power penalty weight: every task's reward adds `−power_coefficient · Σ|τ·q̇|` over the
    /// character's dofs (drive torques τ, N·m; joint rates q̇, rad/s), the released
    /// `power_coefficient` (0 switches it off).
    #[schemars(range(min = 0))]
    pub power_coefficient: f64,
    /// How an episode starts (`reference_init`): `auto` (default: a random frame of the task's
    /// reference clips when it has any, else the rest pose — the released `stateInit: Random`
    /// where motions are given), `default` (the rest pose), `reference` (always a clip frame;
    /// clips required), `hybrid` (a clip frame with probability `hybrid_init_prob`).
    pub state_init: StateInit,
    /// Probability of a reference start under `state_init = "hybrid"`.
    #[schemars(range(min = 0, max = 1))]
    pub hybrid_init_prob: f64,
    /// Which form of TokenHSI the tasks follow where the supplementary's text and the released
    /// code differ: `released` (default) or `supplementary` (the follow observation's waypoints
    /// 0.1 s apart instead of 0.5 s).
    pub form: HsiForm,
    /// Start heading of the character: uniformly random (else facing +x).
    pub random_heading: bool,
    /// Reference clips of the character (`tokenhsi-clip` files or folders, e.g. written by
    /// `skillmimic retarget`) for the adversarial motion prior of the run's task (`ppo.amp`;
    /// one discriminator per task as in TokenHSI).
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
    pub follow: FollowConfig,
    pub sit: SitConfig,
    pub climb: ClimbConfig,
    pub carry: CarryConfig,
}

impl crate::config_table::TaskConfig for HsiConfig {
    const KEY: &'static str = "hsi";
    const DOC: &'static str = "Options of the TokenHSI tasks (`hsi_follow`, `hsi_sit`, \
        `hsi_climb`, `hsi_carry` and their compositions).";
}

impl Default for HsiConfig {
    fn default() -> Self {
        Self {
            object_variants: 16,
            object_seed: 0,
            termination_height: 0.15,
            head_termination_height: 0.3,
            power_coefficient: 0.0005,
            form: HsiForm::Released,
            state_init: StateInit::Auto,
            hybrid_init_prob: 0.5,
            random_heading: true,
            style_motion: Vec::new(),
            follow: Default::default(),
            sit: Default::default(),
            climb: Default::default(),
            carry: Default::default(),
        }
    }
}

/// How a TokenHSI episode starts (see [`HsiConfig::state_init`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StateInit {
    /// Reference frames when the task has clips, else the rest pose.
    #[default]
    Auto,
    /// The rest pose.
    Default,
    /// A reference frame (clips required).
    Reference,
    /// A reference frame with probability `hybrid_init_prob`, else the rest pose.
    Hybrid,
}

/// The form of TokenHSI's task rules (see [`HsiConfig::form`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum HsiForm {
    /// As the released code (liangpan99/TokenHSI) computes it.
    #[default]
    Released,
    /// As the supplementary's text states it, where it differs.
    Supplementary,
}

/// Path following (supplementary §B.2.1; the released `humanoid_traj.py` and its config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FollowConfig {
    /// Episode length L (policy steps; 300 = 10 s). As released, the time limit ends the episode
    /// after L − 1 steps and the trajectory spans L / 30 s.
    #[schemars(range(min = 2))]
    pub episode_length: usize,
    /// Vertices of the trajectory (101: 100 segments of 0.1 s over the 10 s episode).
    #[schemars(range(min = 2))]
    pub num_vertices: usize,
    /// Time between the observed waypoints (s): 0.5 as released (`trajSampleTimestep`); the
    /// supplementary's 0.1 with `env.hsi.form = "supplementary"`.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub point_dt: f64,
    /// Speed range of the trajectory (m/s).
    #[schemars(inner(range(min = 0)))]
    pub speed: [f64; 2],
    /// Largest speed change per segment (m/s per s).
    #[schemars(range(min = 0))]
    pub accel_max: f64,
    /// Largest heading change per segment (rad per s).
    #[schemars(range(min = 0))]
    pub turn_rate_max: f64,
    /// Probability per segment of a sharp turn: the segment's heading change is then drawn from
    /// U(−`sharp_turn_angle`, `sharp_turn_angle`) instead.
    #[schemars(range(min = 0, max = 1))]
    pub sharp_turn_prob: f64,
    /// Largest sharp turn (rad).
    #[schemars(range(min = 0, max = std::f64::consts::PI))]
    pub sharp_turn_angle: f64,
    /// Path-distance termination: the 2-D root distance to the current waypoint above this (m).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub fail_distance: f64,
    /// Success (the released evaluation): at some step ≥ `success_time` · L, the 2-D root within
    /// this distance (m) of the trajectory's point at `success_time` · L / 30 s.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Fraction of the episode at which success is judged (0.98, as released).
    #[schemars(range(min = 0, max = 1))]
    pub success_time: f64,
    /// Reference clips of this task's own discriminator (multi-task training keeps one per task,
    /// as TokenHSI); empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for FollowConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            num_vertices: 101,
            point_dt: 0.5,
            speed: [0.5, 1.5],
            accel_max: 2.0,
            turn_rate_max: 2.0,
            sharp_turn_prob: 0.02,
            sharp_turn_angle: 1.57,
            fail_distance: 4.0,
            success_distance: 0.3,
            success_time: 0.98,
            style_motion: Vec::new(),
        }
    }
}

/// Sitting (supplementary §B.2.2) on procedural box chairs and stools.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SitConfig {
    /// Episode length (policy steps; 300 = 10 s, Tab. A).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Seat height range (m, floor to seat top).
    #[schemars(inner(range(min = 0.05)))]
    pub seat_height: [f64; 2],
    /// Seat width and depth range (m).
    #[schemars(inner(range(min = 0.1)))]
    pub seat_size: [f64; 2],
    /// Probability that a variant has a backrest (a chair rather than a stool).
    #[schemars(range(min = 0, max = 1))]
    pub backrest_prob: f64,
    /// Distance range (m) of the object from the character at the start.
    #[schemars(inner(range(min = 0)))]
    pub distance: [f64; 2],
    /// Target height above the seat top (m; 0.1 in the paper).
    pub target_above_seat: f64,
    /// Success / interaction early termination: root within this distance (m) of the target.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Interaction early termination after this many consecutive steps within
    /// `success_distance` (0 = off).
    pub iet_steps: usize,
    /// Reference clips of this task's own discriminator (multi-task training keeps one per task,
    /// as TokenHSI); empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for SitConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            seat_height: [0.35, 0.55],
            seat_size: [0.4, 0.6],
            backrest_prob: 0.5,
            distance: [1.0, 5.0],
            target_above_seat: 0.1,
            success_distance: 0.2,
            iet_steps: 60,
            style_motion: Vec::new(),
        }
    }
}

/// Climbing onto a platform (supplementary §B.2.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ClimbConfig {
    /// Episode length (policy steps; 300 = 10 s, Tab. A).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Platform height range (m).
    #[schemars(inner(range(min = 0.02)))]
    pub height: [f64; 2],
    /// Platform width and depth range (m).
    #[schemars(inner(range(min = 0.1)))]
    pub size: [f64; 2],
    /// Distance range (m) of the platform from the character at the start.
    #[schemars(inner(range(min = 0)))]
    pub distance: [f64; 2],
    /// Target root height above the platform top (m; 0.94 in the paper).
    pub target_above_top: f64,
    /// Success / interaction early termination: root within this distance (m) of the target.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Interaction early termination after this many consecutive steps within
    /// `success_distance` (0 = off).
    pub iet_steps: usize,
    /// Reference clips of this task's own discriminator (multi-task training keeps one per task,
    /// as TokenHSI); empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for ClimbConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            height: [0.2, 0.6],
            size: [0.6, 1.2],
            distance: [1.0, 5.0],
            target_above_top: 0.94,
            success_distance: 0.2,
            iet_steps: 60,
            style_motion: Vec::new(),
        }
    }
}

/// Carrying a box between two supports (supplementary §B.2.4).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CarryConfig {
    /// Episode length (600 = 20 s).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Box side length range (m), each side drawn independently.
    #[schemars(inner(range(min = 0.05)))]
    pub box_size: [f64; 2],
    /// Box mass range (kg).
    #[schemars(inner(range(min = 0.01)))]
    pub box_mass: [f64; 2],
    /// Height range of the start and target support tops (m).
    #[schemars(inner(range(min = 0)))]
    pub support_height: [f64; 2],
    /// Distance range (m) of the start support from the character, and of the target support
    /// from the start support.
    #[schemars(inner(range(min = 0)))]
    pub distance: [f64; 2],
    /// Object-fall termination: the box centre below this height (m) (off when 0).
    #[schemars(range(min = 0))]
    pub fall_height: f64,
    /// Success: box centre within this distance (m) of its target.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Reference clips of this task's own discriminator (multi-task training keeps one per task,
    /// as TokenHSI); empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for CarryConfig {
    fn default() -> Self {
        Self {
            episode_length: 600,
            box_size: [0.25, 0.45],
            box_mass: [1.0, 8.0],
            support_height: [0.0, 0.8],
            distance: [1.0, 5.0],
            fall_height: 0.0,
            success_distance: 0.2,
            style_motion: Vec::new(),
        }
    }
}

/// A `[low, high]` pair in order (the bounds of each value are checked by
/// `EnvConfig::validate_driver`).
fn range(key: &str, r: [f64; 2]) -> Result<(), ConfigError> {
    if r[0] <= r[1] {
        Ok(())
    } else {
        Err(bad(key, format!("{r:?} must be a [low, high] range with low <= high")))
    }
}

impl HsiConfig {
    /// The reference clips of task `task`'s discriminator: its table's `style_motion`, else the
    /// shared `style_motion`; a composition (`hsi_sit_carry`, …) takes both tasks' clips together.
    pub fn style_motion_of(&self, task: &str) -> Vec<std::path::PathBuf> {
        let own: Vec<std::path::PathBuf> = match task {
            "hsi_follow" => self.follow.style_motion.clone(),
            "hsi_sit" => self.sit.style_motion.clone(),
            "hsi_climb" => self.climb.style_motion.clone(),
            "hsi_carry" => self.carry.style_motion.clone(),
            "hsi_follow_carry" => {
                self.follow.style_motion.iter().chain(&self.carry.style_motion).cloned().collect()
            }
            "hsi_sit_carry" => {
                self.sit.style_motion.iter().chain(&self.carry.style_motion).cloned().collect()
            }
            "hsi_climb_carry" => {
                self.climb.style_motion.iter().chain(&self.carry.style_motion).cloned().collect()
            }
            _ => Vec::new(),
        };
        if own.is_empty() { self.style_motion.clone() } else { own }
    }

    /// Check the values: each range in order (each key's own range is checked by
    /// `EnvConfig::validate_driver`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (key, r) in [
            ("env.hsi.follow.speed", self.follow.speed),
            ("env.hsi.sit.seat_height", self.sit.seat_height),
            ("env.hsi.sit.seat_size", self.sit.seat_size),
            ("env.hsi.sit.distance", self.sit.distance),
            ("env.hsi.climb.height", self.climb.height),
            ("env.hsi.climb.size", self.climb.size),
            ("env.hsi.climb.distance", self.climb.distance),
            ("env.hsi.carry.box_size", self.carry.box_size),
            ("env.hsi.carry.box_mass", self.carry.box_mass),
            ("env.hsi.carry.support_height", self.carry.support_height),
            ("env.hsi.carry.distance", self.carry.distance),
        ] {
            range(key, r)?;
        }
        Ok(())
    }
}
