//! Procedural walking clips of the TokenHSI character: reference motions the project can ship
//! for the follow task's reference-state initialisation and style prior (issue 38; the released
//! code uses AMASS walks, which cannot be redistributed).
//!
//! A clip is pure kinematics of [`tokenhsi::spec`] (no physics, no learned model), made as
//! follows:
//! * **Gait cycle.** A stride of two steps of `T_s` seconds each; each leg is in stance for one
//!   step (phase ψ ∈ [0, ½)) and swings for the next (ψ ∈ [½, 1)); there is no double support.
//!   Step time `T_s = 0.55 s · (1 m/s ÷ v)^0.4` (about 109 steps/min at 1 m/s, fewer when slower).
//! * **Hip pitch** (the hip's y hinge, negative = thigh forward) runs linearly from `n − α` at
//!   heel strike to the toe-off pitch `a` during stance, so the pelvis moves over the planted
//!   foot at a nearly constant rate, and back along a cubic Hermite during swing whose end slopes
//!   equal the stance rate (no kink at strike or toe-off). `n` is the pitch at which the leg
//!   reaches lowest (its axis vertical; about −0.2 rad, since the knee is bent and the ankle sits
//!   behind the knee); `a` ≈ `n + α` is solved (bisection) so that the foot frame is as far below
//!   the hip at toe-off as at strike: at each switch both feet stand on the floor. α is solved
//!   (bisection) so that the mean speed over a stride is `v`.
//! * **Knee** (y hinge, positive = flexion): 8° in stance, plus 45° · sin²(π u^0.66) in swing
//!   (u ∈ [0, 1) the swing's progress; the flexion peaks at u ≈ 0.35, early as in human gait).
//! * **Ankle** pitch = −(hip + knee): the foot stays parallel to the floor (hip, knee and ankle
//!   pitch about parallel axes; their x and z hinges stay 0), within the asset's range less 1°
//!   (early in the swing the toe may point down a few degrees).
//! * **Arms** swing opposite to the legs: shoulder pitch 0.8 × the other leg's hip pitch,
//!   abducted 0.1 rad, the elbow bent 0.35 rad plus 0.6 × the shoulder's forward swing. Trunk,
//!   neck and pelvis stay upright (no pelvis twist or tilt: a simplification).
//! * **Root.** Heading `ψ(t) = ω t` (ω > 0 turns left, about +z); the position follows from the
//!   planted stance foot: the stance foot's frame keeps its world position for the whole step
//!   (the root is placed so that forward kinematics puts it there) at the height its frame has in
//!   the rest pose standing on the floor, so the stance foot's box touches the floor as in the
//!   rest pose. Under a turn the planted foot pivots about its frame (it turns with the body).
//!   At a switch the new stance foot is planted where it is.
//!
//! The clips start at a right heel strike with the root over the origin, heading +x, 30 frames/s.
//! Everything is deterministic (no random numbers). `tests/synth_walk.rs` checks the contacts,
//! the speed and turn rate, the joint limits and the floor.

use skillmimic_core::characters::{CharacterSpec, tokenhsi};
use skillmimic_core::math::{Quat, Vec3};

use crate::character_clip::CharacterClip;

/// Frames per second of the synthesised clips (TokenHSI's policy rate).
pub const FPS: f64 = 30.0;
/// Knee flexion in stance (rad).
const KNEE_STANCE: f64 = 8.0 * std::f64::consts::PI / 180.0;
/// Extra knee flexion at the swing's peak (rad).
const KNEE_SWING: f64 = 45.0 * std::f64::consts::PI / 180.0;
/// Exponent of the swing's time warp `u^p` under the knee's bump: the flexion peaks at
/// u = 0.5^(1/p) ≈ 0.35, early in the swing as in human gait (ln 0.5 / ln 0.35).
const KNEE_PEAK_WARP: f64 = 0.660_2;
/// Shoulder pitch per unit of the opposite hip's pitch.
const ARM_GAIN: f64 = 0.8;
/// Shoulder abduction (rad, away from the body).
const ARM_ABDUCTION: f64 = 0.1;
/// Elbow flexion at rest (rad; the elbow hinge is negative when flexed).
const ELBOW_BASE: f64 = 0.35;
/// Largest ankle pitch (rad): the asset's ±55° less 1°. The foot stays flat while this suffices
/// (always in stance); early in the swing, when the knee is bent most behind an extended hip, the
/// foot's toe then points down by up to a few degrees.
const ANKLE_PITCH_MAX: f64 = 54.0 * std::f64::consts::PI / 180.0;
/// Speeds (m/s) the gait model accepts.
pub const SPEED_RANGE: [f64; 2] = [0.3, 2.0];

/// One walking clip's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkParams {
    /// Mean speed over whole strides (m/s), within [`SPEED_RANGE`].
    pub speed: f64,
    /// Turn rate about +z (rad/s; positive = left).
    pub yaw_rate: f64,
    /// Duration (s), > 0; the clip has `round(seconds · 30) + 1` frames.
    pub seconds: f64,
}

/// The built-in walking set: 0.7, 1.0 and 1.3 m/s straight ahead, and 1.0 m/s turning left and
/// right at 0.5 rad/s, 6 s each (the follow task's paths run at 0.5–1.5 m/s). Name, parameters.
pub const WALKS: [(&str, WalkParams); 5] = [
    ("synth_walk_0.7", WalkParams { speed: 0.7, yaw_rate: 0.0, seconds: 6.0 }),
    ("synth_walk_1.0", WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 6.0 }),
    ("synth_walk_1.3", WalkParams { speed: 1.3, yaw_rate: 0.0, seconds: 6.0 }),
    ("synth_walk_1.0_left", WalkParams { speed: 1.0, yaw_rate: 0.5, seconds: 6.0 }),
    ("synth_walk_1.0_right", WalkParams { speed: 1.0, yaw_rate: -0.5, seconds: 6.0 }),
];

/// The clips of [`WALKS`], in that order.
pub fn tokenhsi_walks() -> Vec<CharacterClip> {
    WALKS
        .iter()
        .map(|(name, p)| walk(name, *p).expect("the built-in parameters are valid"))
        .collect()
}

/// Step time (s) at speed `v` (m/s).
pub fn step_time(v: f64) -> f64 {
    0.55 * (1.0 / v).powf(0.4)
}

/// The legs: (hip, knee, ankle) first dof and the foot body.
pub(crate) struct Leg {
    pub(crate) hip: usize,
    pub(crate) knee: usize,
    pub(crate) ankle: usize,
    pub(crate) foot: usize,
}

pub(crate) const RIGHT: Leg = Leg { hip: 14, knee: 17, ankle: 20, foot: 11 };
pub(crate) const LEFT: Leg = Leg { hip: 23, knee: 26, ankle: 29, foot: 14 };
/// First dof of the abdomen (x, y, z hinges; y = pitch, positive = forward).
pub(crate) const ABDOMEN: usize = 0;
pub(crate) const R_SHOULDER: usize = 6;
pub(crate) const R_ELBOW: usize = 9;
pub(crate) const L_SHOULDER: usize = 10;
pub(crate) const L_ELBOW: usize = 13;

/// The gait's angles for one leg: strike hip pitch `b` = −α, toe-off pitch `a`.
#[derive(Clone, Copy)]
struct Swing {
    b: f64,
    a: f64,
}

impl Swing {
    /// (hip pitch, knee flexion) at leg phase `psi` ∈ [0, 1).
    fn at(self, psi: f64) -> (f64, f64) {
        if psi < 0.5 {
            (self.b + (self.a - self.b) * psi / 0.5, KNEE_STANCE)
        } else {
            let u = (psi - 0.5) / 0.5;
            let (u2, u3) = (u * u, u * u * u);
            let m = self.a - self.b;
            let hip = (2.0 * u3 - 3.0 * u2 + 1.0) * self.a
                + (u3 - 2.0 * u2 + u) * m
                + (-2.0 * u3 + 3.0 * u2) * self.b
                + (u3 - u2) * m;
            let s = (std::f64::consts::PI * u.powf(KNEE_PEAK_WARP)).sin();
            (hip, KNEE_STANCE + KNEE_SWING * s * s)
        }
    }
}

/// Write one leg's pitch angles into `dof` (foot kept flat).
pub(crate) fn set_leg(dof: &mut [f64], leg: &Leg, hip: f64, knee: f64) {
    dof[leg.hip + 1] = hip;
    dof[leg.knee + 1] = knee;
    dof[leg.ankle + 1] = (-(hip + knee)).clamp(-ANKLE_PITCH_MAX, ANKLE_PITCH_MAX);
}

/// Position of `leg`'s foot frame relative to an upright root at the origin (heading +x).
pub(crate) fn foot_in_root(spec: &CharacterSpec, leg: &Leg, hip: f64, knee: f64) -> Vec3 {
    let mut dof = vec![0.0; spec.num_dofs];
    set_leg(&mut dof, leg, hip, knee);
    spec.forward_kinematics([0.0; 3], Quat::IDENTITY, &dof).0[leg.foot]
}

/// Hip and knee pitch of `leg` that put its foot frame at `target` = (x, z) relative to an
/// upright root at the origin (heading +x; the foot kept flat, the hip's x and z hinges 0, so the
/// foot moves in the leg's sagittal plane): Newton's method from `seed` = (hip, knee) with a
/// finite-difference Jacobian, the knee kept within [0, 2.7] rad. Where the target is out of
/// reach this ends near the closest pose; callers check the foot's position.
pub(crate) fn plant_leg(
    spec: &CharacterSpec,
    leg: &Leg,
    target: [f64; 2],
    seed: (f64, f64),
) -> (f64, f64) {
    let at = |h: f64, k: f64| {
        let p = foot_in_root(spec, leg, h, k);
        [p[0] - target[0], p[2] - target[1]]
    };
    let (mut h, mut k) = seed;
    let e = 1e-6;
    for _ in 0..40 {
        let r = at(h, k);
        if r[0].abs().max(r[1].abs()) < 1e-10 {
            break;
        }
        let (rh, rk) = (at(h + e, k), at(h, k + e));
        let j =
            [[(rh[0] - r[0]) / e, (rk[0] - r[0]) / e], [(rh[1] - r[1]) / e, (rk[1] - r[1]) / e]];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det.abs() < 1e-12 {
            break;
        }
        h -= ((j[1][1] * r[0] - j[0][1] * r[1]) / det).clamp(-0.3, 0.3);
        k = (k - ((-j[1][0] * r[0] + j[0][0] * r[1]) / det).clamp(-0.3, 0.3)).clamp(0.0, 2.7);
    }
    (h, k)
}

/// Bisection of a continuous, monotonic `f` for `f(x) = 0` on [lo, hi] (signs differ there).
pub(crate) fn bisect(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let f_lo = f(lo);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if (f(mid) > 0.0) == (f_lo > 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The hip pitch at which `leg` (stance knee) reaches lowest below the root: its chain's axis is
/// then vertical. The bent knee and the ankle's offset behind the knee put it at about −0.2 rad
/// (thigh forward), so a stance swung symmetrically about this pitch swings the leg's axis
/// symmetrically about the vertical.
fn neutral_pitch(spec: &CharacterSpec, leg: &Leg) -> f64 {
    let z = |a: f64| foot_in_root(spec, leg, a, KNEE_STANCE)[2];
    // ternary search of the unimodal height on [−1, 1]
    let (mut lo, mut hi) = (-1.0, 1.0);
    for _ in 0..100 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if z(m1) < z(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    0.5 * (lo + hi)
}

/// The gait of `leg` for amplitude α: strike at the neutral pitch − α, toe-off where the foot
/// frame is as far below the root as at the strike (about the neutral pitch + α), so that at
/// each switch both feet stand on the floor.
fn swing_of(spec: &CharacterSpec, leg: &Leg, alpha: f64) -> Swing {
    let z = |a: f64| foot_in_root(spec, leg, a, KNEE_STANCE)[2];
    let n = neutral_pitch(spec, leg);
    let b = n - alpha;
    let z_strike = z(b);
    Swing { b, a: bisect(n, n + alpha + 0.5, |a| z(a) - z_strike) }
}

/// The gait of both legs for amplitude α.
fn swings(spec: &CharacterSpec, alpha: f64) -> [Swing; 2] {
    [swing_of(spec, &RIGHT, alpha), swing_of(spec, &LEFT, alpha)]
}

/// Forward displacement (m) of the root over one stride (right stance, then left) of a straight
/// walk with amplitude α: the stance foot's frame moves back relative to the root by this much.
fn stride_length(spec: &CharacterSpec, alpha: f64) -> f64 {
    let [r, l] = swings(spec, alpha);
    let back = |leg: &Leg, s: Swing| {
        foot_in_root(spec, leg, s.b, KNEE_STANCE)[0] - foot_in_root(spec, leg, s.a, KNEE_STANCE)[0]
    };
    back(&RIGHT, r) + back(&LEFT, l)
}

/// The pose (dof vector) at time `t` for step time `ts`.
fn pose(spec: &CharacterSpec, sw: [Swing; 2], ts: f64, t: f64) -> Vec<f64> {
    let psi_r = (t / (2.0 * ts)).rem_euclid(1.0);
    let psi_l = (psi_r + 0.5).rem_euclid(1.0);
    let (hr, kr) = sw[0].at(psi_r);
    let (hl, kl) = sw[1].at(psi_l);
    let mut dof = vec![0.0; spec.num_dofs];
    set_leg(&mut dof, &RIGHT, hr, kr);
    set_leg(&mut dof, &LEFT, hl, kl);
    for (shoulder, elbow, other_hip, side) in
        [(R_SHOULDER, R_ELBOW, hl, -1.0), (L_SHOULDER, L_ELBOW, hr, 1.0)]
    {
        let pitch = ARM_GAIN * other_hip;
        dof[shoulder] = side * ARM_ABDUCTION;
        dof[shoulder + 1] = pitch;
        dof[elbow] = -(ELBOW_BASE + 0.6 * (-pitch).max(0.0));
    }
    dof
}

/// One frame of a synthesised clip: root position (m, world), root orientation, dof vector.
pub(crate) type Frame = ([f64; 3], Quat, Vec<f64>);

/// One walking clip named `name` (see the module doc). Errors name the parameter.
pub fn walk(name: &str, p: WalkParams) -> Result<CharacterClip, String> {
    let (frames, ts, alpha) = walk_frames(p)?;
    let source = format!(
        "procedural walk (skillmimic_motion::synth_walk): {} m/s, turn {} rad/s, step {:.4} s, \
         hip amplitude {:.4} rad",
        p.speed, p.yaw_rate, ts, alpha
    );
    Ok(CharacterClip::from_frames(&tokenhsi::spec(), name, &source, FPS, &frames))
}

/// The frames of the walk `p`, its step time (s) and hip amplitude α (rad).
pub(crate) fn walk_frames(p: WalkParams) -> Result<(Vec<Frame>, f64, f64), String> {
    if !(p.speed >= SPEED_RANGE[0] && p.speed <= SPEED_RANGE[1]) {
        return Err(format!("speed is {} m/s; expected {SPEED_RANGE:?}", p.speed));
    }
    if !p.yaw_rate.is_finite() || p.yaw_rate.abs() > 2.0 {
        return Err(format!("yaw_rate is {} rad/s; expected at most 2 in magnitude", p.yaw_rate));
    }
    if !(p.seconds > 0.0 && p.seconds <= 600.0) {
        return Err(format!("seconds is {}; expected (0, 600]", p.seconds));
    }
    let spec = tokenhsi::spec();
    let ts = step_time(p.speed);
    let alpha = bisect(0.02, 0.7, |a| stride_length(&spec, a) - 2.0 * p.speed * ts);
    let sw = swings(&spec, alpha);
    let legs = [&RIGHT, &LEFT];
    let rest = spec.forward_kinematics(spec.root_pos, Quat::IDENTITY, &vec![0.0; spec.num_dofs]).0;
    let floor_z = [rest[RIGHT.foot][2], rest[LEFT.foot][2]];
    let heading = |t: f64| Quat::about_z(p.yaw_rate * t);
    // the root at time t while `leg`'s frame is planted at `anchor`
    let root_at = |t: f64, leg: usize, anchor: Vec3| -> ([f64; 3], Quat, Vec<f64>) {
        let dof = pose(&spec, sw, ts, t);
        let q = heading(t);
        let rel = spec.forward_kinematics([0.0; 3], q, &dof).0[legs[leg].foot];
        ([anchor[0] - rel[0], anchor[1] - rel[1], anchor[2] - rel[2]], q, dof)
    };
    let n = (p.seconds * FPS).round() as usize + 1;
    // the anchor of step k: planted at the step's start where the foot is
    let rel0 = spec.forward_kinematics([0.0; 3], heading(0.0), &pose(&spec, sw, ts, 0.0)).0;
    let mut anchor = [rel0[RIGHT.foot][0], rel0[RIGHT.foot][1], floor_z[0]];
    let mut step = 0usize;
    let mut frames = Vec::with_capacity(n);
    for f in 0..n {
        let t = f as f64 / FPS;
        // advance the anchor over every switch at or before t
        while t >= (step + 1) as f64 * ts - 1e-12 {
            let switch = (step + 1) as f64 * ts;
            let (root, q, dof) = root_at(switch, step % 2, anchor);
            let next = (step + 1) % 2;
            let foot = spec.forward_kinematics(root, q, &dof).0[legs[next].foot];
            anchor = [foot[0], foot[1], floor_z[next]];
            step += 1;
        }
        frames.push(root_at(t, step % 2, anchor));
    }
    Ok((frames, ts, alpha))
}
