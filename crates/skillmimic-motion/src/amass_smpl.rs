//! AMASS-layout sequences straight onto the SMPL humanoid ([`skillmimic_core::characters::smpl`])
//! without retargeting (issue 39): the SMPL humanoid *is* SMPL's neutral body, so SMPL's joint
//! rotations are its joint rotations, as PHC's and ModSkill's motion conversion takes them.
//!
//! Per frame of a [`Sequence`] (SMPL 72, SMPL-H 156 or SMPL-X 165 columns):
//! 1. SMPL's 24 local rotations `L_j`: joints 0…21 as stored; SMPL's hand joints 22 and 23 from
//!    a 72-column SMPL file, identity for SMPL-H / SMPL-X (their columns there are fingers, which
//!    the humanoid lacks; PHC's conversion zeroes the hands the same way).
//! 2. World orientations in SMPL's kinematic tree, `G_j = G_parent(j) · L_j` (`G_0 = L_0`, the
//!    root orientation, which already stands SMPL's Y-up model up in AMASS's Z-up world).
//! 3. Each humanoid body `b` takes the world orientation of its SMPL joint turned into the
//!    humanoid's upright body frames, `G_t(b) = G_joint(b) · P⁻¹` with `P` SMPL's Y-up → the
//!    simulated Z-up frame ((x, y, z) ↦ (z, x, y), PHC's upright start); local rotations
//!    `G_t(parent)⁻¹ · G_t(b)` become the three hinge angles (intrinsic x-y-z).
//! 4. The pelvis at `trans + J_pelvis` (SMPL's neutral rest pelvis in model coordinates, added as
//!    is, as SMPL and PHC place it); with `ground`, the whole clip shifted vertically once so that
//!    the lowest foot-box point over the clip touches the floor (PHC's motion library fixes the
//!    height of each motion over the whole clip with the body mesh; the humanoid's foot boxes
//!    stand in for the mesh here).
//!
//! The sequence's `betas` are not used: the simulated body is the neutral mean shape (the
//! setting ModSkill reports), so its rest joints are SMPL's neutral ones whatever the subject.
//! The clip keeps the file's frame rate; the tracking task resamples it to its control rate.

use std::path::Path;

use serde::Serialize;
use skillmimic_core::characters::smpl::{self, NUM_BODIES};
use skillmimic_core::math::Quat;

use crate::amass::{SMPL_NEUTRAL_OFFSETS, Sequence};
use crate::character_clip::CharacterClip;
use crate::error::ClipError;

/// SMPL's 24-joint kinematic tree: the parent of each SMPL joint (SMPL's joint order: pelvis,
/// left hip, right hip, spine1, left knee, right knee, spine2, left ankle, right ankle, spine3,
/// left foot, right foot, neck, left collar, right collar, head, left shoulder, right shoulder,
/// left elbow, right elbow, left wrist, right wrist, left hand, right hand).
pub const SMPL_PARENTS: [Option<usize>; 24] = [
    None,
    Some(0),
    Some(0),
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(9),
    Some(9),
    Some(12),
    Some(13),
    Some(14),
    Some(16),
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(21),
];

/// The SMPL joint of each SMPL humanoid body (the humanoid's depth-first order, PHC's
/// `SMPL_MUJOCO_NAMES`: Pelvis, L_Hip, L_Knee, L_Ankle, L_Toe, R_Hip, …, R_Hand).
pub const SMPL_JOINT_OF_BODY: [usize; NUM_BODIES] =
    [0, 1, 4, 7, 10, 2, 5, 8, 11, 3, 6, 9, 12, 15, 13, 16, 18, 20, 22, 14, 17, 19, 21, 23];

/// What loading one sequence measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AmassSmplReport {
    pub name: String,
    pub frames: usize,
    /// The file's frame rate (frames per second), kept by the clip.
    pub fps: f64,
    /// Columns of the file's `poses` (72 SMPL, 156 SMPL-H, 165 SMPL-X).
    pub source_width: usize,
    /// The constant height shift applied to the pelvis (m; 0 without `ground`).
    pub ground_shift: f64,
    /// Lowest foot-box point over the clip after the shift (m; 0 with `ground`).
    pub lowest_foot_point: f64,
    /// Whether the file has shape coefficients (not used: the body is the neutral one).
    pub betas_ignored: bool,
}

/// SMPL's 24 local rotations of frame `f` (module docs, step 1).
fn local_rotations(seq: &Sequence, f: usize) -> [Quat; 24] {
    std::array::from_fn(|j| {
        let column = match (j, seq.width) {
            (0..=21, _) | (22 | 23, 72) => Some(3 * j),
            _ => None,
        };
        column.map_or(Quat::IDENTITY, |c| Quat::from_rotvec(seq.axis_angle(f, c)))
    })
}

/// The SMPL humanoid's root pose and hinge angles for frame `f` of `seq` (module docs, steps 1–4
/// without the ground shift): (pelvis position m, pelvis orientation, 69 hinge angles rad).
pub fn smpl_frame(
    spec: &skillmimic_core::characters::CharacterSpec,
    seq: &Sequence,
    f: usize,
) -> ([f64; 3], Quat, Vec<f64>) {
    let local = local_rotations(seq, f);
    let mut world = [Quat::IDENTITY; 24];
    for j in 0..24 {
        world[j] = match SMPL_PARENTS[j] {
            Some(p) => world[p].mul(local[j]).normalized(),
            None => local[j],
        };
    }
    let p_inv = smpl::upright().conj();
    let gt: [Quat; NUM_BODIES] =
        std::array::from_fn(|b| world[SMPL_JOINT_OF_BODY[b]].mul(p_inv).normalized());
    let mut q = vec![0.0; spec.num_dofs];
    for b in 1..NUM_BODIES {
        let parent = spec.bodies[b].parent.expect("a non-root body has a parent");
        spec.set_local_rotation(b, gt[parent].conj().mul(gt[b]).normalized(), &mut q);
    }
    let (tr, j0) = (seq.trans_at(f), SMPL_NEUTRAL_OFFSETS[0]);
    ([tr[0] + j0[0], tr[1] + j0[1], tr[2] + j0[2]], gt[0], q)
}

/// Load an AMASS-layout `.npz` (SMPL, SMPL-H or SMPL-X `poses`) as a clip of the SMPL humanoid
/// (module docs); `ground` shifts the clip so that its lowest foot point touches the floor.
/// Errors name the file and what is wrong (array shapes, joint count, frame rate, non-finite
/// values).
pub fn load(path: &Path, ground: bool) -> Result<(CharacterClip, AmassSmplReport), ClipError> {
    let seq = Sequence::read(path)?;
    let spec = smpl::spec();
    let mut frames: Vec<_> = (0..seq.frames).map(|f| smpl_frame(&spec, &seq, f)).collect();
    let lowest = frames
        .iter()
        .map(|(root, rot, q)| {
            let (pos, rots) = spec.forward_kinematics(*root, *rot, q);
            spec.lowest_foot_box(&pos, &rots)
        })
        .fold(f64::INFINITY, f64::min);
    let shift = if ground { -lowest } else { 0.0 };
    for f in &mut frames {
        f.0[2] += shift;
    }
    let name = path.file_stem().map_or("amass".into(), |s| s.to_string_lossy().into_owned());
    let source = format!("{} (AMASS layout, SMPL joint rotations as they are)", path.display());
    let clip = CharacterClip::from_frames(&spec, &name, &source, seq.fps, &frames);
    let rep = AmassSmplReport {
        name,
        frames: seq.frames,
        fps: seq.fps,
        source_width: seq.width,
        ground_shift: shift,
        lowest_foot_point: lowest + shift,
        betas_ignored: !seq.betas.is_empty(),
    };
    Ok((clip, rep))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_humanoid_bodies_map_onto_smpl_joints_by_name() {
        // SMPL joint names in SMPL's order, in the humanoid's naming
        let smpl_names = [
            "Pelvis",
            "L_Hip",
            "R_Hip",
            "Torso",
            "L_Knee",
            "R_Knee",
            "Spine",
            "L_Ankle",
            "R_Ankle",
            "Chest",
            "L_Toe",
            "R_Toe",
            "Neck",
            "L_Thorax",
            "R_Thorax",
            "Head",
            "L_Shoulder",
            "R_Shoulder",
            "L_Elbow",
            "R_Elbow",
            "L_Wrist",
            "R_Wrist",
            "L_Hand",
            "R_Hand",
        ];
        let spec = smpl::spec();
        for (b, body) in spec.bodies.iter().enumerate() {
            let j = SMPL_JOINT_OF_BODY[b];
            assert_eq!(smpl_names[j], body.name);
            // parents agree through the map
            let p = body.parent.map(|p| SMPL_JOINT_OF_BODY[p]);
            assert_eq!(p, SMPL_PARENTS[j], "{}", body.name);
        }
    }
}
