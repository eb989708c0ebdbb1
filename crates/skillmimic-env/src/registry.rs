//! The task registry: name → constructor and the characters a task runs on. Adding a task = one
//! module under `tasks/` and one line in [`TASKS`] (plus its config table in `EnvConfig`).

use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::tasks;
use crate::vec_env::Env;

pub use skillmimic_sim::Character;

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
    /// The characters the task runs on (registry names of `skillmimic_core::characters`), the
    /// first the default (`env.character` empty).
    pub characters: &'static [&'static str],
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

const SKILLMIMIC: &[&str] = &["skillmimic"];
const TOKENHSI: &[&str] = &["tokenhsi"];
const ALL: &[&str] = &skillmimic_sim::Character::NAMES;

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry {
        name: "imitation",
        summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)",
        high_level: false,
        choices: &[],
        characters: SKILLMIMIC,
        build: tasks::imitation::env::build,
    },
    TaskEntry {
        name: "stand",
        summary: "keep the pelvis height and the start heading (no clip, no ball)",
        high_level: false,
        choices: &[],
        characters: ALL,
        build: tasks::stand::build,
    },
    TaskEntry {
        name: "tracking",
        summary: "motion tracking of clips without the ball (ModSkill, PHC): next-frame reference observation",
        high_level: false,
        choices: &[],
        characters: &["skillmimic", "smpl"],
        build: tasks::tracking::build,
    },
    TaskEntry {
        name: "hsi_follow",
        summary: "TokenHSI: follow a procedural 2-D trajectory (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::follow::build,
    },
    TaskEntry {
        name: "hsi_sit",
        summary: "TokenHSI: sit on a procedural chair or stool (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::sit::build,
    },
    TaskEntry {
        name: "hsi_climb",
        summary: "TokenHSI: climb onto a procedural platform (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::climb::build,
    },
    TaskEntry {
        name: "hsi_carry",
        summary: "TokenHSI: carry a box between two supports (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::carry::build,
    },
    TaskEntry {
        name: "hsi_follow_carry",
        summary: "TokenHSI composition: follow a trajectory while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::compose::build_follow_carry,
    },
    TaskEntry {
        name: "hsi_sit_carry",
        summary: "TokenHSI composition: sit down while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::compose::build_sit_carry,
    },
    TaskEntry {
        name: "hsi_climb_carry",
        summary: "TokenHSI composition: climb onto a platform while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::hsi::compose::build_climb_carry,
    },
    TaskEntry {
        name: "hsi_multi",
        summary: "TokenHSI multi-task: environments split across TokenHSI tasks by [env.multi] (one token policy)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        build: tasks::multi::build,
    },
    TaskEntry {
        name: "heading",
        summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::heading::build,
    },
    TaskEntry {
        name: "circling",
        summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::circling::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::circling::build,
    },
    TaskEntry {
        name: "throwing",
        summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::throwing::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::throwing::build,
    },
    TaskEntry {
        name: "scoring",
        summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::scoring::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::scoring::build,
    },
    TaskEntry {
        name: "steering",
        summary: "skill reuse: move in a commanded direction at a commanded speed (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::steering::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::steering::build,
    },
    TaskEntry {
        name: "reach",
        summary: "skill reuse: bring the right hand to a 3-D target (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::reach::LABELS,
        characters: SKILLMIMIC,
        build: tasks::hlc::reach::build,
    },
    TaskEntry {
        name: "hlc_multi",
        summary: "skill reuse, multi-task: environments split across high-level tasks by [env.multi] (one token policy)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        characters: SKILLMIMIC,
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

/// The character `cfg` asks for: `env.character`, or the task's default when it is empty; an
/// unknown character, or one the task does not run on, is an error listing the task's.
pub fn character(cfg: &EnvConfig) -> Result<Character, EnvError> {
    let entry = entry(&cfg.task).ok_or_else(|| EnvError::UnknownTask {
        name: cfg.task.clone(),
        known: names().join(", "),
    })?;
    let name = if cfg.character.is_empty() { entry.characters[0] } else { cfg.character.as_str() };
    let hands = cfg.hand_model()?;
    let supported = entry.characters.contains(&name);
    match Character::by_name(name, hands) {
        Some(c) if supported => Ok(c),
        _ => Err(crate::error::bad(
            "env.character",
            format!(
                "task '{}' runs on {} (registered characters: {}); got '{name}'",
                cfg.task,
                entry.characters.join(", "),
                Character::NAMES.join(", ")
            ),
        )
        .into()),
    }
}

/// The registered task called `name`.
pub fn entry(name: &str) -> Option<&'static TaskEntry> {
    TASKS.iter().find(|t| t.name == name)
}

/// Build the environment of the task named by `cfg.task` on the character `cfg` asks for
/// ([`character`]; the constructor sees `env.character` filled in).
pub fn make(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    let character = character(cfg)?;
    let entry = entry(&cfg.task).expect("checked by character()");
    let mut c = cfg.clone();
    c.character = character.name().to_string();
    (entry.build)(&c)
}
