//! Shared foundation of skillmimic-rs.
//!
//! * [`characters`]: the simulated characters, each one module — the SkillMimic humanoid
//!   (`characters::skillmimic`: 53 bodies, the clip columns' order), the TokenHSI character
//!   (`characters::tokenhsi`: 15 bodies, 32 dofs) and the SMPL humanoid (`characters::smpl`: 24
//!   bodies, 69 dofs) — and the [`characters::CharacterSpec`] the simulation reads;
//! * [`math`]: rotations in `f64` (quaternions stored **w, x, y, z** as MuJoCo does, rotation
//!   vectors / exponential maps, heading frame, tan-norm 6D).
//! * [`tensorfile`]: safetensors reading with validation and atomic writing.
//! * [`shared_data`]: where tests and benchmarks find the reference data in `../shared`.
//! * [`panic_message`]: the text of a caught panic (the CLI, the Python module and the fuzzer
//!   report panics with it).

pub mod characters;
pub mod math;
pub mod serde_array;
pub mod shared_data;
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
