//! The 222-d proprioception of the TokenHSI character (supplementary §A; ASE's observation with
//! the root height left out and the root rotation kept in the world frame): the shared formula
//! of [`crate::proprio`] with the character's [`PROPRIO`] selection.
//!
//! Layout (float32), all in the root's heading frame (rotation about +z by −heading, heading =
//! yaw of the pelvis's x axis) relative to the root, except where noted:
//! * `[0, 42)`: positions of bodies 1…14 minus the root position (m);
//! * `[42, 132)`: rotations of bodies 0…14 as tan-norm 6D (rotated x axis, rotated z axis) —
//!   body 0 (the root) in the **world** frame, the others heading-local;
//! * `[132, 177)`: linear velocities of the 15 bodies' centres of mass (m/s);
//! * `[177, 222)`: angular velocities of the 15 bodies (rad/s).

use skillmimic_core::characters::tokenhsi::{NUM_BODIES, PROPRIO};
use skillmimic_sim::EnvState;

/// Width of the proprioception.
pub const PROPRIO_DIM: usize =
    3 * (NUM_BODIES - 1) + 6 * NUM_BODIES + 3 * NUM_BODIES + 3 * NUM_BODIES;

/// Write the proprioception of `st` into `out[..222]`.
pub fn write_proprio(st: &EnvState<'_>, out: &mut [f32]) {
    crate::proprio::write(&PROPRIO, NUM_BODIES, st, out);
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_proprioception_is_222_wide() {
        assert_eq!(super::PROPRIO_DIM, 222);
        assert_eq!(super::PROPRIO.width(super::NUM_BODIES), 222);
    }
}
