//! Shared foundation of skillmimic-rs.
//!
//! * [`skeleton`]: the SkillMimic humanoid (53 bodies, depth-first order, offsets, geoms, PD gains,
//!   named body sets). Every other crate indexes bodies and joint triples through this table.
//! * [`hsi_character`]: the TokenHSI character (15 bodies, 32 dofs, gains, action scaling).
//! * [`math`]: rotations in `f64` (quaternions stored **w, x, y, z** as MuJoCo does, rotation
//!   vectors / exponential maps, heading frame, tan-norm 6D).
//! * [`tensorfile`]: safetensors reading with validation and atomic writing.
//! * [`shared_data`]: where tests and benchmarks find the reference data in `../shared`.

pub mod hsi_character;
pub mod math;
pub mod shared_data;
pub mod skeleton;
pub mod tensorfile;
