//! Motion data of skillmimic-rs.
//!
//! * [`pt`]: a restricted reader for `torch.save` archives holding one float32 matrix
//!   (BallPlay-M clips) — no pickle code is executed;
//! * [`clip`]: the project's clip representation and its decoding from the 337-column layout.

pub mod clip;
pub mod error;
pub mod pt;

pub use clip::{BALLPLAY_FPS, Clip, PT_WIDTH, SKILL_WIDTH};
pub use error::ClipError;
