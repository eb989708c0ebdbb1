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
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry { name: "imitation", summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)", build: tasks::imitation::env::build },
    TaskEntry { name: "stand", summary: "keep the pelvis height and the start heading (no clip, no ball)", build: tasks::stand::build },
];

/// Registered task names.
pub fn names() -> Vec<&'static str> {
    TASKS.iter().map(|t| t.name).collect()
}

/// Build the environment of the task named by `cfg.task`.
pub fn make(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    match TASKS.iter().find(|t| t.name == cfg.task) {
        Some(t) => (t.build)(cfg),
        None => Err(EnvError::UnknownTask { name: cfg.task.clone(), known: names().join(", ") }),
    }
}
