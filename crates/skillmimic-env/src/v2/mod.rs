//! SkillMimic-V2 (seed 003): the parts that make skills robust and connect them.
//!
//! * [`similarity`]: S = r_b · r_o · r_rel and the masked bridging-step count;
//! * [`transition`]: State Transition Field — ε-neighbourhood starts connected to the most
//!   similar frame of the same clip;
//! * [`graph`]: Stitched Trajectory Graph — aligned connections to other skills' states;
//! * [`ats`]: Adaptive Trajectory Sampling of clips and start frames;
//! * [`history`]: the history encoder (features, frozen encoder, incremental per-env buffer).
//!
//! They are wired into [`SkillEnv`](crate::SkillEnv) through `EnvConfig::v2`; each switches on
//! and off on its own.

pub mod ats;
pub mod graph;
pub mod history;
pub mod similarity;
pub mod transition;
