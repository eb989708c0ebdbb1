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
    /// Character-fall termination: a body other than the feet that touches the floor or an
    /// object below this height (m) ends the episode (ASE's rule).
    #[schemars(range(min = 0))]
    pub termination_height: f64,
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
            random_heading: true,
            style_motion: Vec::new(),
            follow: Default::default(),
            sit: Default::default(),
            climb: Default::default(),
            carry: Default::default(),
        }
    }
}

/// Path following (supplementary §B.2.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FollowConfig {
    /// Episode length (policy steps; 300 = 10 s).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Time between trajectory vertices (s): 0.1 in the supplementary, 0.5 in the released code.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub vertex_dt: f64,
    /// Speed range of the trajectory (m/s).
    #[schemars(inner(range(min = 0)))]
    pub speed: [f64; 2],
    /// Largest speed change per vertex (m/s per s).
    #[schemars(range(min = 0))]
    pub accel_max: f64,
    /// Largest heading change per vertex (rad per s).
    #[schemars(range(min = 0))]
    pub turn_rate_max: f64,
    /// Probability per vertex of a sharp turn (a heading jump of up to ±π).
    #[schemars(range(min = 0, max = 1))]
    pub sharp_turn_prob: f64,
    /// Path-distance termination: the 2-D root distance to the current waypoint above this (m).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub fail_distance: f64,
    /// Success: within this distance (m) of the current waypoint for at least `success_fraction`
    /// of the episode.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Fraction of the episode's steps within `success_distance` for success (0.98, the
    /// released code's rule).
    #[schemars(range(min = 0, max = 1))]
    pub success_fraction: f64,
    /// Reference clips of this task's own discriminator (multi-task training keeps one per task,
    /// as TokenHSI); empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for FollowConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            vertex_dt: 0.1,
            speed: [0.0, 3.0],
            accel_max: 2.0,
            turn_rate_max: 2.0,
            sharp_turn_prob: 0.02,
            fail_distance: 4.0,
            success_distance: 0.4,
            success_fraction: 0.98,
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
