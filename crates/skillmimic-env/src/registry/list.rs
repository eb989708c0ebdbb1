//! The list of registered tasks (one entry per task; see [`super::TaskEntry`]).

use super::{
    Evaluation, HIGH_LEVEL, HighLevel, LOW_LEVEL, TaskEntry, build_hlc_multi, build_hsi_multi,
};
use crate::config_table::TableEntry;
use crate::obs_blocks::ObsLayout;
use crate::tasks;
use tasks::hlc;

const HSI: &[TableEntry] = &[tasks::hsi::TABLE];
const TOKENHSI: &[&str] = &["tokenhsi"];
const ALL: &[&str] = &skillmimic_sim::Character::NAMES;

/// Every task, in listing order.
pub const TASKS: &[TaskEntry] = &[
    TaskEntry {
        name: "imitation",
        summary: "SkillMimic imitation of human–ball clips (+ SkillMimic-V2 parts)",
        build: tasks::imitation::env::build,
        obs_layout: ObsLayout::Imitation,
        evaluation: Evaluation::SkillMimic,
        episode_starts: tasks::imitation::env::episode_starts,
        build_sharing: Some(tasks::imitation::env::build_sharing),
        ..LOW_LEVEL
    },
    // ANCHOR: stand
    TaskEntry {
        name: "stand",
        summary: "keep the pelvis height and the start heading (no clip, no ball)",
        characters: ALL,
        tables: &[tasks::stand::TABLE],
        build: tasks::stand::build,
        obs_layout: tasks::stand::LAYOUT,
        ..LOW_LEVEL
    },
    // ANCHOR_END: stand
    TaskEntry {
        name: "tracking",
        summary: "motion tracking of clips without the ball (ModSkill, PHC): next-frame reference \
            observation",
        characters: &["skillmimic", "smpl"],
        tables: &[tasks::tracking::TABLE],
        build: tasks::tracking::build,
        obs_layout: tasks::tracking::LAYOUT,
        episode_starts: tasks::tracking::episode_starts,
        evaluation: Evaluation::Tracking,
        active_learning: true,
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_follow",
        summary: "TokenHSI: follow a procedural 2-D trajectory (32-DoF TokenHSI character)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::follow::build,
        obs_layout: ObsLayout::Proprio { part: "hsi_follow" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_sit",
        summary: "TokenHSI: sit on a procedural chair or stool (32-DoF TokenHSI character)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::sit::build,
        obs_layout: ObsLayout::Proprio { part: "hsi_sit" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_climb",
        summary: "TokenHSI: climb onto a procedural platform (32-DoF TokenHSI character)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::climb::build,
        obs_layout: ObsLayout::Proprio { part: "hsi_climb" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_carry",
        summary: "TokenHSI: carry a box between two supports (32-DoF TokenHSI character)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::carry::build,
        obs_layout: ObsLayout::Proprio { part: "hsi_carry" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_follow_carry",
        summary: "TokenHSI composition: follow a trajectory while carrying a box (policy \
            adaptation target)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_follow_carry,
        obs_layout: ObsLayout::Proprio { part: "hsi_follow_carry" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_sit_carry",
        summary: "TokenHSI composition: sit down while carrying a box (policy adaptation target)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_sit_carry,
        obs_layout: ObsLayout::Proprio { part: "hsi_sit_carry" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_climb_carry",
        summary: "TokenHSI composition: climb onto a platform while carrying a box (policy \
            adaptation target)",
        characters: TOKENHSI,
        tables: HSI,
        build: tasks::hsi::compose::build_climb_carry,
        obs_layout: ObsLayout::Proprio { part: "hsi_climb_carry" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "hsi_multi",
        summary: "TokenHSI multi-task: environments split across TokenHSI tasks by [env.multi] \
            (one token policy)",
        characters: TOKENHSI,
        tables: &[tasks::hsi::TABLE, tasks::multi::TABLE],
        build: build_hsi_multi,
        obs_layout: ObsLayout::Proprio { part: "hsi_multi" },
        ..LOW_LEVEL
    },
    TaskEntry {
        name: "heading",
        summary: "skill reuse: dribble the ball to a target (frozen skill policy, --llc)",
        tables: &[hlc::TABLE, hlc::heading::TABLE],
        build: tasks::hlc::heading::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::heading::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "heading" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "circling",
        summary: "skill reuse: dribble around a point at a radius (frozen skill policy, --llc)",
        tables: &[hlc::TABLE, hlc::circling::TABLE],
        build: tasks::hlc::circling::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::circling::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "circling" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "throwing",
        summary: "skill reuse: throw the ball up to 2.5 m and catch it (frozen skill policy, \
            --llc)",
        tables: &[hlc::TABLE, hlc::throwing::TABLE],
        build: tasks::hlc::throwing::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::throwing::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "throwing" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "scoring",
        summary: "skill reuse: dribble to a basket and score with layups (frozen skill policy, \
            --llc)",
        tables: &[hlc::TABLE, hlc::scoring::TABLE],
        build: tasks::hlc::scoring::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::scoring::LABELS,
            minibatches: 4,
            iterations: 6000,
        }),
        obs_layout: ObsLayout::BallState { part: "scoring" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "steering",
        summary: "skill reuse: move in a commanded direction at a commanded speed (ModSkill; \
            skill or modular policy, --llc)",
        tables: &[hlc::TABLE, hlc::steering::TABLE],
        build: tasks::hlc::steering::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::steering::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "steering" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "reach",
        summary: "skill reuse: bring the right hand to a 3-D target (ModSkill; skill or modular \
            policy, --llc)",
        tables: &[hlc::TABLE, hlc::reach::TABLE],
        build: tasks::hlc::reach::build,
        high_level: Some(HighLevel {
            choices: tasks::hlc::reach::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "reach" },
        ..HIGH_LEVEL
    },
    TaskEntry {
        name: "hlc_multi",
        summary: "skill reuse, multi-task: environments split across high-level tasks by \
            [env.multi] (one token policy)",
        tables: &[hlc::TABLE, tasks::multi::TABLE],
        build: build_hlc_multi,
        high_level: Some(HighLevel {
            choices: tasks::hlc::heading::LABELS,
            minibatches: 2,
            iterations: 2000,
        }),
        obs_layout: ObsLayout::BallState { part: "hlc_multi" },
        ..HIGH_LEVEL
    },
];
