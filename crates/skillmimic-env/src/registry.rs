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
    /// A high-level task (discrete skill choices over a frozen skill policy): the learner then
    /// defaults to the high-level controller's network and PPO settings.
    pub high_level: bool,
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry { name: "imitation", summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)", high_level: false, build: tasks::imitation::env::build },
    TaskEntry { name: "stand", summary: "keep the pelvis height and the start heading (no clip, no ball)", high_level: false, build: tasks::stand::build },
    TaskEntry { name: "heading", summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)", high_level: true, build: tasks::hlc::heading::build },
    TaskEntry { name: "circling", summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)", high_level: true, build: tasks::hlc::circling::build },
    TaskEntry { name: "throwing", summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, --llc)", high_level: true, build: tasks::hlc::throwing::build },
    TaskEntry { name: "scoring", summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, --llc)", high_level: true, build: tasks::hlc::scoring::build },
];

/// Registered task names.
pub fn names() -> Vec<&'static str> {
    TASKS.iter().map(|t| t.name).collect()
}

/// Whether `name` is a registered high-level task.
pub fn is_high_level(name: &str) -> bool {
    TASKS.iter().any(|t| t.name == name && t.high_level)
}

/// Build the environment of the task named by `cfg.task`.
pub fn make(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    match TASKS.iter().find(|t| t.name == cfg.task) {
        Some(t) => (t.build)(cfg),
        None => Err(EnvError::UnknownTask { name: cfg.task.clone(), known: names().join(", ") }),
    }
}
