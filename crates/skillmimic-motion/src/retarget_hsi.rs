//! Retargeting clips of the SkillMimic skeleton onto the TokenHSI character by shared joints
//! (issue 16: BallPlay-M locomotion as style references of the TokenHSI tasks).
//!
//! Method (per frame, world frame, Z-up):
//! 1. Global orientations of the source bodies from the clip (root quaternion, exp-map chain).
//! 2. Each target body copies the world rotation of its source body *relative to the source's
//!    rest pose*: `G_t(b) = G_s(s) · A⁻¹ · Y⁻¹ · P(b)`, with `A` the source rest orientation (the
//!    skeleton's Y-up → Z-up turn, Rx(90°), facing −y), `Y` = Rz(90°) (turns the source's rest
//!    facing onto the character's +x) and `P(b)` the target body's orientation in the source's
//!    rest posture (a T-pose: the upper arms turned from hanging to horizontal, Rx(∓90°) for
//!    right/left; identity elsewhere). Shared joints: pelvis ← Pelvis, torso ← Chest (the
//!    accumulated spine), head ← Head, upper arms ← Shoulder, lower arms ← Elbow, thighs ← Hip,
//!    shins ← Knee, feet ← Ankle; collars, toes and fingers have no counterpart.
//! 3. Elbows: the source's are 3-DoF, the character's bend about y only. Each upper arm is
//!    twisted about its own axis so that the source forearm lies in the hinge plane, and the hinge
//!    angle points the forearm along the source's (`fit_elbow_hinge`), clamped to [−160°, 0°].
//! 4. Local rotations `G_t(parent)⁻¹ · G_t(b)`: intrinsic x-y-z hinge angles for the 3-DoF
//!    joints (three nested hinges), hinge angles for the elbows, each clamped into its joint's
//!    range (a hinge limit is a hard stop in the simulation; the report counts the clamps).
//! 5. Root position: the source pelvis scaled by the leg-length ratio (character hip→ankle /
//!    source hip→ankle), then lifted per frame so that the lowest foot-sole point touches the
//!    floor in the source's stance frames (its lowest foot within 3 cm of the clip's 10th
//!    percentile), interpolated linearly in between (flight phases keep their shape).
//!
//! The report measures what a user checks before training on a retarget: foot height error
//! over the source's stance frames and joint-limit violations of the character's per-axis limits.

use serde::Serialize;
use skillmimic_core::characters::skillmimic as skeleton;
use skillmimic_core::characters::tokenhsi::{self as hsi, BODIES, JointSpec, NUM_DOFS};
use skillmimic_core::math::{Quat, norm};

use crate::character_clip::CharacterClip;
use crate::clip::Clip;

/// Target body → source body name (None: no counterpart; the hands follow their forearms).
const MAP: [Option<&str>; hsi::NUM_BODIES] = [
    Some("Pelvis"),
    Some("Chest"),
    Some("Head"),
    Some("R_Shoulder"),
    Some("R_Elbow"),
    None,
    Some("L_Shoulder"),
    Some("L_Elbow"),
    None,
    Some("R_Hip"),
    Some("R_Knee"),
    Some("R_Ankle"),
    Some("L_Hip"),
    Some("L_Knee"),
    Some("L_Ankle"),
];

/// What retargeting one clip measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RetargetReport {
    pub name: String,
    pub frames: usize,
    /// Scale applied to the root trajectory (leg-length ratio).
    pub scale: f64,
    /// Mean |lowest foot-sole height| (m) over the source's stance frames that one constant
    /// root offset (the median of the per-frame lifts) would leave: how far the character's
    /// proportions move its feet off the floor before the per-frame correction.
    pub foot_height_error_mean: f64,
    /// Largest such error (m).
    pub foot_height_error_max: f64,
    /// Stance frames counted.
    pub stance_frames: usize,
    /// Hinges of the 3-DoF joints whose angle lies beyond the character's per-axis limit, summed
    /// over frames, clamped into the range in the written clip.
    pub limit_violations: usize,
    /// Elbow angles beyond [−160°, 0°] (summed over frames and both elbows), clamped into it in
    /// the written clip (a hinge's limit is a hard stop in the simulation).
    pub elbow_clamped: usize,
    /// Fraction of frames with at least one 3-DoF violation or elbow clamp.
    pub frames_with_violation: f64,
    /// Largest excess beyond a limit (rad), 3-DoF axes and elbows.
    pub max_violation: f64,
}

fn leg_length_source() -> f64 {
    let k = skeleton::body_index("L_Knee").expect("skeleton body");
    let a = skeleton::body_index("L_Ankle").expect("skeleton body");
    norm(skeleton::BODIES[k].offset) + norm(skeleton::BODIES[a].offset)
}

fn leg_length_target() -> f64 {
    norm(BODIES[13].offset) + norm(BODIES[14].offset)
}

/// The hinge angles (x, y, z) of the local rotation `q` that lie closest to the joint's ranges
/// (degrees): a rotation has two intrinsic x-y-z decompositions, (a, b, c) and
/// (a + π, π − b, c + π); the shoulders' and hips' y ranges reach beyond ±90°, where the second
/// one is the one inside the limits.
fn within_limits(q: Quat, range_deg: [[f64; 2]; 3]) -> [f64; 3] {
    use skillmimic_core::math::wrap_angle;
    let [a, b, c] = skillmimic_core::characters::intrinsic_xyz(q);
    let pi = std::f64::consts::PI;
    let other = [wrap_angle(a + pi), wrap_angle(pi - b), wrap_angle(c + pi)];
    let excess = |v: &[f64; 3]| -> f64 {
        (0..3)
            .map(|k| {
                let (lo, hi) = (range_deg[k][0].to_radians(), range_deg[k][1].to_radians());
                (lo - v[k]).max(v[k] - hi).max(0.0)
            })
            .sum()
    };
    if excess(&other) < excess(&[a, b, c]) { other } else { [a, b, c] }
}

/// Retarget `clip` (SkillMimic skeleton) onto the TokenHSI character.
pub fn retarget_to_hsi(clip: &Clip) -> (CharacterClip, RetargetReport) {
    let t_frames = clip.num_frames;
    let src_index: Vec<Option<usize>> = MAP
        .iter()
        .map(|m| m.map(|n| skeleton::body_index(n).expect("mapped skeleton body")))
        .collect();
    let a_inv = Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]).conj();
    let y_inv = Quat::about_z(std::f64::consts::FRAC_PI_2).conj();
    let tpose = |b: usize| match b {
        3..=5 => Quat::from_rotvec([-std::f64::consts::FRAC_PI_2, 0.0, 0.0]),
        6..=8 => Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]),
        _ => Quat::IDENTITY,
    };
    let scale = leg_length_target() / leg_length_source();
    let mut rep =
        RetargetReport { name: clip.name.clone(), frames: t_frames, scale, ..Default::default() };
    let mut out = CharacterClip {
        character: "tokenhsi".to_string(),
        num_dofs: NUM_DOFS,
        num_bodies: hsi::NUM_BODIES,
        name: clip.name.clone(),
        source: format!(
            "retargeted from {} (SkillMimic skeleton) by skillmimic retarget",
            clip.source
        ),
        fps: clip.fps,
        num_frames: t_frames,
        root_pos: Vec::with_capacity(3 * t_frames),
        root_rot: Vec::with_capacity(4 * t_frames),
        dof_pos: Vec::with_capacity(NUM_DOFS * t_frames),
        body_pos: Vec::with_capacity(3 * hsi::NUM_BODIES * t_frames),
    };
    let mut roots = Vec::with_capacity(t_frames);
    let character = hsi::spec();
    let mut soles = Vec::with_capacity(t_frames);
    let mut src_feet = Vec::with_capacity(t_frames);
    let wrist_src = [
        skeleton::body_index("R_Wrist").expect("skeleton body"),
        skeleton::body_index("L_Wrist").expect("skeleton body"),
    ];
    let feet_src: Vec<usize> = ["L_Ankle", "R_Ankle", "L_Toe", "R_Toe"]
        .iter()
        .map(|n| skeleton::body_index(n).expect("skeleton body"))
        .collect();
    let mut frames_bad = 0usize;
    for t in 0..t_frames {
        // source global rotations
        let dof = clip.dof_at(t);
        let mut gs = [clip.root_quat_at(t); skeleton::NUM_BODIES];
        for b in 1..skeleton::NUM_BODIES {
            let p = skeleton::BODIES[b].parent.expect("parent");
            let r = skeleton::dof_range(b);
            gs[b] = gs[p].mul(Quat::from_rotvec([
                dof[r.start] as f64,
                dof[r.start + 1] as f64,
                dof[r.start + 2] as f64,
            ]));
        }
        // target global rotations (bodies without a counterpart follow their parent's local rest)
        let mut gt = [Quat::IDENTITY; hsi::NUM_BODIES];
        for b in 0..hsi::NUM_BODIES {
            gt[b] = match src_index[b] {
                Some(s) => gs[s].mul(a_inv).mul(y_inv).mul(tpose(b)).normalized(),
                None => gt[BODIES[b].parent.expect("unmapped bodies have a parent")],
            };
        }
        for (upper, wrist) in [(3, wrist_src[0]), (6, wrist_src[1])] {
            let elbow = src_index[upper + 1].expect("mapped elbow");
            fit_elbow_hinge(&mut gt, upper, gs[elbow].rotate(skeleton::BODIES[wrist].offset));
        }
        // local joint coordinates
        let mut q = [0.0f64; NUM_DOFS];
        let mut k = 0;
        let mut bad_here = false;
        for b in 1..hsi::NUM_BODIES {
            let p = BODIES[b].parent.expect("parent");
            let mut local = gt[p].conj().mul(gt[b]).normalized();
            if local.w < 0.0 {
                local = local.neg();
            }
            match BODIES[b].joint {
                JointSpec::Triple { range_deg, .. } => {
                    let v = within_limits(local, range_deg);
                    for a in 0..3 {
                        let (lo, hi) = (range_deg[a][0].to_radians(), range_deg[a][1].to_radians());
                        let excess = (lo - v[a]).max(v[a] - hi);
                        if excess > 0.0 {
                            rep.limit_violations += 1;
                            rep.max_violation = rep.max_violation.max(excess);
                            bad_here = true;
                        }
                        q[k + a] = v[a].clamp(lo, hi);
                    }
                }
                JointSpec::HingeY { range_deg: [lo, hi], .. } => {
                    let angle = 2.0 * local.y.atan2(local.w);
                    let angle = skillmimic_core::math::wrap_angle(angle);
                    let (lo, hi) = (lo.to_radians(), hi.to_radians());
                    let excess = (lo - angle).max(angle - hi);
                    if excess > 0.0 {
                        rep.elbow_clamped += 1;
                        rep.max_violation = rep.max_violation.max(excess);
                        bad_here = true;
                    }
                    q[k] = angle.clamp(lo, hi);
                }
                _ => {}
            }
            k += BODIES[b].joint.dofs();
        }
        frames_bad += usize::from(bad_here);
        let src_root = clip.root_pos_at(t);
        let root = [scale * src_root[0], scale * src_root[1], scale * src_root[2]];
        let (pos, rot) = character.forward_kinematics(root, gt[0], &q);
        soles.push(character.lowest_foot_box(&pos, &rot));
        roots.push((root, gt[0], q));
        src_feet.push(
            feet_src.iter().map(|&b| clip.body_pos_at(t, b)[2]).fold(f64::INFINITY, f64::min),
        );
    }
    // stance frames: the source's lowest foot frame within 3 cm of its clip-wide 10th percentile
    let mut sorted = src_feet.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 10];
    let stance: Vec<bool> = src_feet.iter().map(|&z| z - floor < 0.03).collect();
    let lift = stance_lift(&soles, &stance);
    let median = {
        let mut l: Vec<f64> =
            stance.iter().zip(&lift).filter(|(s, _)| **s).map(|(_, l)| *l).collect();
        l.sort_by(f64::total_cmp);
        l.get(l.len() / 2).copied().unwrap_or(0.0)
    };
    let (mut sum, mut n) = (0.0, 0usize);
    for (t, (root, quat, q)) in roots.into_iter().enumerate() {
        let root = [root[0], root[1], root[2] + lift[t]];
        let (pos, _) = character.forward_kinematics(root, quat, &q);
        out.root_pos.extend(root.iter().map(|&x| x as f32));
        out.root_rot.extend(quat.to_wxyz().iter().map(|&x| x as f32));
        out.dof_pos.extend(q.iter().map(|&x| x as f32));
        out.body_pos.extend(pos.iter().flatten().map(|&x| x as f32));
        if stance[t] {
            // the foot height error a constant root offset would leave (the per-frame correction)
            let e = (soles[t] + median).abs();
            sum += e;
            n += 1;
            rep.foot_height_error_max = rep.foot_height_error_max.max(e);
        }
    }
    rep.stance_frames = n;
    rep.foot_height_error_mean = if n > 0 { sum / n as f64 } else { 0.0 };
    rep.frames_with_violation = frames_bad as f64 / t_frames.max(1) as f64;
    (out, rep)
}

/// Fit the 1-DoF elbow of the arm whose upper arm is body `upper` (its forearm `upper + 1`, hand
/// `upper + 2`) to the source forearm direction `forearm` (world): the source elbow has 3 DoF,
/// the character's bends about its y axis only. The upper arm is twisted about its own axis
/// (local z, which keeps its direction) so that the forearm lies in the hinge's x–z plane, bent
/// forwards; the hinge angle then points the forearm along the source's. A nearly straight arm
/// (the forearm within ~6° of the upper arm's axis) keeps the copied twist.
fn fit_elbow_hinge(gt: &mut [Quat; hsi::NUM_BODIES], upper: usize, forearm: [f64; 3]) {
    let mut f = gt[upper].conj().rotate(forearm);
    let n = norm(f);
    if n < 1e-9 {
        return;
    }
    f = [f[0] / n, f[1] / n, f[2] / n];
    if f[0].hypot(f[1]) > 0.1 {
        let phi = f[1].atan2(f[0]);
        gt[upper] = gt[upper].mul(Quat::about_z(phi)).normalized();
        f = Quat::about_z(-phi).rotate(f);
    }
    // Ry(α) turns the rest forearm (−z) into (−sin α, 0, −cos α)
    let alpha = (-f[0]).atan2(-f[2]);
    gt[upper + 1] = gt[upper].mul(Quat::from_rotvec([0.0, alpha, 0.0])).normalized();
    gt[upper + 2] = gt[upper + 1];
}

/// Per-frame root lift that puts the lowest foot-sole point on the floor in stance frames,
/// linearly interpolated across the other frames (held at the ends); a clip without stance
/// frames gets one constant lift that makes its lowest sole touch the floor.
fn stance_lift(soles: &[f64], stance: &[bool]) -> Vec<f64> {
    let keys: Vec<usize> = (0..soles.len()).filter(|&t| stance[t]).collect();
    if keys.is_empty() {
        let m = soles.iter().copied().fold(f64::INFINITY, f64::min);
        return vec![-m; soles.len()];
    }
    (0..soles.len())
        .map(|t| {
            let after = keys.partition_point(|&k| k < t);
            match (after.checked_sub(1).map(|i| keys[i]), keys.get(after).copied()) {
                (_, Some(k)) if k == t => -soles[t],
                (Some(a), Some(b)) => {
                    let f = (t - a) as f64 / (b - a) as f64;
                    -(soles[a] + f * (soles[b] - soles[a]))
                }
                (Some(a), None) => -soles[a],
                (None, Some(b)) => -soles[b],
                (None, None) => 0.0,
            }
        })
        .collect()
}
