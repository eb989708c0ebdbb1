//! The task registry: name → constructor and the characters a task runs on. Adding a task = one
//! module under `tasks/` and one line in [`TASKS`] (plus its config table in `EnvConfig`).

use crate::config::EnvConfig;
use crate::config_table::{TableEntry, TaskTables};
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
    /// The configuration tables the task reads (`[env.<key>]`, defined next to the task's
    /// code); the imitation task's keys are `[env]`'s own.
    pub tables: &'static [TableEntry],
    /// Build the batched environment from the `[env]` table (episode starts seeded with
    /// `cfg.start_seed(0)`; trainers set `env.seed` explicitly first).
    pub build: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
}

use tasks::hlc;

const SKILLMIMIC: &[&str] = &["skillmimic"];
const HSI: &[TableEntry] = &[tasks::hsi::TABLE];
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
        tables: &[],
        build: tasks::imitation::env::build,
    },
    TaskEntry {
        name: "stand",
        summary: "keep the pelvis height and the start heading (no clip, no ball)",
        high_level: false,
        choices: &[],
        characters: ALL,
        tables: &[tasks::stand::TABLE],
        build: tasks::stand::build,
    },
    TaskEntry {
        name: "tracking",
        summary: "motion tracking of clips without the ball (ModSkill, PHC): next-frame reference observation",
        high_level: false,
        choices: &[],
        characters: &["skillmimic", "smpl"],
        tables: &[tasks::tracking::TABLE],
        build: tasks::tracking::build,
    },
    TaskEntry {
        name: "hsi_follow",
        summary: "TokenHSI: follow a procedural 2-D trajectory (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::follow::build,
    },
    TaskEntry {
        name: "hsi_sit",
        summary: "TokenHSI: sit on a procedural chair or stool (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::sit::build,
    },
    TaskEntry {
        name: "hsi_climb",
        summary: "TokenHSI: climb onto a procedural platform (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::climb::build,
    },
    TaskEntry {
        name: "hsi_carry",
        summary: "TokenHSI: carry a box between two supports (32-DoF TokenHSI character)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::carry::build,
    },
    TaskEntry {
        name: "hsi_follow_carry",
        summary: "TokenHSI composition: follow a trajectory while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_follow_carry,
    },
    TaskEntry {
        name: "hsi_sit_carry",
        summary: "TokenHSI composition: sit down while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_sit_carry,
    },
    TaskEntry {
        name: "hsi_climb_carry",
        summary: "TokenHSI composition: climb onto a platform while carrying a box (policy adaptation target)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_climb_carry,
    },
    TaskEntry {
        name: "hsi_multi",
        summary: "TokenHSI multi-task: environments split across TokenHSI tasks by [env.multi] (one token policy)",
        high_level: false,
        choices: &[],
        characters: TOKENHSI,
        tables: &[tasks::hsi::TABLE, tasks::multi::TABLE],
        build: tasks::multi::build,
    },
    TaskEntry {
        name: "heading",
        summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::heading::TABLE],
        build: tasks::hlc::heading::build,
    },
    TaskEntry {
        name: "circling",
        summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::circling::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::circling::TABLE],
        build: tasks::hlc::circling::build,
    },
    TaskEntry {
        name: "throwing",
        summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::throwing::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::throwing::TABLE],
        build: tasks::hlc::throwing::build,
    },
    TaskEntry {
        name: "scoring",
        summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, --llc)",
        high_level: true,
        choices: tasks::hlc::scoring::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::scoring::TABLE],
        build: tasks::hlc::scoring::build,
    },
    TaskEntry {
        name: "steering",
        summary: "skill reuse: move in a commanded direction at a commanded speed (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::steering::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::steering::TABLE],
        build: tasks::hlc::steering::build,
    },
    TaskEntry {
        name: "reach",
        summary: "skill reuse: bring the right hand to a 3-D target (ModSkill; skill or modular policy, --llc)",
        high_level: true,
        choices: tasks::hlc::reach::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, hlc::reach::TABLE],
        build: tasks::hlc::reach::build,
    },
    TaskEntry {
        name: "hlc_multi",
        summary: "skill reuse, multi-task: environments split across high-level tasks by [env.multi] (one token policy)",
        high_level: true,
        choices: tasks::hlc::heading::LABELS,
        characters: SKILLMIMIC,
        tables: &[hlc::TABLE, tasks::multi::TABLE],
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

/// Every registered configuration table, once each, in listing order of the tasks that read it.
pub fn tables() -> Vec<&'static TableEntry> {
    let mut out: Vec<&'static TableEntry> = Vec::new();
    for t in TASKS.iter().flat_map(|e| e.tables) {
        if !out.iter().any(|o| o.key == t.key) {
            out.push(t);
        }
    }
    out
}

/// Every registered table at its defaults.
impl Default for TaskTables {
    fn default() -> Self {
        TaskTables(tables().into_iter().map(|e| (e.key, (e.default)())).collect())
    }
}

/// The `[env]` keys that are not the driver's or the imitation task's: each must be a registered
/// table (the message lists them); a table's own keys are checked by its type.
impl<'de> serde::Deserialize<'de> for TaskTables {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let given = toml::Table::deserialize(d)?;
        let mut out = TaskTables::default();
        let all = tables();
        for (key, value) in given {
            let Some(entry) = all.iter().find(|e| e.key == key) else {
                let keys: Vec<&str> = all.iter().map(|e| e.key).collect();
                return Err(D::Error::custom(format!(
                    "unknown field `{key}`: not a key of [env] nor a task's table ({})",
                    keys.join(", ")
                )));
            };
            let table =
                (entry.parse)(value).map_err(|e| D::Error::custom(format!("[env.{key}]: {e}")))?;
            let slot = out.0.iter_mut().find(|(k, _)| *k == key).expect("every table is defaulted");
            slot.1 = table;
        }
        Ok(out)
    }
}

/// One property per registered table (with its one-line description), for the configuration
/// reference and the range checks.
impl schemars::JsonSchema for TaskTables {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "TaskTables".into()
    }
    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let mut props = serde_json::Map::new();
        for e in tables() {
            let mut s = (e.schema)(generator).to_value();
            if let Some(o) = s.as_object_mut() {
                o.insert("description".into(), e.doc.into());
            }
            props.insert(e.key.to_string(), s);
        }
        schemars::json_schema!({ "type": "object", "properties": props })
    }
}
