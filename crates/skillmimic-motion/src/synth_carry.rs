//! Procedural box-carrying walks of the TokenHSI character (issue 38: the carry task's reference
//! motion, `builtin:carry`; the released code uses OMOMO / AMASS carrying clips, which cannot be
//! redistributed). The released carry task's references are pick-up, carry-with and put-down
//! clips; these are carry-with clips only (no pick-up or put-down yet).
//!
//! Pure kinematics of [`tokenhsi::spec`]: the legs, root and timing are those of the walk with the
//! same [`WalkParams`] ([`crate::synth_walk`]), frame for frame; the arms hold a cube of side `s`
//! in front of the body instead of swinging:
//! * The box's centre is fixed in the root's frame (x forward, y left, z up; the trunk stays
//!   upright in the walks, so the root's frame is the torso's): x = [`BOX_GAP`] + s/2 (its back
//!   face [`BOX_GAP`] in front of the root, clear of the torso's spheres), y = 0, z =
//!   [`BOX_HEIGHT`] above the root.
//! * Each hand's centre is on the box's side face, at the box's centre height and depth, sunk
//!   [`GRIP_DEPTH`] into the face (y = ±(s/2 + hand radius − [`GRIP_DEPTH`])), so that the mean
//!   of the hands is the box's centre (the carry reward's handheld term is at its maximum).
//! * The arm angles reaching there (shoulder x and y hinges and the elbow; the shoulder's twist
//!   z stays 0) are solved once per clip by Newton's method with a finite-difference Jacobian;
//!   a box that the arms cannot reach with the elbow bent is refused ([`BOX_RANGE`]).

use skillmimic_core::characters::{CharacterSpec, tokenhsi};
use skillmimic_core::math::{Quat, Vec3};

use crate::character_clip::CharacterClip;
use crate::synth_walk::{FPS, L_ELBOW, L_SHOULDER, R_ELBOW, R_SHOULDER, WalkParams, walk_frames};

/// Gap (m) between the root and the box's back face, forward.
pub const BOX_GAP: f64 = 0.14;
/// Height (m) of the box's centre above the root.
pub const BOX_HEIGHT: f64 = 0.2;
/// How far (m) each hand's centre is sunk into the box's side face (a firm grip).
pub const GRIP_DEPTH: f64 = 0.01;
/// Side lengths (m) of the boxes the arms hold this way (the released cubes are 0.2–0.6 m). At
/// 0.5 m the upper arms already pass 4 mm into the box's top behind the hands, and a box held
/// lower is out of the arms' reach at this depth (`tests/synth_carry.rs` checks that nothing but
/// the hands and forearms touches it).
pub const BOX_RANGE: [f64; 2] = [0.2, 0.45];
/// The hand sphere's radius (m, the asset's).
const HAND_RADIUS: f64 = 0.04;

/// A carrying walk and its box.
#[derive(Clone, Debug, PartialEq)]
pub struct CarryClip {
    pub clip: CharacterClip,
    /// Side length of the carried cube (m).
    pub side: f64,
    /// The cube's centre in the root's frame (m; x forward, y left, z up), fixed for the clip.
    pub box_in_root: Vec3,
}

/// The hand targets (right, left) in the root's frame for a cube of side `side`.
pub fn hand_targets(side: f64) -> [Vec3; 2] {
    let (x, z) = (BOX_GAP + 0.5 * side, BOX_HEIGHT);
    let y = 0.5 * side + HAND_RADIUS - GRIP_DEPTH;
    [[x, -y, z], [x, y, z]]
}

/// The arm dofs (shoulder x, shoulder y, elbow) per arm (right, left) that put the hands at
/// [`hand_targets`] with the rest of the body in its rest pose. Errors when out of reach.
pub fn hold_pose(spec: &CharacterSpec, side: f64) -> Result<[[f64; 3]; 2], String> {
    if !(BOX_RANGE[0]..=BOX_RANGE[1]).contains(&side) {
        return Err(format!("box side is {side} m; expected {BOX_RANGE:?}"));
    }
    let targets = hand_targets(side);
    let mut out = [[0.0; 3]; 2];
    for (arm, (shoulder, elbow, side_sign)) in
        [(R_SHOULDER, R_ELBOW, -1.0), (L_SHOULDER, L_ELBOW, 1.0)].into_iter().enumerate()
    {
        let hand = tokenhsi::HANDS[arm];
        let at = |q: [f64; 3]| -> Vec3 {
            let mut dof = vec![0.0; spec.num_dofs];
            (dof[shoulder], dof[shoulder + 1], dof[elbow]) = (q[0], q[1], q[2]);
            let p = spec.forward_kinematics([0.0; 3], Quat::IDENTITY, &dof).0[hand];
            [p[0] - targets[arm][0], p[1] - targets[arm][1], p[2] - targets[arm][2]]
        };
        // forward, slightly adducted, elbow bent: the solution with the elbow down and out
        let mut q = [-0.3 * side_sign, -0.9, -1.0];
        for _ in 0..50 {
            let r = at(q);
            if r.iter().all(|v| v.abs() < 1e-10) {
                break;
            }
            let e = 1e-6;
            let mut j = [[0.0; 3]; 3];
            for c in 0..3 {
                let mut qc = q;
                qc[c] += e;
                let rc = at(qc);
                for row in 0..3 {
                    j[row][c] = (rc[row] - r[row]) / e;
                }
            }
            let Some(d) = solve3(j, r) else { break };
            for c in 0..3 {
                q[c] -= d[c].clamp(-0.3, 0.3);
            }
        }
        let r = at(q);
        let miss = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        // the elbow must stay bent (an extended arm is the reach's edge) and within its range
        if miss > 1e-6 || !(q[2] < -0.2 && q[2] > -160f64.to_radians()) {
            return Err(format!(
                "box side {side} m: the hands cannot hold it (miss {miss:.4} m, elbow {:.3} rad)",
                q[2]
            ));
        }
        out[arm] = q;
    }
    Ok(out)
}

/// Solve `j · d = r` (3 × 3, Cramer's rule); `None` when singular.
fn solve3(j: [[f64; 3]; 3], r: Vec3) -> Option<Vec3> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(j);
    if d.abs() < 1e-12 {
        return None;
    }
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mut m = j;
        for row in 0..3 {
            m[row][c] = r[row];
        }
        *o = det(m) / d;
    }
    Some(out)
}

/// One carrying walk named `name`: the walk `p` with the arms holding a cube of side `side`.
/// Errors name the parameter.
pub fn carry(name: &str, p: WalkParams, side: f64) -> Result<CarryClip, String> {
    let spec = tokenhsi::spec();
    let hold = hold_pose(&spec, side)?;
    let (mut frames, ts, alpha) = walk_frames(p)?;
    for (_, _, dof) in &mut frames {
        for (q, (shoulder, elbow)) in
            hold.iter().zip([(R_SHOULDER, R_ELBOW), (L_SHOULDER, L_ELBOW)])
        {
            (dof[shoulder], dof[shoulder + 1], dof[shoulder + 2], dof[elbow]) =
                (q[0], q[1], 0.0, q[2]);
        }
    }
    let source = format!(
        "procedural carrying walk (skillmimic_motion::synth_carry): {} m/s, turn {} rad/s, \
         step {ts:.4} s, hip amplitude {alpha:.4} rad, cube {side} m",
        p.speed, p.yaw_rate
    );
    let clip = CharacterClip::from_frames(&spec, name, &source, FPS, &frames);
    Ok(CarryClip { clip, side, box_in_root: [BOX_GAP + 0.5 * side, 0.0, BOX_HEIGHT] })
}

/// The built-in carrying set: the released base cube (0.4 m) carried at 0.7 and 1.0 m/s straight
/// and at 1.0 m/s turning left and right at 0.5 rad/s, and cubes of 0.3 and 0.45 m at 1.0 m/s,
/// 6 s each. Name, walk, cube side.
pub const CARRIES: [(&str, WalkParams, f64); 6] = [
    ("synth_carry_0.4_0.7", WalkParams { speed: 0.7, yaw_rate: 0.0, seconds: 6.0 }, 0.4),
    ("synth_carry_0.4_1.0", WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 6.0 }, 0.4),
    ("synth_carry_0.4_1.0_left", WalkParams { speed: 1.0, yaw_rate: 0.5, seconds: 6.0 }, 0.4),
    ("synth_carry_0.4_1.0_right", WalkParams { speed: 1.0, yaw_rate: -0.5, seconds: 6.0 }, 0.4),
    ("synth_carry_0.3_1.0", WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 6.0 }, 0.3),
    ("synth_carry_0.45_1.0", WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 6.0 }, 0.45),
];

/// The clips of [`CARRIES`], in that order.
pub fn tokenhsi_carries() -> Vec<CarryClip> {
    CARRIES
        .iter()
        .map(|(name, p, s)| carry(name, *p, *s).expect("the built-in parameters are valid"))
        .collect()
}
