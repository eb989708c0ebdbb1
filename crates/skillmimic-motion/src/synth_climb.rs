//! Procedural step-up clips of the TokenHSI character: climbing onto a platform (issue 38: the
//! climb task's reference motion, `builtin:climb`; the released code uses AMASS / SAMP climbing,
//! which cannot be redistributed). Reference starts are placed against the episode's platform by
//! the environment's `reference_init`.
//!
//! Pure kinematics of [`tokenhsi::spec`], heading +x throughout, 30 frames/s. The platform's
//! front face is at x = [`FACE_X`] (the character stands at the origin in its rest pose, its toes
//! about 0.2 m from the face), its top `h` m above the floor. Phases:
//! 1. [`STAND_S`] s standing in the rest pose.
//! 2. [`LEAD_S`] s: the right foot steps up. Its frame (kept flat) rises by `h` along a smoothstep
//!    over the first 60 % of the phase plus a bump of [`CLEARANCE`] m (sin π u), and moves
//!    forward along a smoothstep over the last 75 %, so that it is above the top before its toe
//!    passes the face; it lands where its rest-pose place is relative to the final root. The
//!    root dips [`DIP`] m (smoothstep), the left foot staying planted.
//! 3. [`RISE_S`] s: the root moves along a smoothstep from its rest place to the final root
//!    (`h` higher, [`FINAL_X`] forward) over the planted right foot. The left foot stays on the
//!    floor until its leg would have to stretch beyond [`REACH`] of its full length, then swings
//!    onto the top in [`TRAIL_S`] s (the same path shape as the right foot's, pulled towards the
//!    hip wherever it would stretch the leg beyond its length), to its rest-pose place relative
//!    to the final root.
//! 4. [`END_S`] s standing on the platform in the rest pose.
//!
//! Legs are solved in their sagittal planes (hip and knee pitch, Newton; the ankles keep the
//! feet flat, the hips' other hinges 0); the trunk leans forward by 0.35 rad · sin(π p) over
//! phases 2–3 (p their progress), the elbows bent 0.35 rad. The platform: [`ClimbClip::edge`],
//! the centre of its front face's top edge; the platform lies beyond it in +x.

use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::{Quat, Vec3};

use crate::character_clip::CharacterClip;
use crate::synth_walk::{
    ABDOMEN, FPS, L_ELBOW, LEFT, Leg, R_ELBOW, RIGHT, foot_in_root, plant_leg, set_leg,
};

/// x of the platform's front face (m) in the clip's frame (the root starts at x = 0).
pub const FACE_X: f64 = 0.35;
/// x of the final root (m): its feet, in their rest-pose places below it, stand 0.14 m or more
/// beyond the face.
pub const FINAL_X: f64 = 0.56;
/// Extra lift (m) of a stepping foot's path over the top.
pub const CLEARANCE: f64 = 0.04;
/// How far (m) the root dips (both knees bending) while the leading foot steps up, so that the
/// trailing leg can push through the start of the rise.
pub const DIP: f64 = 0.03;
/// Share of its full length beyond which the trailing leg lets go of the floor.
pub const REACH: f64 = 0.985;
pub const STAND_S: f64 = 0.4;
pub const LEAD_S: f64 = 0.8;
pub const RISE_S: f64 = 1.0;
pub const TRAIL_S: f64 = 0.6;
pub const END_S: f64 = 0.5;
/// Platform heights (m) the clip model accepts.
pub const HEIGHT_RANGE: [f64; 2] = [0.1, 0.6];

/// A step-up clip and its platform.
#[derive(Clone, Debug, PartialEq)]
pub struct ClimbClip {
    pub clip: CharacterClip,
    /// Centre of the platform's front top edge in the clip's frame (m; its z is the platform's
    /// height); the platform lies beyond it in +x.
    pub edge: Vec3,
}

fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// A stepping foot's frame at progress `u` ∈ [0, 1] from `from` to `to` (x, z; m, world).
fn step_path(from: [f64; 2], to: [f64; 2], u: f64) -> [f64; 2] {
    let lift = smoothstep(u / 0.6)
        + CLEARANCE / (to[1] - from[1]).max(1e-9)
            * (std::f64::consts::PI * u.clamp(0.0, 1.0)).sin();
    [
        from[0] + (to[0] - from[0]) * smoothstep((u - 0.25) / 0.75),
        from[1] + (to[1] - from[1]) * lift,
    ]
}

/// The clip for a platform `height` m high. Errors name the parameter and an unreachable pose.
pub fn climb(name: &str, height: f64) -> Result<ClimbClip, String> {
    if !(HEIGHT_RANGE[0]..=HEIGHT_RANGE[1]).contains(&height) {
        return Err(format!("height is {height} m; expected {HEIGHT_RANGE:?}"));
    }
    let spec = tokenhsi::spec();
    let zero = vec![0.0; spec.num_dofs];
    let r0 = spec.root_pos;
    let rest = spec.forward_kinematics(r0, Quat::IDENTITY, &zero).0;
    let r1 = [FINAL_X, 0.0, r0[2] + height];
    // rest-pose feet relative to the root, and their places at the start and the end (x, z)
    let rel = |leg: &Leg| [rest[leg.foot][0] - r0[0], rest[leg.foot][2] - r0[2]];
    let start = |leg: &Leg| [rest[leg.foot][0], rest[leg.foot][2]];
    let end = |leg: &Leg| [r1[0] + rel(leg)[0], r1[2] + rel(leg)[1]];
    // the leg's full length: hip to foot frame with the knee straight
    let full = |leg: &Leg| {
        let p = spec.forward_kinematics([0.0; 3], Quat::IDENTITY, &zero).0;
        let hip = p[leg.foot - 2];
        let f = p[leg.foot];
        ((f[0] - hip[0]).powi(2) + (f[2] - hip[2]).powi(2)).sqrt()
    };
    let hip_of = |leg: &Leg, root: [f64; 3]| {
        let p = spec.forward_kinematics(root, Quat::IDENTITY, &zero).0[leg.foot - 2];
        [p[0], p[2]]
    };
    // the root: dipping during the lead step (progress `lead`), then rising (progress `u`)
    let root_at = |lead: f64, u: f64| {
        let s = smoothstep(u);
        let z0 = r0[2] - DIP * smoothstep(lead);
        [r0[0] + (r1[0] - r0[0]) * s, 0.0, z0 + (r1[2] - z0) * s]
    };
    // when the trailing (left) leg lets go: the first rise progress at which it would overreach
    let reach = REACH * full(&LEFT);
    let overreach = |u: f64| {
        let (h, f) = (hip_of(&LEFT, root_at(1.0, u)), start(&LEFT));
        ((f[0] - h[0]).powi(2) + (f[1] - h[1]).powi(2)).sqrt() > reach
    };
    // phases in whole frames (no rounding at their boundaries)
    let frames_of = |s: f64| (s * FPS).round() as usize;
    let (f_lead, n_lead, n_rise) = (frames_of(STAND_S), frames_of(LEAD_S), frames_of(RISE_S));
    let f_rise = f_lead + n_lead;
    let lift_k = (0..=n_rise).find(|&k| overreach(k as f64 / n_rise as f64)).unwrap_or(n_rise);
    let f_lift = f_rise + lift_k;
    let n_trail = frames_of(TRAIL_S);
    let f_end = (f_rise + n_rise).max(f_lift + n_trail);
    let n = f_end + frames_of(END_S) + 1;
    let mut frames = Vec::with_capacity(n);
    let (mut seed_r, mut seed_l) = ((0.0, 0.0), (0.0, 0.0));
    let progress = |f: usize, from: usize, len: usize| (f as f64 - from as f64) / len as f64;
    for f in 0..n {
        let root = root_at(progress(f, f_lead, n_lead), progress(f, f_rise, n_rise));
        let right = if f < f_rise {
            step_path(start(&RIGHT), end(&RIGHT), progress(f, f_lead, n_lead))
        } else {
            end(&RIGHT)
        };
        let left = if f < f_lift {
            start(&LEFT)
        } else {
            // the swinging foot trails within reach: pulled towards the hip where the path
            // would stretch the leg beyond its length (early in the swing, while the root still
            // rises fast)
            let p = step_path(start(&LEFT), end(&LEFT), progress(f, f_lift, n_trail));
            let h = hip_of(&LEFT, root);
            let d = (p[0] - h[0]).hypot(p[1] - h[1]);
            let limit = full(&LEFT) - 1e-4;
            let s = if f >= f_end { 1.0 } else { (limit / d).min(1.0) };
            [h[0] + (p[0] - h[0]) * s, h[1] + (p[1] - h[1]) * s]
        };
        let mut dof = vec![0.0; spec.num_dofs];
        for (leg, target, seed) in [(&RIGHT, right, &mut seed_r), (&LEFT, left, &mut seed_l)] {
            let goal = [target[0] - root[0], target[1] - root[2]];
            *seed = plant_leg(&spec, leg, goal, *seed);
            let got = foot_in_root(&spec, leg, seed.0, seed.1);
            let miss = (got[0] - goal[0]).hypot(got[2] - goal[1]);
            if miss > 1e-6 {
                return Err(format!(
                    "height {height} m: frame {f}, foot {} cannot reach its place (miss {miss:.4} m)",
                    leg.foot
                ));
            }
            set_leg(&mut dof, leg, seed.0, seed.1);
        }
        let p = progress(f, f_lead, f_end - f_lead).clamp(0.0, 1.0);
        dof[ABDOMEN + 1] = 0.35 * (std::f64::consts::PI * p).sin();
        dof[R_ELBOW] = -0.35;
        dof[L_ELBOW] = -0.35;
        frames.push((root, Quat::IDENTITY, dof));
    }
    let source = format!(
        "procedural step-up (skillmimic_motion::synth_climb): platform {height} m, front face at \
         x = {FACE_X} m, trailing foot off the floor at frame {f_lift}"
    );
    Ok(ClimbClip {
        clip: CharacterClip::from_frames(&spec, name, &source, FPS, &frames),
        edge: [FACE_X, 0.0, height],
    })
}

/// Platform heights (m) of the built-in climb set: 0.2 to 0.6 m in steps of 0.025 m (the climb
/// task's `env.hsi.climb.height` default range), so that a platform is within 0.0125 m of one.
pub const HEIGHT_GRID: [f64; 17] = [
    0.2, 0.225, 0.25, 0.275, 0.3, 0.325, 0.35, 0.375, 0.4, 0.425, 0.45, 0.475, 0.5, 0.525, 0.55,
    0.575, 0.6,
];

/// The built-in climb set: one clip per height of [`HEIGHT_GRID`], named `synth_climb_<height>`.
pub fn tokenhsi_climbs() -> Vec<ClimbClip> {
    HEIGHT_GRID
        .iter()
        .map(|&h| climb(&format!("synth_climb_{h}"), h).expect("the grid's heights are valid"))
        .collect()
}
