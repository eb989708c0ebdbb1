//! The 222-d proprioception of the TokenHSI character (supplementary §A; ASE's observation with
//! the root height left out and the root rotation kept in the world frame).
//!
//! Layout (float32), all in the root's heading frame (rotation about +z by −heading, heading =
//! yaw of the pelvis's x axis) relative to the root, except where noted:
//! * `[0, 42)`: positions of bodies 1…14 minus the root position (m);
//! * `[42, 132)`: rotations of bodies 0…14 as tan-norm 6D (rotated x axis, rotated z axis) —
//!   body 0 (the root) in the **world** frame, the others heading-local;
//! * `[132, 177)`: linear velocities of the 15 bodies' centres of mass (m/s);
//! * `[177, 222)`: angular velocities of the 15 bodies (rad/s).

use skillmimic_core::hsi_character::NUM_BODIES;
use skillmimic_core::math::{heading_inverse, sub, tan_norm};
use skillmimic_sim::HsiEnvState;

/// Width of the proprioception.
pub const PROPRIO_DIM: usize =
    3 * (NUM_BODIES - 1) + 6 * NUM_BODIES + 3 * NUM_BODIES + 3 * NUM_BODIES;

/// Write the proprioception of `st` into `out[..222]`.
pub fn write_proprio(st: &HsiEnvState<'_>, out: &mut [f32]) {
    let root = st.pos(0);
    let rq = st.quat(0);
    let inv = heading_inverse(rq);
    for b in 1..NUM_BODIES {
        let p = inv.rotate(sub(st.pos(b), root));
        for k in 0..3 {
            out[3 * (b - 1) + k] = p[k] as f32;
        }
    }
    let r0 = 3 * (NUM_BODIES - 1);
    for b in 0..NUM_BODIES {
        let t = if b == 0 { tan_norm(rq) } else { tan_norm(inv.mul(st.quat(b))) };
        for k in 0..6 {
            out[r0 + 6 * b + k] = t[k] as f32;
        }
    }
    let (v0, w0) = (r0 + 6 * NUM_BODIES, r0 + 9 * NUM_BODIES);
    for b in 0..NUM_BODIES {
        let v = inv.rotate(st.linvel(b));
        let w = inv.rotate(st.angvel(b));
        for k in 0..3 {
            out[v0 + 3 * b + k] = v[k] as f32;
            out[w0 + 3 * b + k] = w[k] as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_proprioception_is_222_wide() {
        assert_eq!(super::PROPRIO_DIM, 222);
    }
}
