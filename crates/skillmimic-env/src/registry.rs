//! The task registry: name → constructor. Adding a task = one module under `tasks/` and one line
//! in [`TASKS`] (plus its config table in `EnvConfig`).

use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::tasks;
use crate::vec_env::Env;

/// The simulated character a task drives (what its observation's first entries describe).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Character {
    /// The 53-body SkillMimic humanoid (observation starts with its 823 humanoid entries).
    SkillMimic,
    /// The 15-body, 32-DoF TokenHSI character (observation starts with its 222-d proprioception).
    TokenHsi,
}

/// A registered task.
pub struct TaskEntry {
    /// The value of `env.task` that selects it.
    pub name: &'static str,
    /// One line for listings.
    pub summary: &'static str,
    /// A high-level task (over a frozen policy, `env.hlc.llc`: discrete skill choices, or part
    /// embeddings for a modular checkpoint): the learner then defaults to the high-level
    /// controller's network and PPO settings.
    pub high_level: bool,
    /// Skill label of each discrete choice of a high-level task (empty for the others).
    pub choices: &'static [u32],
    /// The character (the adversarial motion prior reads its features and reference clips).
    pub character: Character,
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry {
        name: "imitation",
        summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)",
        high_level: false,
        choices: &[],
        character: Character::SkillMimic,
        build: tasks::imitation::env::build,
    },
    TaskEntry {
        name: "stand",
        summary: "keep the pelvis height and the start heading (no clip, no ball)",
        high_level: false,
        choices: &[],
        character: Character::SkillMimic,
        build: tasks::stand::build,
    },
    TaskEntry {
        name: "tracking",
        summary: "motion tracking of clips without the ball (ModSkill, PHC): next-frame reference observation",
        high_level: false,
        choices: &[],
        character: Character::SkillMimic,
        build: tasks::tracking::build,
    },
    TaskEntry {
        name: "hsi_follow",
        summary: "TokenHSI: follow a procedural 2-D trajectory (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::follow::build,
    },
    TaskEntry {
        name: "hsi_sit",
        summary: "TokenHSI: sit on a procedural chair or stool (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::sit::build,
    },
    TaskEntry {
        name: "hsi_climb",
        summary: "TokenHSI: climb onto a procedural platform (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::climb::build,
    },
    TaskEntry {
        name: "hsi_carry",
        summary: "TokenHSI: carry a box between two supports (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::carry::build,
    },
    TaskEntry {
        name: "hsi_follow_carry",
        summary: "TokenHSI composition: follow a trajectory while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::compose::build_follow_carry,
    },
    TaskEntry {
        name: "hsi_sit_carry",
        summary: "TokenHSI composition: sit down while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::compose::build_sit_carry,
    },
    TaskEntry {
        name: "hsi_climb_carry",
        summary: "TokenHSI composition: climb onto a platform while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::hsi::compose::build_climb_carry,
    },
    TaskEntry {
        name: "hsi_multi",
        summary: "TokenHSI multi-task: environments split across TokenHSI tasks by [env.multi] (one token policy)",
        high_level: false,
        choices: &[],
        character: Character::TokenHsi,
        build: tasks::multi::build,
    },
    TaskEntry {
        name: "heading",
        summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::heading::build,
    },
    TaskEntry {
        name: "circling",
        summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::circling::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::circling::build,
    },
    TaskEntry {
        name: "throwing",
        summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::throwing::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::throwing::build,
    },
    TaskEntry {
        name: "scoring",
        summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::scoring::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::scoring::build,
    },
    TaskEntry {
        name: "steering",
        summary: "skill reuse: move in a commanded direction at a commanded speed (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::steering::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::steering::build,
    },
    TaskEntry {
        name: "reach",
        summary: "skill reuse: bring the right hand to a 3-D target (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::reach::LABELS,
        character: Character::SkillMimic,
        build: tasks::hlc::reach::build,
    },
    TaskEntry {
        name: "hlc_multi",
        summary: "skill reuse, multi-task: environments split across high-level tasks by [env.multi] (one token policy)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        character: Character::SkillMimic,
        build: tasks::multi::build,
    },
];

/// Registered task names.
pub fn names() -> Vec<&'static str> {
    TASKS.iter().map(|t| t.name).collect()
}

/// Whether `name` is a registered high-level task.
pub fn is_high_level(name: &str) -> bool {
    TASKS.iter().any(|t| t.name == name && t.high_level)
}

/// The character of the registered task `name` (`None` for an unknown name).
pub fn character(name: &str) -> Option<Character> {
    entry(name).map(|t| t.character)
}

/// The registered task called `name`.
pub fn entry(name: &str) -> Option<&'static TaskEntry> {
    TASKS.iter().find(|t| t.name == name)
}

/// Build the environment of the task named by `cfg.task`.
pub fn make(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    match entry(&cfg.task) {
        Some(t) => (t.build)(cfg),
        None => Err(EnvError::UnknownTask { name: cfg.task.clone(), known: names().join(", ") }),
    }
}
