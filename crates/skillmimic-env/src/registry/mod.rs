//! The task registry: name → constructor, the characters a task runs on and what consumers
//! outside the task need to know about it (its configuration tables, high-level PPO defaults,
//! evaluation, observation layout, episode starts). Adding a task = one module under `tasks/`
//! (its code and its configuration table) and one entry in [`TASKS`] (`list.rs`).

mod list;
mod tables;

use std::sync::Arc;

use skillmimic_motion::MotionLibrary;

use crate::config::EnvConfig;
use crate::config_table::TableEntry;
use crate::error::EnvError;
use crate::obs_blocks::{ObsBlock, ObsLayout};
use crate::task::EpisodeStarts;
use crate::tasks::multi;
use crate::vec_env::Env;

pub use list::TASKS;
pub use skillmimic_sim::{Character, SceneOptions};
pub use tables::tables;

/// A constructor over an already loaded motion library.
pub type BuildSharing = fn(&EnvConfig, Arc<MotionLibrary>) -> Result<Box<dyn Env>, EnvError>;

/// A registered task.
pub struct TaskEntry {
    /// The value of `env.task` that selects it.
    pub name: &'static str,
    /// One line for listings.
    pub summary: &'static str,
    /// The characters the task runs on (registry names of `skillmimic_core::characters`), the
    /// first the default (`env.character` empty).
    pub characters: &'static [&'static str],
    /// The configuration tables the task reads (`[env.<key>]`, defined next to the task's
    /// code); the imitation task's keys are `[env]`'s own.
    pub tables: &'static [TableEntry],
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
    /// Build it over an already loaded motion library (evaluation and video environments of a
    /// training run share the trainer's); `None`: [`TaskEntry::build`] loads its own data.
    pub build_sharing: Option<BuildSharing>,
    /// A high-level task (over a frozen policy, `env.hlc.llc`): its choices and the high-level
    /// PPO defaults. `None`: a low-level task.
    pub high_level: Option<HighLevel>,
    /// How its observation reads (ONNX metadata, without building an environment).
    pub obs_layout: ObsLayout,
    /// How `skillmimic eval` and the end of a training run evaluate it.
    pub evaluation: Evaluation,
    /// Apply an evaluation's episode-start request (`--horizon`, `--start-frame`) to the
    /// configuration, or refuse it with a message.
    pub episode_starts: fn(&mut EnvConfig, EpisodeStarts) -> Result<(), String>,
    /// Active skill learning (`run.active`) can generate clips for it.
    pub active_learning: bool,
}

/// What a high-level task declares beyond its environment.
#[derive(Clone, Copy, Debug)]
pub struct HighLevel {
    /// Skill label of each discrete choice (over a skill policy).
    pub choices: &'static [u32],
    /// PPO minibatches per iteration of the high-level defaults (the released code: 4 for
    /// scoring, 2 for the others).
    pub minibatches: usize,
    /// Training iterations of the high-level defaults when the run keeps the default count (the
    /// released SkillMimic code's `max_epochs`: 2 000, 6 000 for scoring; ModSkill's steering
    /// and reach, whose released configurations are not published, take 2 000 as well).
    pub iterations: usize,
}

/// How a task is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluation {
    /// SkillMimic's metrics (Acc, MPJPE, E_cg and the skills' success rules) of the imitation
    /// environment.
    SkillMimic,
    /// The task-independent episode report (return, length, the task's success metrics).
    Episodes,
    /// The episode report, and PHC's and ModSkill's evaluation of a motion tracker: every
    /// motion of the set once from its start (`skillmimic eval --each-motion`).
    Tracking,
}

fn no_build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    Err(EnvError::UnknownTask { name: cfg.task.clone(), known: names().join(", ") })
}

/// The defaults of a low-level task entry (`..LOW_LEVEL` in [`TASKS`]).
pub const LOW_LEVEL: TaskEntry = TaskEntry {
    name: "",
    summary: "",
    characters: &["skillmimic"],
    tables: &[],
    build: no_build,
    build_sharing: None,
    high_level: None,
    obs_layout: ObsLayout::Proprio { part: "task" },
    evaluation: Evaluation::Episodes,
    episode_starts: EpisodeStarts::refuse,
    active_learning: false,
};

/// The defaults of a high-level task entry (`..HIGH_LEVEL`; `high_level` is set per task).
pub const HIGH_LEVEL: TaskEntry =
    TaskEntry { obs_layout: ObsLayout::BallState { part: "task" }, ..LOW_LEVEL };

/// The registry as the multi-task environment sees it.
const MULTI: multi::Tasks = multi::Tasks {
    make,
    high_level: |name| entry(name).map(|e| e.high_level.is_some()),
    is_multi: |name| name == multi::HSI.name || name == multi::HLC.name,
    characters: |name| entry(name).map_or(&[], |e| e.characters),
    names,
};

fn build_hsi_multi(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    multi::build(cfg, &multi::HSI, &MULTI)
}

fn build_hlc_multi(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    multi::build(cfg, &multi::HLC, &MULTI)
}

/// Registered task names.
pub fn names() -> Vec<&'static str> {
    TASKS.iter().map(|t| t.name).collect()
}

/// Whether `name` is a registered high-level task.
pub fn is_high_level(name: &str) -> bool {
    TASKS.iter().any(|t| t.name == name && t.high_level.is_some())
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

/// The scene `cfg` asks for, on the task's character ([`character`]): the SkillMimic humanoid
/// with the ball (after the `[env.ball]` overrides), any other character bare; the solver of
/// `[env.physics]`.
pub fn scene_options(cfg: &EnvConfig) -> Result<SceneOptions, EnvError> {
    Ok(cfg.scene_options_on(character(cfg)?)?)
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

/// Build the environment of `cfg` sharing what `like` (an environment of the same task, e.g. the
/// trainer's) has loaded — its motion library — where the task can ([`TaskEntry::build_sharing`]);
/// otherwise as [`make`].
pub fn make_sharing(cfg: &EnvConfig, like: &dyn Env) -> Result<Box<dyn Env>, EnvError> {
    let character = character(cfg)?;
    let entry = entry(&cfg.task).expect("checked by character()");
    let mut c = cfg.clone();
    c.character = character.name().to_string();
    match (entry.build_sharing, like.library()) {
        (Some(build), Some(lib)) if like.spec().name == entry.name => build(&c, lib.clone()),
        _ => (entry.build)(&c),
    }
}

/// The named blocks of an observation `obs_dim` wide of the task and character of `cfg`, from
/// the task's declared layout (no environment is built).
pub fn obs_blocks(cfg: &EnvConfig, obs_dim: usize) -> Result<Vec<ObsBlock>, EnvError> {
    let character = character(cfg)?;
    let entry = entry(&cfg.task).expect("checked by character()");
    Ok(entry.obs_layout.blocks(&character.spec(), obs_dim))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An empty `env.character` (every saved TokenHSI configuration) is the task's default: the
    /// scene of `hsi_follow` is the bare TokenHSI character, not the SkillMimic humanoid with its
    /// ball (the fallback of `EnvConfig::scene_options`, which is crate-private for that reason).
    #[test]
    fn an_empty_character_is_the_tasks_default_in_the_scene() {
        let hsi = EnvConfig { task: "hsi_follow".into(), ..Default::default() };
        assert!(hsi.character.is_empty());
        let scene = scene_options(&hsi).unwrap();
        assert_eq!(scene.character.name(), "tokenhsi");
        assert!(scene.ball.is_none());
        assert_eq!(character(&hsi).unwrap().name(), "tokenhsi");
        let imitation = EnvConfig::default();
        let scene = scene_options(&imitation).unwrap();
        assert_eq!(scene.character.name(), "skillmimic");
        assert!(scene.ball.is_some());
        // a character the task does not run on is refused, naming the task's
        let wrong = EnvConfig { character: "smpl".into(), ..hsi };
        let err = scene_options(&wrong).unwrap_err().to_string();
        assert!(err.contains("task 'hsi_follow' runs on tokenhsi"), "{err}");
    }
}
