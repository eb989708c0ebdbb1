//! `stand`: keep the pelvis at a target height and the heading the episode started with — no
//! clip, no ball, on any character. The worked example of adding a task (the guide's tutorial
//! docs/tutorials/add-a-task.md shows the parts between the `ANCHOR` comments): this module plus
//! one line in [`crate::registry::TASKS`] and one config table,
//! `[env.stand]` ([`StandConfig`], defined here and listed in the registry line).
//!
//! * Start: the character's rest pose (every joint at 0, upright root) at `start_height` (0 = the
//!   character's rest height: SkillMimic humanoid 0.95 m, TokenHSI character 0.92 m, SMPL
//!   humanoid 0.937 m), turned to a uniformly random heading ψ₀ ∈ [−π, π); zero velocities. On
//!   the SkillMimic humanoid the ball rests out of the way at (5, 5) m and plays no part.
//! * Observation: the character's proprioception ([`crate::proprio`]; 823, 222 or 358 wide) |
//!   z − z* (m) | cos Δψ | sin Δψ, with Δψ = ψ₀ − ψ the heading still to turn (rad, wrapped to
//!   (−π, π]).
//! * Reward: r = w_h·exp(−k_h (z − z*)²) + (1 − w_h)·exp(−k_ψ Δψ²) ∈ [0, 1]; terms
//!   `height`, `heading`, `total`.
//! * Done: terminated when the pelvis falls below `termination_height` or the simulation is
//!   unstable; truncated after `episode_length` steps.
//! * Metrics: `height_err` |z − z*| (m), `heading_err` |Δψ| (rad).

use std::sync::Arc;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::CharacterSpec;
use skillmimic_core::math::{Quat, heading, wrap_angle};
use skillmimic_sim::{EnvState, ResetState, Scene};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::config::EnvConfig;
use crate::config_table::TableEntry;
use crate::error::{EnvError, bad};
use crate::task::{ActionSpace, StepOut, Task, TaskSpec};
use crate::vec_env::{Env, VecEnv};

// ANCHOR: config
/// Options of the `stand` task (`[env.stand]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct StandConfig {
    /// Episode length in policy steps (60 = 1 s).
    #[schemars(range(min = 1))]
    pub episode_length: usize,
    /// Pelvis height at the start (m); 0 = the character's rest height, where the zero pose's
    /// feet touch the floor (SkillMimic humanoid 0.95, TokenHSI character 0.92, SMPL humanoid
    /// 0.937).
    pub start_height: f64,
    /// Target pelvis height z* (m).
    pub target_height: f64,
    /// Early termination below this pelvis height (m).
    pub termination_height: f64,
    /// Weight w_h of the height term (the heading term gets 1 − w_h).
    #[schemars(range(min = 0, max = 1))]
    pub height_weight: f64,
    /// Height error scale k_h (1/m²).
    #[schemars(range(min = 0))]
    pub height_scale: f64,
    /// Heading error scale k_ψ (1/rad²).
    #[schemars(range(min = 0))]
    pub heading_scale: f64,
}

impl crate::config_table::TaskConfig for StandConfig {
    const KEY: &'static str = "stand";
    const DOC: &'static str = "Options of the `stand` task (the worked example of adding a task).";
}

impl Default for StandConfig {
    fn default() -> Self {
        Self {
            episode_length: 300,
            start_height: 0.0,
            target_height: 0.9,
            termination_height: 0.5,
            height_weight: 0.5,
            height_scale: 20.0,
            heading_scale: 2.0,
        }
    }
}

/// The `[env.stand]` table.
pub const TABLE: TableEntry = TableEntry::of::<StandConfig>();
// ANCHOR_END: config

/// The observation: the character's proprioception, then the stand part (3).
pub const LAYOUT: crate::obs_blocks::ObsLayout =
    crate::obs_blocks::ObsLayout::Proprio { part: "stand" };

/// Per-environment state: steps taken and the heading to keep (rad).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct StandSlot {
    pub steps: usize,
    pub target_heading: f64,
}

/// The `stand` task.
pub struct Stand {
    cfg: StandConfig,
    spec: TaskSpec,
    character: CharacterSpec,
}

impl Stand {
    /// The task with options `cfg` on `character`.
    pub fn new(cfg: StandConfig, character: CharacterSpec) -> Self {
        let p = character.proprio_dim();
        let obs_blocks = LAYOUT.blocks(&character, p + 3);
        let spec = TaskSpec {
            name: "stand",
            obs_dim: p + 3,
            action_space: ActionSpace::Box { dim: character.num_dofs },
            max_episode_steps: cfg.episode_length,
            term_names: crate::task::names(&["height", "heading", "total"]),
            metric_names: crate::task::names(&["height_err", "heading_err"]),
            obs_blocks,
            ..TaskSpec::default()
        };
        Self { cfg, spec, character }
    }

    /// (z − z*, Δψ) of a state.
    fn errors(&self, slot: &StandSlot, st: &EnvState<'_>) -> (f64, f64) {
        (
            st.pos(0)[2] - self.cfg.target_height,
            wrap_angle(slot.target_heading - heading(st.quat(0))),
        )
    }

    fn write_obs(&self, slot: &StandSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        let p = self.character.proprio_dim();
        crate::proprio::write_for(&self.character, st, &mut obs[..p]);
        let (dz, dpsi) = self.errors(slot, st);
        obs[p..].copy_from_slice(&[dz as f32, dpsi.cos() as f32, dpsi.sin() as f32]);
    }
}

// ANCHOR: task
impl Task for Stand {
    type Slot = StandSlot;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn new_slot(&self) -> StandSlot {
        StandSlot::default()
    }

    fn plan_reset(
        &mut self,
        _i: usize,
        slot: &mut StandSlot,
        rng: &mut ChaCha8Rng,
        scene: &Scene,
        state: &mut ResetState,
    ) {
        let psi = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        // the rest orientation (the SkillMimic skeleton's Y-up → Z-up turn), then the heading
        let root_quat = Quat::about_z(psi).mul(self.character.root_quat);
        let z = if self.cfg.start_height > 0.0 {
            self.cfg.start_height
        } else {
            self.character.root_pos[2]
        };
        state.clear([0.0, 0.0, z], root_quat);
        if let Some(ball) = scene.ball() {
            let k = ball - scene.num_character_bodies();
            state.objects[k].pos = [5.0, 5.0, 0.12];
        }
        *slot = StandSlot { steps: 0, target_heading: heading(root_quat) };
    }

    fn after_reset(&self, _i: usize, slot: &mut StandSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        self.write_obs(slot, st, obs);
    }

    fn step_env(&self, _i: usize, slot: &mut StandSlot, st: &EnvState<'_>, out: StepOut<'_>) {
        slot.steps += 1;
        let c = &self.cfg;
        let (dz, dpsi) = self.errors(slot, st);
        let (rh, rpsi) =
            ((-c.height_scale * dz * dz).exp(), (-c.heading_scale * dpsi * dpsi).exp());
        let total = c.height_weight * rh + (1.0 - c.height_weight) * rpsi;
        out.terms.copy_from_slice(&[rh as f32, rpsi as f32, total as f32]);
        *out.reward = total as f32;
        out.metrics.copy_from_slice(&[dz.abs() as f32, dpsi.abs() as f32]);
        self.write_obs(slot, st, out.obs);
        let fell = st.pos(0)[2] < c.termination_height;
        *out.terminated = u8::from(fell || st.unstable);
        *out.truncated = u8::from(*out.terminated == 0 && slot.steps >= c.episode_length);
    }

    fn observe(&self, slot: &mut StandSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        self.write_obs(slot, st, obs);
    }
}
// ANCHOR_END: task

// ANCHOR: build
/// Registry constructor: the `stand` task from `[env]` (driver keys, the character) and
/// `[env.stand]`.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    let s = cfg.table::<StandConfig>();
    if s.episode_length == 0 {
        return Err(bad("env.stand.episode_length", "must be at least 1").into());
    }
    if !(0.0..=1.0).contains(&s.height_weight) {
        return Err(bad(
            "env.stand.height_weight",
            format!("{} is outside [0, 1]", s.height_weight),
        )
        .into());
    }
    let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
    let task = Stand::new(s.clone(), scene.character().clone());
    Ok(Box::new(VecEnv::with_task(task, scene, cfg.num_envs, cfg.threads, cfg.start_seed(0))?))
}
// ANCHOR_END: build
