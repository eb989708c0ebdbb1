//! Shared foundation of skillmimic-rs.
//!
//! * [`skeleton`]: the SkillMimic humanoid (53 bodies, depth-first order, offsets, geoms, PD gains,
//!   named body sets). Every other crate indexes bodies and joint triples through this table.
//! * [`hsi_character`]: the TokenHSI character (15 bodies, 32 dofs, gains, action scaling).
//! * [`math`]: rotations in `f64` (quaternions stored **w, x, y, z** as MuJoCo does, rotation
//!   vectors / exponential maps, heading frame, tan-norm 6D).
//! * [`tensorfile`]: safetensors reading with validation and atomic writing.
//! * [`shared_data`]: where tests and benchmarks find the reference data in `../shared`.
//! * [`panic_message`]: the text of a caught panic (the CLI, the Python module and the fuzzer
//!   report panics with it).

pub mod hsi_character;
pub mod math;
pub mod shared_data;
pub mod skeleton;
pub mod tensorfile;

/// The message of a panic caught with `std::panic::catch_unwind` (`panic!` payloads are a
/// `&str` or a `String`); "unknown panic" for any other payload.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}
