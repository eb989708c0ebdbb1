//! The skill-policy observation (reference-facts §4.1), 902 values.
//!
//! | range | size | content (heading frame = world rotated about +z by −heading(root)) |
//! |---|---|---|
//! | 0 | 1 | root height: world z of the pelvis (m) |
//! | 1:157 | 156 | positions of bodies 1…52 minus the root position, in the heading frame (m) |
//! | 157:475 | 318 | rotations of all 53 bodies (root included) in the heading frame, tan-norm 6D |
//! | 475:634 | 159 | linear velocities (centre of mass) of all 53 bodies, heading frame (m/s) |
//! | 634:793 | 159 | angular velocities of all 53 bodies, heading frame (rad/s) |
//! | 793:823 | 30 | net contact force on the 10 fingertips (left Index3 … Thumb3, then right), **world**, N |
//! | 823:826 | 3 | ball position: (ball − root) with z replaced by the absolute ball height, heading frame (m) |
//! | 826:832 | 6 | ball rotation in the heading frame, tan-norm 6D |
//! | 832:835 | 3 | ball linear velocity, heading frame (m/s) |
//! | 835:838 | 3 | ball angular velocity, heading frame (rad/s) |
//! | 838:902 | 64 | one-hot skill label |
//!
//! Heading = atan2 of world +x rotated by the root quaternion (for this skeleton the character's
//! left side); tan-norm 6D of q = [R(q)·x̂, R(q)·ẑ]. Nothing is clipped; the learner's running
//! normaliser takes care of scales.

use std::ops::Range;

use skillmimic_core::characters::skillmimic::{NUM_BODIES, PROPRIO};
use skillmimic_core::math::{Quat, heading_inverse, tan_norm};
use skillmimic_motion::SKILL_WIDTH;
use skillmimic_sim::{BALL, EnvState};

/// Index ranges of the observation vector.
pub mod layout {
    use super::Range;
    pub const ROOT_HEIGHT: Range<usize> = 0..1;
    pub const BODY_POS: Range<usize> = 1..157;
    pub const BODY_ROT: Range<usize> = 157..475;
    pub const BODY_LINVEL: Range<usize> = 475..634;
    pub const BODY_ANGVEL: Range<usize> = 634..793;
    pub const FINGERTIP_FORCE: Range<usize> = 793..823;
    pub const BALL_POS: Range<usize> = 823..826;
    pub const BALL_ROT: Range<usize> = 826..832;
    pub const BALL_LINVEL: Range<usize> = 832..835;
    pub const BALL_ANGVEL: Range<usize> = 835..838;
    pub const SKILL: Range<usize> = 838..902;
    /// Humanoid part (1 + 53·15 − 3 + 30).
    pub const HUMANOID_DIM: usize = 823;
    /// Humanoid + ball part (the high-level controller's proprioception).
    pub const STATE_DIM: usize = 838;
    /// Full skill-policy observation.
    pub const OBS_DIM: usize = 902;
}

/// Version of the observation layout above (the table in this module's doc and [`BLOCKS`]),
/// written into exported policies so a deployment can refuse observations of another layout.
/// Any change of an entry's meaning, frame, unit or position gets a new version.
pub const OBS_LAYOUT_VERSION: &str = "skillmimic-obs-1";

/// Names of the observation blocks with their ranges (documentation, Python info).
pub const BLOCKS: [(&str, Range<usize>); 11] = [
    ("root_height", layout::ROOT_HEIGHT),
    ("body_pos", layout::BODY_POS),
    ("body_rot", layout::BODY_ROT),
    ("body_linvel", layout::BODY_LINVEL),
    ("body_angvel", layout::BODY_ANGVEL),
    ("fingertip_force", layout::FINGERTIP_FORCE),
    ("ball_pos", layout::BALL_POS),
    ("ball_rot", layout::BALL_ROT),
    ("ball_linvel", layout::BALL_LINVEL),
    ("ball_angvel", layout::BALL_ANGVEL),
    ("skill", layout::SKILL),
];

#[inline]
fn put3(out: &mut [f32], at: usize, v: [f64; 3]) {
    out[at] = v[0] as f32;
    out[at + 1] = v[1] as f32;
    out[at + 2] = v[2] as f32;
}

/// Write the 838 state entries (humanoid + ball) of the observation into `out[..838]`: the
/// humanoid's proprioception ([`crate::proprio`], 823), then the ball.
pub fn write_state_obs(st: &EnvState<'_>, out: &mut [f32]) {
    crate::proprio::write(&PROPRIO, NUM_BODIES, st, &mut out[..layout::HUMANOID_DIM]);
    let root = st.pos(0);
    let hinv: Quat = heading_inverse(st.quat(0));
    let ball = st.pos(BALL);
    put3(out, layout::BALL_POS.start, hinv.rotate([ball[0] - root[0], ball[1] - root[1], ball[2]]));
    let t = tan_norm(hinv.mul(st.quat(BALL)));
    for k in 0..6 {
        out[layout::BALL_ROT.start + k] = t[k] as f32;
    }
    put3(out, layout::BALL_LINVEL.start, hinv.rotate(st.linvel(BALL)));
    put3(out, layout::BALL_ANGVEL.start, hinv.rotate(st.angvel(BALL)));
}

/// Write the one-hot skill condition into a 64-wide slice.
pub fn write_skill(skill: u32, out: &mut [f32]) {
    out[..SKILL_WIDTH].fill(0.0);
    out[skill as usize] = 1.0;
}

/// The full 902-wide observation.
pub fn write_observation(st: &EnvState<'_>, skill: u32, out: &mut [f32]) {
    write_state_obs(st, &mut out[..layout::STATE_DIM]);
    write_skill(skill, &mut out[layout::SKILL]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_sizes_add_up() {
        assert_eq!(layout::HUMANOID_DIM, 1 + NUM_BODIES * (3 + 6 + 3 + 3) - 3 + 10 * 3);
        let mut end = 0;
        for (_, r) in BLOCKS {
            assert_eq!(r.start, end);
            end = r.end;
        }
        assert_eq!(end, layout::OBS_DIM);
        assert_eq!(layout::BALL_POS.start, layout::HUMANOID_DIM);
        assert_eq!(layout::SKILL.start, layout::STATE_DIM);
    }
}
