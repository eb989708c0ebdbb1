//! The registered tasks (see [`crate::registry`]).
//!
//! * [`imitation`]: SkillMimic imitation of human–ball clips, with the SkillMimic-V2 parts;
//! * [`stand`]: keep the pelvis height and heading — the worked example of adding a task.

pub mod imitation;
pub mod stand;
