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
    /// code differ: `released` (default) or `supplementary`: the follow observation's waypoints
    /// 0.1 s apart instead of 0.5 s; sit and carry observations in the text's order (target
    /// first, the object's position as its frame origin); the sit/climb/carry rewards of
    /// Eqs. 2–15 (climb's fixed 0.7 m gate, no sign masks, no speed, turning or box-speed
    /// penalties, no "box still low" mask, a continuous put-down term). Where the text is silent
    /// (fall rules, interaction early termination, success, corner order) both forms are the
    /// released code's.
    pub form: HsiForm,
    /// Start heading of the character: uniformly random (else facing +x).
    pub random_heading: bool,
    /// What the motion prior's discriminator (`ppo.amp`) reads per frame: `released` (default:
    /// the released TokenHSI discriminator's 129 features — heading-local root rotation and
    /// velocities, joint rotations, dof rates, hands and feet; `style::released_features`) or
    /// `proprioception` (the 222-d policy proprioception).
    pub style_features: StyleFeatures,
    /// The motion prior of a multi-task run (`hsi_multi` with several tasks): `conditional`
    /// (default, as released: one discriminator whose input is the window followed by the task
    /// one-hot; reference windows drawn per task by its share of the environments) or `per_task`
    /// (one discriminator per task).
    pub discriminator: Discriminators,
    /// Reference clips of the character (`tokenhsi-clip` files or folders, e.g. written by
    /// `skillmimic retarget`) for the adversarial motion prior of the run's task (`ppo.amp`) and
    /// its reference starts; the entry "builtin:walks" stands for the built-in procedural walks
    /// (docs/tokenhsi.md, "Built-in walks"); a task's own `style_motion` takes precedence.
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
            style_features: StyleFeatures::Released,
            discriminator: Discriminators::Conditional,
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

/// The discriminator's per-frame features (see [`HsiConfig::style_features`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StyleFeatures {
    /// The released TokenHSI discriminator's 129 features.
    #[default]
    Released,
    /// The 222-d proprioception of the policy observation.
    Proprioception,
}

/// The discriminators of a multi-task run (see [`HsiConfig::discriminator`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Discriminators {
    /// One discriminator conditioned on the task one-hot.
    #[default]
    Conditional,
    /// One discriminator per task.
    PerTask,
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
    /// Reference clips of this task (its discriminator's, or — multi-task, conditional — its
    /// one-hot's reference windows); empty = `env.hsi.style_motion`.
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
    /// Success / interaction early termination: root within this distance (m, ≤) of the target.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Interaction early termination (the released rule): the episode is truncated once the steps
    /// with the root within `success_distance` of the target — counted over the whole episode,
    /// not necessarily consecutive — reach `iet_steps` − 1 (60 → 59, the released
    /// `maxIETSteps`; 0 = off).
    pub iet_steps: usize,
    /// Speed penalty within `penalty_radius` of the object (released form):
    /// `−coefficient (1 − exp(−2 (threshold − max(|v|, threshold))²))`, |v| the root's 3-D
    /// speed (m/s); 0 switches it off.
    #[schemars(range(min = 0))]
    pub speed_penalty_coefficient: f64,
    /// Speed above which the penalty starts (m/s).
    #[schemars(range(min = 0))]
    pub speed_penalty_threshold: f64,
    /// Turning penalty within `penalty_radius` (released form):
    /// `−coefficient (1 − exp(−0.5 (threshold − max(ω, threshold))²))`, ω the change of the root's
    /// yaw in [0, 2π) over one step divided by 1/30 s (rad/s; as released, the yaw is not
    /// unwrapped, so crossing 0 reads as a fast turn); 0 switches it off.
    #[schemars(range(min = 0))]
    pub turn_penalty_coefficient: f64,
    /// Turning rate above which the penalty starts (rad/s).
    #[schemars(range(min = 0))]
    pub turn_penalty_threshold: f64,
    /// The penalties apply within this 2-D root–object distance (m).
    #[schemars(range(min = 0))]
    pub penalty_radius: f64,
    /// Reference clips of this task (its discriminator's, or — multi-task, conditional — its
    /// one-hot's reference windows, and its reference starts); "builtin:sit" stands for the
    /// built-in stand-to-sit clips, whose starts are placed against the seat; empty =
    /// `env.hsi.style_motion`.
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
            speed_penalty_coefficient: 0.5,
            speed_penalty_threshold: 1.3,
            turn_penalty_coefficient: 0.5,
            turn_penalty_threshold: 3.0,
            penalty_radius: 1.5,
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
    /// Success / interaction early termination: root within this distance (m, ≤) of the target.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Interaction early termination: as `env.hsi.sit.iet_steps` (cumulative count, truncation
    /// at `iet_steps` − 1; 0 = off).
    pub iet_steps: usize,
    /// The close gate (released form): root within half the diagonal of the object's footprint
    /// plus this margin (m) of the object's centre (2-D).
    #[schemars(range(min = 0))]
    pub gate_margin: f64,
    /// Speed penalty (released form) within `penalty_radius` of the object:
    /// `−coefficient (1 − exp(−2 (thr − max(|v|, thr))²))`, |v| the root's 3-D speed (m/s), thr
    /// `speed_penalty_threshold` inside the gate, else `speed_penalty_threshold_approach`; 0
    /// switches it off.
    #[schemars(range(min = 0))]
    pub speed_penalty_coefficient: f64,
    /// Speed threshold inside the close gate (m/s).
    #[schemars(range(min = 0))]
    pub speed_penalty_threshold: f64,
    /// Speed threshold between the gate and `penalty_radius` (m/s).
    #[schemars(range(min = 0))]
    pub speed_penalty_threshold_approach: f64,
    /// The penalty applies within this 2-D root–object distance (m).
    #[schemars(range(min = 0))]
    pub penalty_radius: f64,
    /// Reference clips of this task (its discriminator's, or — multi-task, conditional — its
    /// one-hot's reference windows, and its reference starts); "builtin:climb" stands for the
    /// built-in step-ups, whose starts are placed against the platform's face that looks towards
    /// the character; empty = `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for ClimbConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            height: [0.2, 0.6],
            size: [0.6, 1.2],
            distance: [1.0, 10.0],
            target_above_top: 0.94,
            success_distance: 0.2,
            iet_steps: 60,
            gate_margin: 0.3,
            speed_penalty_coefficient: 1.0,
            speed_penalty_threshold: 1.3,
            speed_penalty_threshold_approach: 1.5,
            penalty_radius: 1.5,
            style_motion: Vec::new(),
        }
    }
}

/// Carrying a box (supplementary §B.2.4; the released `humanoid_carry.py` and its config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CarryConfig {
    /// Episode length (600 = 20 s).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Box side length range (m): 0.2–0.6, the released base size 0.4 scaled by 0.5–1.5.
    #[schemars(inner(range(min = 0.05)))]
    pub box_size: [f64; 2],
    /// Step of the side lengths (m): sizes low, low + step, …, high (0.05 → 9 sizes, as
    /// released); 0 draws them continuously.
    #[schemars(range(min = 0))]
    pub box_size_step: f64,
    /// Cubes (one drawn side for all three, as released); else each side drawn independently.
    pub cube: bool,
    /// Box density (kg/m³; 100 as released: 0.8 kg for a 0.2 m cube, 21.6 kg for 0.6 m).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub box_density: f64,
    /// Distance range (m) of the box from the character at the start.
    #[schemars(inner(range(min = 0)))]
    pub distance: [f64; 2],
    /// The target's horizontal position is uniform in [−a, a]² around the character's start
    /// (m; 4.5 as released: the environment spacing 5 minus 0.5).
    #[schemars(range(min = 0))]
    pub target_area: f64,
    /// The target is redrawn while it is closer than this (m, 2-D) to the character or the box.
    #[schemars(range(min = 0))]
    pub keep_clear: f64,
    /// Probability that the box's start, and independently its target, is raised off the floor.
    #[schemars(range(min = 0, max = 1))]
    pub raise_prob: f64,
    /// A raised box's centre goes up by U(0, this) (m) …
    #[schemars(range(min = 0))]
    pub raise_height: f64,
    /// … with its top at most this high (m).
    #[schemars(range(min = 0))]
    pub max_top: f64,
    /// Side lengths (m, x and y) of the 0.02 m thick platforms under the start and the target.
    #[schemars(inner(range(min = 0.01)))]
    pub platform_size: [f64; 2],
    /// The box starts this far (m) above its platform and drops onto it.
    #[schemars(range(min = 0))]
    pub drop_height: f64,
    /// Box-speed penalty (released form), every step:
    /// `−coefficient (1 − exp(−2 (thr − max(|v_box|, thr))²))`, |v_box| the box's 3-D speed (m/s);
    /// 0 switches it off.
    #[schemars(range(min = 0))]
    pub box_speed_penalty_coefficient: f64,
    /// Box speed above which the penalty starts (m/s).
    #[schemars(range(min = 0))]
    pub box_speed_penalty_threshold: f64,
    /// "Box still low" (released form): the term for moving the box towards its target is 0 while
    /// the box's centre is at most this much (m) above half its height, unless the box is within
    /// 0.5 m of the target — no reward for kicking or pushing it along the floor.
    #[schemars(range(min = 0))]
    pub low_margin: f64,
    /// Height range of the support tops of the compositions (`hsi_*_carry`; m).
    #[schemars(inner(range(min = 0)))]
    pub support_height: [f64; 2],
    /// Object-fall termination: the box centre below this height (m) (off when 0; the released
    /// carry task has none).
    #[schemars(range(min = 0))]
    pub fall_height: f64,
    /// Success: box centre within this distance (m, ≤) of its target at some step.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub success_distance: f64,
    /// Reference clips of this task (its discriminator's, or — multi-task, conditional — its
    /// one-hot's reference windows, and its reference starts); "builtin:carry" stands for the
    /// built-in carrying walks, whose starts put a box of a clip's size into the hands; empty =
    /// `env.hsi.style_motion`.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub style_motion: Vec<std::path::PathBuf>,
}

impl Default for CarryConfig {
    fn default() -> Self {
        Self {
            episode_length: 600,
            box_size: [0.2, 0.6],
            box_size_step: 0.05,
            cube: true,
            box_density: 100.0,
            distance: [1.0, 10.0],
            target_area: 4.5,
            keep_clear: 1.0,
            raise_prob: 0.5,
            raise_height: 1.0,
            max_top: 1.2,
            platform_size: [0.4, 0.4],
            drop_height: 0.05,
            box_speed_penalty_coefficient: 1.0,
            box_speed_penalty_threshold: 2.5,
            low_margin: 0.2,
            support_height: [0.0, 0.8],
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
            ("env.hsi.carry.support_height", self.carry.support_height),
            ("env.hsi.carry.distance", self.carry.distance),
        ] {
            range(key, r)?;
        }
        Ok(())
    }
}
