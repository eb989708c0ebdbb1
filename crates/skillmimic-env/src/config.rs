//! Typed environment configuration with the paper's defaults (SkillMimic, seed 000 §5–6).
//!
//! Every field can be set from the `[env]` table of a TOML file; unknown keys are errors.

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use skillmimic_sim::{BallParams, HandModel, SceneOptions};

pub use crate::config_table::{TableEntry, TaskConfig, TaskTables};
pub use crate::config_v2::{
    AtsConfig, BridgeConfig, HistoryConfig, MaskedReward, NoiseEps, StfConfig, StgConfig, V2Config,
};
pub use crate::error::ConfigError;
use crate::error::bad;

/// How the reward combines its terms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
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
    /// (seed 003 Tab. 9: p 40, r 2, rv 0.1, op 40) combined additively with equal weights, no
    /// contact term: their mean (`env.compat = "paper"`) or their sum (`"code"`).
    Deepmimic,
}

/// How simulated contact-graph states are measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ContactGraphMode {
    /// Exact MuJoCo contact pairs: edges hand–ball (target: the clip label), body–ball,
    /// hand–body and body–floor (targets 0). Body = every humanoid body that is not a hand;
    /// for body–floor, feet are excluded. Our option (the papers' edges, measurable in MuJoCo).
    Exact,
    /// The papers' graph as the released code measures it (the default): body node = any
    /// |component| ≥ threshold (N) of the net contact force (world frame, every source: floor,
    /// ball and self-contact) on one of the 17 reference body-node bodies (target 0); ball node =
    /// |F_x| or |F_y| of the ball's net contact force > threshold, from any source including
    /// floor bounces (target: the clip's hand–ball label).
    #[default]
    ForceThreshold,
}

/// Weights of the DeepMimic-style baseline (seed 003 Tab. 9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DeepMimicWeights {
    /// Body position.
    #[schemars(range(min = 0))]
    pub w_p: f64,
    /// Body rotation.
    #[schemars(range(min = 0))]
    pub w_r: f64,
    /// Joint velocity.
    #[schemars(range(min = 0))]
    pub w_rv: f64,
    /// Ball position.
    #[schemars(range(min = 0))]
    pub w_op: f64,
}

impl Default for DeepMimicWeights {
    fn default() -> Self {
        Self { w_p: 40.0, w_r: 2.0, w_rv: 0.1, w_op: 40.0 }
    }
}

/// Reward weights (exponent scales) and variant. Defaults: SkillMimic yaml.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    /// How the reward combines its terms.
    pub variant: RewardVariant,
    /// Body position: root + 17 key bodies.
    #[schemars(range(min = 0))]
    pub w_p: f64,
    /// Body rotation: root exp map + 156 joint exp-map components.
    #[schemars(range(min = 0))]
    pub w_r: f64,
    /// Key-body linear velocity.
    #[schemars(range(min = 0))]
    pub w_pv: f64,
    /// Joint velocity.
    #[schemars(range(min = 0))]
    pub w_rv: f64,
    /// Velocity regulariser exponent weight.
    #[schemars(range(min = 0))]
    pub w_reg: f64,
    /// Scale of the reference velocity in the regulariser denominator 1 + scale·v̂².
    #[schemars(range(min = 0))]
    pub reg_scale: f64,
    /// Ball position.
    #[schemars(range(min = 0))]
    pub w_op: f64,
    /// Ball rotation (squared rotation angle).
    #[schemars(range(min = 0))]
    pub w_or: f64,
    /// Ball linear velocity.
    #[schemars(range(min = 0))]
    pub w_opv: f64,
    /// Ball angular velocity.
    #[schemars(range(min = 0))]
    pub w_orv: f64,
    /// Relative (interaction-graph) term: root and key bodies minus the ball.
    #[schemars(range(min = 0))]
    pub w_ig: f64,
    /// How contact-graph states are measured.
    pub contact_graph: ContactGraphMode,
    /// Exact mode edge weight: hand–ball.
    #[schemars(range(min = 0))]
    pub w_cg_hand_ball: f64,
    /// Exact mode edge weight: body–ball.
    #[schemars(range(min = 0))]
    pub w_cg_body_ball: f64,
    /// Exact mode edge weight: hand–body.
    #[schemars(range(min = 0))]
    pub w_cg_hand_body: f64,
    /// Exact mode edge weight: body–floor.
    #[schemars(range(min = 0))]
    pub w_cg_body_floor: f64,
    /// Force-threshold mode node weight: body node (cg1).
    #[schemars(range(min = 0))]
    pub w_cg1_body: f64,
    /// Force-threshold mode node weight: ball node (cg2).
    #[schemars(range(min = 0))]
    pub w_cg2_ball: f64,
    /// Force threshold (N) of the force-threshold mode.
    #[schemars(range(min = 0))]
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
            contact_graph: ContactGraphMode::ForceThreshold,
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

/// How the ball's contacts with the humanoid behave.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BallBodyContact {
    /// PhysX's combined restitution of the reference's materials: (ball 0.81 + body 0)/2 = 0.405.
    #[default]
    Combined,
    /// MuJoCo's default soft, non-bouncy contact.
    Soft,
}

/// The ball's physical properties: scale factors (robustness tests, seed 000 Tab. 2) and the
/// reference's PhysX behaviours (damping, bounce threshold, combined restitution; see
/// `skillmimic_sim::mjcf` for how each is modelled in MuJoCo).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BallOverrides {
    /// Factor on the ball radius.
    #[schemars(range(max = 100), extend("exclusiveMinimum" = 0))]
    pub radius_scale: f64,
    /// Factor on the ball density.
    #[schemars(range(max = 100), extend("exclusiveMinimum" = 0))]
    pub density_scale: f64,
    /// Factor on the ball restitution (the result must stay ≤ 1).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub restitution_scale: f64,
    /// Linear and angular velocity damping (1/s): dv/dt = −damping·v (PhysX's 0.01).
    #[schemars(range(min = 0, max = 100))]
    pub damping: f64,
    /// Floor impacts slower than this normal speed (m/s) do not bounce (PhysX's 0.2); 0 = off.
    #[schemars(range(min = 0, max = 10))]
    pub bounce_threshold: f64,
    /// Ball–humanoid contact model.
    pub body_contact: BallBodyContact,
}

impl Default for BallOverrides {
    fn default() -> Self {
        Self {
            radius_scale: 1.0,
            density_scale: 1.0,
            restitution_scale: 1.0,
            damping: 0.01,
            bounce_threshold: 0.2,
            body_contact: BallBodyContact::Combined,
        }
    }
}

/// Where episodes start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StateInit {
    /// Random clip (class-balanced) and random start frame 2 … T−2 (training).
    #[default]
    Random,
    /// Random clip, fixed start frame (clamped to T−2) — evaluation.
    Frame(usize),
}

/// Motion source name of the built-in demo clips (the clips of `motions/`, synthesised in memory;
/// loaded by `tasks::imitation::load_motion_library`); the default of `env.motion`.
pub const BUILTIN_DEMO: &str = "builtin:demo";

/// Environment configuration: the driver's keys, the keys of the imitation task (the default
/// task, whose options stay in `[env]` itself) and one table per registered task or family of
/// tasks (`[env.<key>]`, defined next to the task's code). Unknown keys are refused.
// (the refusal is `TaskTables`'s deserialiser, which receives every key that is not a field)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default)]
pub struct EnvConfig {
    /// The task to train (a name of the task registry: "imitation", "stand"). `[env]` holds the
    /// driver's keys and, for historical reasons, the imitation task's; every other task has its
    /// own `[env.<task>]` table.
    pub task: String,
    /// Clip files or folders (searched recursively for `.pt` and `.safetensors`); the entry
    /// "builtin:demo" (the default) stands for the built-in demo clips (the same clips as the
    /// repository's `motions/`), so the default works from any working directory.
    #[schemars(extend("items" = {"type": "string", "format": "path"}))]
    pub motion: Vec<PathBuf>,
    /// Number of parallel environments.
    #[schemars(range(min = 1))]
    pub num_envs: usize,
    /// Simulation threads (0 = one per core; a count above four per core is capped to that).
    #[schemars(range(max = crate::config_range::MAX_THREADS))]
    pub threads: usize,
    /// The character the task drives: "skillmimic" (the SkillMimic humanoid), "tokenhsi" (the
    /// TokenHSI character) or "smpl" (the SMPL humanoid); empty = the task's default (its first
    /// supported character). A task refuses a character it does not run on, naming the ones it
    /// does.
    pub character: String,
    /// Hand model of the SkillMimic humanoid: "full" (156 dofs) or "box" (fingers welded).
    pub hands: String,
    /// Maximum episode length in policy steps (reference frames), 60 = 1 s.
    #[schemars(range(min = 2))]
    pub episode_length: usize,
    /// Early termination when the root is below this height (m) after the first step.
    pub termination_height: f64,
    /// Reference-state initialisation.
    pub state_init: StateInit,
    /// Evaluation horizon: when > 0 every episode lasts exactly this many steps (truncation) and
    /// reference frames past the clip end hold the last frame (SkillMimic-V2 success rates are
    /// measured over 10 s = 600 steps). 0 = training behaviour (episodes end with the clip).
    pub fixed_horizon: usize,
    /// Paper or released-code behaviour where the two differ (`compat` module docs and
    /// docs/fidelity.md list every behaviour this switch changes).
    pub compat: crate::compat::Compat,
    /// Seed of the stream of episode starts (clip/frame sampling, V2 start variants). Unset
    /// (the default) = derived: training uses `run.seed`, a standalone environment 0 (see
    /// [`EnvConfig::start_seed`]). Set it to decouple episode starts from the run seed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Reward weights (exponent scales) and variant.
    pub reward: RewardConfig,
    /// Scale factors of the ball's physical properties (robustness tests, seed 000 Tab. 2).
    pub ball: BallOverrides,
    /// Constraint-solver settings (MuJoCo's defaults; the others are speed options).
    pub physics: crate::config_physics::PhysicsConfig,
    /// SkillMimic-V2 options (all off by default = SkillMimic).
    pub v2: V2Config,
    /// The tables of the registered tasks, `[env.<key>]` each: every task (or family of tasks)
    /// owns its table next to its code (`crate::config_table`); the configuration reference
    /// lists their keys under their own headings.
    #[serde(flatten)]
    pub tables: TaskTables,
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            motion: vec![PathBuf::from(BUILTIN_DEMO)],
            num_envs: 64,
            threads: 0,
            character: String::new(),
            hands: "full".into(),
            episode_length: 60,
            termination_height: 0.3,
            state_init: StateInit::Random,
            fixed_horizon: 0,
            compat: Default::default(),
            seed: None,
            reward: RewardConfig::default(),
            ball: BallOverrides::default(),
            physics: Default::default(),
            v2: V2Config::default(),
            task: "imitation".into(),
            tables: TaskTables::default(),
        }
    }
}

impl EnvConfig {
    /// The registered table of type `T` (`[env.<T::KEY>]`).
    pub fn table<T: TaskConfig>(&self) -> &T {
        self.tables.get::<T>()
    }
    /// The registered table of type `T`, mutably.
    pub fn table_mut<T: TaskConfig>(&mut self) -> &mut T {
        self.tables.get_mut::<T>()
    }

    /// The seed of episode starts: `seed` when set, else `derived` (the run seed in training).
    pub fn start_seed(&self, derived: u64) -> u64 {
        self.seed.unwrap_or(derived)
    }

    /// The hand model named by `hands`.
    pub fn hand_model(&self) -> Result<HandModel, ConfigError> {
        match self.hands.as_str() {
            "full" => Ok(HandModel::Full),
            "box" | "boxhand" => Ok(HandModel::Box),
            other => Err(bad(
                "env.hands",
                format!("'{other}' is not a hand model, expected \"full\" or \"box\""),
            )),
        }
    }

    /// The character named by `character` (empty: the SkillMimic humanoid). Crate-private on
    /// purpose: an empty `character` means "the task's default", which only the registry knows
    /// (`config` cannot import it: the registry imports `config`). Task constructors see the
    /// field filled in by `registry::make`; every caller outside this crate asks
    /// `registry::character` / `registry::scene_options`, so no caller can take the SkillMimic
    /// humanoid for a TokenHSI or SMPL task whose saved configuration leaves the field empty.
    pub(crate) fn resolved_character(&self) -> Result<skillmimic_sim::Character, ConfigError> {
        let name = if self.character.is_empty() { "skillmimic" } else { self.character.as_str() };
        skillmimic_sim::Character::by_name(name, self.hand_model()?).ok_or_else(|| {
            bad(
                "env.character",
                format!(
                    "'{name}' is not a character; registered: {}",
                    skillmimic_sim::Character::NAMES.join(", ")
                ),
            )
        })
    }

    /// The scene of the configured character: the SkillMimic humanoid with the ball (after the
    /// ball overrides), any other character bare. Crate-private like [`Self::resolved_character`]:
    /// outside this crate `registry::scene_options` resolves the task's character first.
    pub(crate) fn scene_options(&self) -> Result<SceneOptions, ConfigError> {
        self.scene_options_on(self.resolved_character()?)
    }

    /// The scene of `character` (already resolved by the caller) with this configuration's ball
    /// and solver: what [`Self::scene_options`] builds for the configured character.
    pub(crate) fn scene_options_on(
        &self,
        character: skillmimic_sim::Character,
    ) -> Result<SceneOptions, ConfigError> {
        if !character.plays_ballplay() {
            return Ok(SceneOptions {
                solver: self.physics.solver_options(),
                ..SceneOptions::bare(character)
            });
        }
        let base = BallParams::default();
        let b = &self.ball;
        let ball = BallParams {
            radius: base.radius * b.radius_scale,
            density: base.density * b.density_scale,
            restitution: base.restitution * b.restitution_scale,
            friction: base.friction,
            damping: b.damping,
            bounce_threshold: b.bounce_threshold,
            body_contact: match b.body_contact {
                BallBodyContact::Combined => skillmimic_sim::BodyContact::Combined,
                BallBodyContact::Soft => skillmimic_sim::BodyContact::Soft,
            },
        };
        Ok(SceneOptions {
            character,
            ball: Some(ball),
            solver: self.physics.solver_options(),
            ..Default::default()
        })
    }

    /// Check the driver's keys (every task): the documented range of every number of `[env]`
    /// and its sub-tables ([`crate::config_range::check_ranges`]) and the hand model (the task
    /// name is checked by `registry::make`).
    pub fn validate_driver(&self) -> Result<(), ConfigError> {
        crate::config_range::check_ranges(self, "env")?;
        self.hand_model()?;
        Ok(())
    }

    /// Check value ranges of the driver and the imitation task (called by its constructor).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_driver()?;
        if let StateInit::Frame(f) = self.state_init
            && f < 2
        {
            return Err(bad(
                "env.state_init",
                format!("start frame {f} is below 2 (frames 0 and 1 have no velocity)"),
            ));
        }
        if self.motion.is_empty() {
            return Err(bad("env.motion", "no clip file or folder given"));
        }
        let b = &self.ball;
        if !(b.restitution_scale * BallParams::default().restitution <= 1.0) {
            return Err(bad("env.ball.restitution_scale", "restitution would exceed 1"));
        }
        self.v2.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_overrides_and_rejects_unknown_keys() {
        let c: EnvConfig = toml::from_str(
            "num_envs = 8\nstate_init = { frame = 5 }\n[reward]\nvariant = \"additive\"\nw_p = \
                10.0\n[ball]\nradius_scale = 1.2\n",
        )
        .unwrap();
        assert_eq!(c.num_envs, 8);
        assert_eq!(c.state_init, StateInit::Frame(5));
        assert_eq!(c.reward.variant, RewardVariant::Additive);
        assert_eq!(c.reward.w_p, 10.0);
        assert_eq!(c.reward.w_r, 20.0);
        assert!((c.scene_options().unwrap().ball.unwrap().radius - 0.144).abs() < 1e-12);
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
