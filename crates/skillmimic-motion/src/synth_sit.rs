//! Procedural stand-to-sit clips of the TokenHSI character (issue 38: the sit task's reference
//! motion, `builtin:sit`; its reference starts are placed against the episode's seat by the
//! environment's `reference_init`).
//!
//! Pure kinematics of [`tokenhsi::spec`]: 0.5 s standing in the rest pose, 1.5 s sitting down
//! (progress `s` a smoothstep of time), 1.0 s seated; 30 frames/s, heading +x throughout.
//! * Both feet stay planted: the root follows from the right foot's frame kept at its rest-pose
//!   place (as in [`crate::synth_walk`]); the left leg's hip and knee pitch are solved (Newton,
//!   2 × 2, [`crate::synth_walk`]'s `plant_leg`) so that its foot frame keeps its rest-pose place
//!   too (the legs' offsets differ slightly, so the same angles would not).
//! * Legs: hip pitch `s · H`, knee `−s · H`, so the shins stay vertical and the pelvis moves back
//!   and down; `H` (< 0, thigh forward) is solved (bisection) so that the seated pelvis sphere
//!   (radius 0.0942 m) rests on the seat's top: root height = seat height + 0.0942 m. The ankles
//!   keep the feet flat.
//! * Trunk: the abdomen pitches forward by 0.5 rad · sin(π s) + 0.15 rad · s (a forward lean while
//!   lowering, a slight one when seated); the arms reach forward with it (shoulders −0.4 rad ·
//!   sin(π s)), elbows bent 0.35 rad + 0.3 rad · s.
//! * The seat: its top centre is under the seated root, facing +x (the character's heading),
//!   [`SitClip::seat_top`].

use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::{Quat, Vec3};

use crate::character_clip::CharacterClip;
use crate::synth_walk::{
    ABDOMEN, FPS, L_ELBOW, L_SHOULDER, LEFT, R_ELBOW, R_SHOULDER, RIGHT, bisect, foot_in_root,
    plant_leg, set_leg,
};

/// Radius of the pelvis sphere (m, the asset's).
pub const PELVIS_RADIUS: f64 = 0.0942;
/// Seat heights (m) the clip model accepts.
pub const SEAT_RANGE: [f64; 2] = [0.3, 0.6];
const STAND_S: f64 = 0.5;
const DOWN_S: f64 = 1.5;
const SEATED_S: f64 = 1.0;

/// A stand-to-sit clip and its seat.
#[derive(Clone, Debug, PartialEq)]
pub struct SitClip {
    pub clip: CharacterClip,
    /// World centre of the seat's top face (m); the seat faces +x.
    pub seat_top: Vec3,
    /// The solved hip pitch when seated (rad, negative = thigh forward).
    pub hip_seated: f64,
}

/// The clip for a seat whose top is `seat_height` m above the floor. Errors name the parameter.
pub fn sit(name: &str, seat_height: f64) -> Result<SitClip, String> {
    if !(SEAT_RANGE[0]..=SEAT_RANGE[1]).contains(&seat_height) {
        return Err(format!("seat_height is {seat_height} m; expected {SEAT_RANGE:?}"));
    }
    let spec = tokenhsi::spec();
    let rest = spec.forward_kinematics(spec.root_pos, Quat::IDENTITY, &vec![0.0; spec.num_dofs]).0;
    let anchor = rest[RIGHT.foot];
    let root_z = |hip: f64| anchor[2] - foot_in_root(&spec, &RIGHT, hip, -hip)[2];
    let hip_seated = bisect(-1.9, 0.0, |h| root_z(h) - (seat_height + PELVIS_RADIUS));
    let n = ((STAND_S + DOWN_S + SEATED_S) * FPS).round() as usize + 1;
    let mut frames = Vec::with_capacity(n);
    for f in 0..n {
        let t = f as f64 / FPS;
        let u = ((t - STAND_S) / DOWN_S).clamp(0.0, 1.0);
        let s = u * u * (3.0 - 2.0 * u);
        let bump = (std::f64::consts::PI * s).sin();
        let mut dof = vec![0.0; spec.num_dofs];
        let hip = s * hip_seated;
        set_leg(&mut dof, &RIGHT, hip, -hip);
        let rel = foot_in_root(&spec, &RIGHT, hip, -hip);
        let root = [anchor[0] - rel[0], anchor[1] - rel[1], anchor[2] - rel[2]];
        let left = [rest[LEFT.foot][0] - root[0], rest[LEFT.foot][2] - root[2]];
        let (hl, kl) = plant_leg(&spec, &LEFT, left, (hip, -hip));
        set_leg(&mut dof, &LEFT, hl, kl);
        dof[ABDOMEN + 1] = 0.5 * bump + 0.15 * s; // pitch, forward
        for (shoulder, elbow) in [(R_SHOULDER, R_ELBOW), (L_SHOULDER, L_ELBOW)] {
            dof[shoulder + 1] = -0.4 * bump;
            dof[elbow] = -(0.35 + 0.3 * s);
        }
        frames.push((root, Quat::IDENTITY, dof));
    }
    let seated = frames[n - 1].0;
    let source = format!(
        "procedural stand-to-sit (skillmimic_motion::synth_sit): seat {seat_height} m, hip {hip_seated:.4} rad"
    );
    Ok(SitClip {
        clip: CharacterClip::from_frames(&spec, name, &source, FPS, &frames),
        seat_top: [seated[0], seated[1], seat_height],
        hip_seated,
    })
}

/// Seat heights (m) of the built-in sit set: 0.35 to 0.55 m in steps of 0.025 m (TokenHSI's
/// `env.hsi.sit.seat_height` default range), so that a seat is within 0.0125 m of one of them.
pub const SEAT_GRID: [f64; 9] = [0.35, 0.375, 0.4, 0.425, 0.45, 0.475, 0.5, 0.525, 0.55];

/// The built-in sit set: one clip per height of [`SEAT_GRID`], named `synth_sit_<height>`.
pub fn tokenhsi_sits() -> Vec<SitClip> {
    SEAT_GRID
        .iter()
        .map(|&h| sit(&format!("synth_sit_{h}"), h).expect("the grid's heights are valid"))
        .collect()
}
