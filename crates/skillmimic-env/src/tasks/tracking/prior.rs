//! The motion prior's per-frame features on the SMPL humanoid, as the released ModSkill code
//! builds its discriminator input (`build_amp_observations_smpl` with ModSkill's tracking
//! configuration: heading-local root, root height on, upright start, no dof subset, no shape or
//! limb-weight entries), computed from the simulation state ([`Task::style_features`], read by
//! `[ppo.amp]` when the tracking task runs on the SMPL humanoid).
//!
//! [`SMPL_PRIOR_DIM`] = 232 float32 per frame: root height (1, m) | root rotation in its heading
//! frame, tan-norm 6D (6) | root linear and angular velocity in the heading frame (3 + 3; m/s,
//! rad/s) | per joint (23, the humanoid's body order), its three hinge angles read as a rotation
//! vector, tan-norm 6D (138) | the 69 hinge rates (rad/s) | the key bodies R_Ankle, L_Ankle,
//! R_Wrist, L_Wrist relative to the root in the heading frame (12, m).
//!
//! As released: the toes' and hands' hinge angles and rates count as zero (the released code
//! zeroes dofs 9–11, 21–23, 51–53, 66–68 before building the features), and a joint's three
//! hinge angles are read as an exponential map although they are intrinsic x-y-z angles (the
//! released reading; equal to first order). Reference frames are the tracking clips posed in the
//! character's scene and read by the same function (the released demo side takes the motion's
//! exponential maps instead, which differ from the hinge reading at second order).
//!
//! [`Task::style_features`]: crate::task::Task::style_features

use skillmimic_core::characters::smpl;
use skillmimic_core::math::{Quat, heading_inverse, sub, tan_norm};
use skillmimic_sim::EnvState;

/// A function writing one frame's features of a state.
pub type Features = fn(&EnvState<'_>, &mut [f32]);

/// Features per frame.
pub const SMPL_PRIOR_DIM: usize = 1 + 6 + 3 + 3 + 6 * 23 + smpl::NUM_DOFS + 3 * KEY_BODIES.len();

/// The key bodies of the released configuration, in its order (R_Ankle, L_Ankle, R_Wrist,
/// L_Wrist), as SMPL humanoid body indices (checked against the names by a test).
pub const KEY_BODIES: [usize; 4] = [7, 3, 22, 17];

/// Bodies whose hinge angles and rates the released code zeroes (L_Toe, R_Toe, L_Hand,
/// R_Hand), as body indices (checked against the names by a test).
pub const ZEROED: [usize; 4] = [4, 8, 18, 23];

fn put(out: &mut [f32], at: usize, v: &[f64]) -> usize {
    for (o, x) in out[at..at + v.len()].iter_mut().zip(v) {
        *o = *x as f32;
    }
    at + v.len()
}

/// The three values of joint (body) `b` in a 69-wide dof array (body b's hinges at 3 (b − 1)),
/// zero for the [`ZEROED`] bodies.
fn joint(dofs: &[f64], b: usize) -> [f64; 3] {
    let d = 3 * (b - 1);
    if ZEROED.contains(&b) { [0.0; 3] } else { [dofs[d], dofs[d + 1], dofs[d + 2]] }
}

/// Write the features of the SMPL humanoid's state `st` into `out` (`SMPL_PRIOR_DIM` wide).
pub fn smpl_features(st: &EnvState<'_>, out: &mut [f32]) {
    let root = st.pos(0);
    let inv = heading_inverse(st.quat(0));
    let mut k = put(out, 0, &[root[2]]);
    k = put(out, k, &tan_norm(inv.mul(st.quat(0))));
    k = put(out, k, &inv.rotate(st.linvel(0)));
    k = put(out, k, &inv.rotate(st.angvel(0)));
    for b in 1..smpl::NUM_BODIES {
        k = put(out, k, &tan_norm(Quat::from_rotvec(joint(st.dof_pos, b))));
    }
    for b in 1..smpl::NUM_BODIES {
        k = put(out, k, &joint(st.dof_vel, b));
    }
    for b in KEY_BODIES {
        k = put(out, k, &inv.rotate(sub(st.pos(b), root)));
    }
    debug_assert_eq!(k, SMPL_PRIOR_DIM);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_and_zeroed_bodies_are_the_released_names() {
        let names = smpl::body_names();
        assert_eq!(KEY_BODIES.map(|b| names[b]), ["R_Ankle", "L_Ankle", "R_Wrist", "L_Wrist"]);
        assert_eq!(ZEROED.map(|b| names[b]), ["L_Toe", "R_Toe", "L_Hand", "R_Hand"]);
        let spec = smpl::spec();
        assert!((1..smpl::NUM_BODIES).all(|b| spec.bodies[b].dofs.start == 3 * (b - 1)));
    }
}
