//! The registered tasks (see [`crate::registry`]).
//!
//! * [`imitation`]: SkillMimic imitation of human–ball clips, with the SkillMimic-V2 parts;
//! * [`hlc`]: skill reuse — `heading`, `circling`, `throwing`, `scoring`, `steering`, `reach` over
//!   a frozen skill policy (SkillMimic §5.4);
//! * [`hsi`]: the TokenHSI tasks on the 32-DoF TokenHSI character — `hsi_follow`, `hsi_sit`,
//!   `hsi_climb`, `hsi_carry`;
//! * [`multi`]: `hsi_multi`, `hlc_multi` — several tasks in one batch for one token policy;
//! * [`stand`]: keep the pelvis height and heading — the worked example of adding a task;
//! * [`tracking`]: motion tracking without the ball (ModSkill, PHC).

pub mod hlc;
pub mod hsi;
pub mod imitation;
pub mod multi;
pub mod stand;
pub mod tracking;
