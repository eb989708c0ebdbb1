//! Retargeting clips of the SkillMimic skeleton (BallPlay-M, the demo clips) onto the SMPL
//! humanoid ([`skillmimic_core::characters::smpl`]) by joint name — the body motion only.
//!
//! Both skeletons are authored in SMPL's Y-up frame (+x the character's left, +z forward) and
//! share the body names of SMPL's 22 body joints, so the mapping is exact up to proportions:
//! 1. World orientations of the source bodies from the clip (root quaternion, exp-map chain).
//! 2. Each SMPL body takes the world orientation of its namesake, turned into the SMPL
//!    character's upright body frames: `G_t(b) = G_s(b) · P⁻¹`, where `P` maps SMPL's Y-up
//!    vectors onto the simulated Z-up frame ((x, y, z) ↦ (z, x, y), PHC's upright turn). Sources:
//!    every SMPL body's namesake, except `L_Hand` / `R_Hand` ← the middle finger's first segment
//!    (`L_Middle1`, `R_Middle1`; SMPL's hand body is the fingers). The source's `Spine2` has no
//!    SMPL counterpart: SMPL's chest takes the source chest's world orientation, so its local
//!    rotation carries the source's Spine2 and Chest turns together.
//! 3. Local rotations `G_t(parent)⁻¹ · G_t(b)` become the three hinge angles (intrinsic x-y-z).
//! 4. Root position: the source pelvis scaled by the leg-length ratio (SMPL hip→ankle / source
//!    hip→ankle), then shifted up or down once for the whole clip so that the lowest foot-box
//!    point of the clip's stance frames (10th percentile of the per-frame lowest point) lies on
//!    the floor.

use serde::Serialize;
use skillmimic_core::characters::skillmimic as skeleton;
use skillmimic_core::characters::smpl::{self, NUM_BODIES};
use skillmimic_core::math::{Quat, norm};

use crate::character_clip::CharacterClip;
use crate::clip::Clip;

/// What retargeting one clip measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SmplRetargetReport {
    pub name: String,
    pub frames: usize,
    /// Scale applied to the root trajectory (leg-length ratio).
    pub scale: f64,
    /// The constant height shift of the root (m).
    pub ground_shift: f64,
    /// Mean and largest |lowest foot point| (m) over the stance frames after the shift.
    pub foot_height_error_mean: f64,
    pub foot_height_error_max: f64,
}

/// The source body of each SMPL body.
fn source_bodies() -> [usize; NUM_BODIES] {
    std::array::from_fn(|b| {
        let name = match smpl::body_names()[b] {
            "L_Hand" => "L_Middle1",
            "R_Hand" => "R_Middle1",
            other => other,
        };
        skeleton::body_index(name).expect("every SMPL body has a source body")
    })
}

fn leg_length(offsets: [[f64; 3]; 2]) -> f64 {
    norm(offsets[0]) + norm(offsets[1])
}

/// Retarget `clip` (SkillMimic skeleton) onto the SMPL humanoid.
pub fn retarget_to_smpl(clip: &Clip) -> (CharacterClip, SmplRetargetReport) {
    let spec = smpl::spec();
    let src = source_bodies();
    let p_inv = smpl::upright().conj();
    let sk = |n: &str| skeleton::BODIES[skeleton::body_index(n).expect("skeleton body")].offset;
    let scale = leg_length([spec.bodies[2].offset, spec.bodies[3].offset])
        / leg_length([sk("L_Knee"), sk("L_Ankle")]);
    let mut frames = Vec::with_capacity(clip.num_frames);
    let mut lowest = Vec::with_capacity(clip.num_frames);
    for t in 0..clip.num_frames {
        let dof = clip.dof_at(t);
        let mut gs = [clip.root_quat_at(t); skeleton::NUM_BODIES];
        for b in 1..skeleton::NUM_BODIES {
            let p = skeleton::BODIES[b].parent.expect("parent");
            let r = skeleton::dof_range(b);
            let v = [dof[r.start] as f64, dof[r.start + 1] as f64, dof[r.start + 2] as f64];
            gs[b] = gs[p].mul(Quat::from_rotvec(v));
        }
        let gt: Vec<Quat> = (0..NUM_BODIES).map(|b| gs[src[b]].mul(p_inv).normalized()).collect();
        let mut q = vec![0.0; spec.num_dofs];
        for b in 1..NUM_BODIES {
            let parent = spec.bodies[b].parent.expect("parent");
            spec.set_local_rotation(b, gt[parent].conj().mul(gt[b]).normalized(), &mut q);
        }
        let r = clip.root_pos_at(t);
        let root = [scale * r[0], scale * r[1], scale * r[2]];
        let (pos, rot) = spec.forward_kinematics(root, gt[0], &q);
        lowest.push(spec.lowest_foot_box(&pos, &rot));
        frames.push((root, gt[0], q));
    }
    let mut sorted = lowest.clone();
    sorted.sort_by(f64::total_cmp);
    let shift = -sorted[sorted.len() / 10];
    let stance: Vec<f64> = lowest.iter().map(|z| z + shift).filter(|z| *z < 0.03).collect();
    for f in &mut frames {
        f.0[2] += shift;
    }
    let source = format!(
        "retargeted from {} (SkillMimic skeleton) by skillmimic retarget --to smpl",
        clip.source
    );
    let out = CharacterClip::from_frames(&spec, &clip.name, &source, clip.fps, &frames);
    let n = stance.len().max(1) as f64;
    let rep = SmplRetargetReport {
        name: clip.name.clone(),
        frames: clip.num_frames,
        scale,
        ground_shift: shift,
        foot_height_error_mean: stance.iter().map(|z| z.abs()).sum::<f64>() / n,
        foot_height_error_max: stance.iter().map(|z| z.abs()).fold(0.0, f64::max),
    };
    (out, rep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rest_pose_maps_onto_the_upright_t_pose_turned_like_the_source() {
        // the source's rest pose (all joints zero, the Y-up → Z-up root turn) becomes SMPL's rest
        // pose with zero hinge angles, facing where the source faces (−y)
        let rows = crate::testing::synthetic_rows(3);
        let mut c = Clip::from_rows("rest".into(), "test".into(), 1, 60.0, 3, &rows);
        c.dof_rot.fill(0.0);
        for t in 0..c.num_frames {
            let q = skeleton::upright().to_wxyz();
            c.root_rot[4 * t..4 * t + 4].copy_from_slice(&q.map(|x| x as f32));
        }
        let (out, rep) = retarget_to_smpl(&c);
        assert!(out.dof_pos.iter().all(|x| x.abs() < 1e-5), "{:?}", &out.dof_pos[..9]);
        let fwd = out.root_quat_at(0).rotate([1.0, 0.0, 0.0]);
        assert!((fwd[1] + 1.0).abs() < 1e-6, "faces -y: {fwd:?}");
        assert!(rep.scale > 0.8 && rep.scale < 1.2, "{}", rep.scale);
        assert!(rep.foot_height_error_max < 1e-6, "{rep:?}");
    }
}
