//! The task registry: name → constructor. Adding a task = one module under `tasks/` and one line
//! in [`TASKS`] (plus its config table in `EnvConfig`).

use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::tasks;
use crate::vec_env::Env;

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
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry { name: "imitation", summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)", high_level: false, choices: &[], build: tasks::imitation::env::build },
    TaskEntry { name: "stand", summary: "keep the pelvis height and the start heading (no clip, no ball)", high_level: false, choices: &[], build: tasks::stand::build },
    TaskEntry { name: "tracking", summary: "motion tracking of clips without the ball (ModSkill, PHC): next-frame reference observation", high_level: false, choices: &[], build: tasks::tracking::build },
    TaskEntry { name: "hsi_follow", summary: "TokenHSI: follow a procedural 2-D trajectory (32-DoF TokenHSI character)", high_level: false, choices: &[], build: tasks::hsi::follow::build },
    TaskEntry { name: "hsi_sit", summary: "TokenHSI: sit on a procedural chair or stool (32-DoF TokenHSI character)", high_level: false, choices: &[], build: tasks::hsi::sit::build },
    TaskEntry { name: "hsi_climb", summary: "TokenHSI: climb onto a procedural platform (32-DoF TokenHSI character)", high_level: false, choices: &[], build: tasks::hsi::climb::build },
    TaskEntry { name: "hsi_carry", summary: "TokenHSI: carry a box between two supports (32-DoF TokenHSI character)", high_level: false, choices: &[], build: tasks::hsi::carry::build },
    TaskEntry { name: "heading", summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)", high_level: true, choices: tasks::hlc::heading::LABELS, build: tasks::hlc::heading::build },
    TaskEntry { name: "circling", summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)", high_level: true, choices: tasks::hlc::circling::LABELS, build: tasks::hlc::circling::build },
    TaskEntry { name: "throwing", summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, --llc)", high_level: true, choices: tasks::hlc::throwing::LABELS, build: tasks::hlc::throwing::build },
    TaskEntry { name: "scoring", summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, --llc)", high_level: true, choices: tasks::hlc::scoring::LABELS, build: tasks::hlc::scoring::build },
    TaskEntry { name: "steering", summary: "skill reuse: move in a commanded direction at a commanded speed (ModSkill; skill or modular policy, --llc)", high_level: true, choices: tasks::hlc::steering::LABELS, build: tasks::hlc::steering::build },
    TaskEntry { name: "reach", summary: "skill reuse: bring the right hand to a 3-D target (ModSkill; skill or modular policy, --llc)", high_level: true, choices: tasks::hlc::reach::LABELS, build: tasks::hlc::reach::build },
];

/// Registered task names.
pub fn names() -> Vec<&'static str> {
    TASKS.iter().map(|t| t.name).collect()
}

/// Whether `name` is a registered high-level task.
pub fn is_high_level(name: &str) -> bool {
    TASKS.iter().any(|t| t.name == name && t.high_level)
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
