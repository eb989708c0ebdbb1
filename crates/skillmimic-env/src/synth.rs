//! Procedural demo clips made with the project's own model and inverse kinematics.
//!
//! `stand_dribble(hand)` synthesises 3 s (180 frames, 60 fps) of a character standing with bent
//! knees and dribbling the ball with one hand:
//! * the ball follows a dribble cycle of 0.6 s: a 0.2 s hand-contact phase around the top (cubic
//!   Hermite between the catch and release velocities), then free flight under gravity down to the
//!   floor, a bounce with restitution 0.81 and free flight up to the catch height; the push speed
//!   is solved so that the cycle closes;
//! * the dribbling hand's palm stays on top of the ball during contact and follows a cubic
//!   Hermite between release and catch in flight (a short dip, see `HAND_FOLLOW`); it is placed
//!   by damped-least-squares IK on the arm chain (thorax, shoulder, elbow, wrist ball joints) with
//!   MuJoCo's Jacobians, position and orientation (palm down, fingers forward), with a null-space
//!   pull towards the starting arm pose and a per-iteration step limit so that the arm moves
//!   continuously (palm within 8 mm of its target, joints turn ≤ 0.21 rad per frame, no joint
//!   beyond 1.35 rad: measured and tested);
//! * the other arm hangs at the side, legs and trunk are fixed, the feet rest on the floor;
//! * stored body positions are forward kinematics of the model, the contact label is 1 during the
//!   contact phase.
//!
//! Everything is deterministic: same libmujoco, same bytes (`skillmimic synth-motions` writes the
//! shipped `motions/` files; a test regenerates them and compares byte for byte).

use std::sync::Arc;

use mujoco_rs::prelude::*;
use skillmimic_core::characters::skillmimic::{
    BODIES, NUM_BODIES, NUM_DOFS, body_index, dof_range,
};
use skillmimic_core::math::{Quat, Vec3, add, norm, sub};
use skillmimic_motion::{Clip, PT_WIDTH};
use skillmimic_sim::{HandModel, Scene, SimError};

/// Which hand dribbles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hand {
    Left,
    Right,
}

/// Skill label of the synthetic right-hand stand dribble (outside BallPlay-M's 0–45).
pub const LABEL_RIGHT: u32 = 50;
/// Skill label of the synthetic left-hand stand dribble.
pub const LABEL_LEFT: u32 = 51;

const FPS: f64 = 60.0;
const FRAMES: usize = 180;
const GRAVITY: f64 = 9.81;
const RESTITUTION: f64 = 0.81;
const BALL_R: f64 = 0.12;
/// Height of the ball centre at catch and release (m).
const Z_TOP: f64 = 0.80;
const PERIOD: f64 = 0.6;
const CONTACT: f64 = 0.2;
/// Fraction of the ball's release and catch speeds that the hand keeps at the ends of its flight
/// path: the hand follows the ball only briefly, so its dip stays within the arm's reach with the
/// trunk and legs fixed (with the full speeds the path dips to 0.66 m, out of reach: the IK then
/// missed by up to 0.5 m and contorted the arm).
const HAND_FOLLOW: f64 = 0.3;
/// Ball centre beside (towards the dribbling hand) and in front of the root (m).
const BALL_SIDE: f64 = 0.30;
const BALL_FRONT: f64 = 0.35;

type Data = MjData<Arc<MjModel>>;

/// Ball centre height, vertical velocity and contact flag at time `t` (s) of the dribble cycle.
struct Dribble {
    v_push: f64,
    v_catch: f64,
}

impl Dribble {
    /// Solve for the push speed that closes a cycle of [`PERIOD`] with [`CONTACT`] s of contact.
    fn new() -> Self {
        let h = Z_TOP - BALL_R;
        let flight = |v: f64| -> Option<(f64, f64)> {
            let v_impact = (v * v + 2.0 * GRAVITY * h).sqrt();
            let v_up = RESTITUTION * v_impact;
            let disc = v_up * v_up - 2.0 * GRAVITY * h;
            (disc > 0.0)
                .then(|| ((v_impact - v) / GRAVITY + (v_up - disc.sqrt()) / GRAVITY, disc.sqrt()))
        };
        let (mut lo, mut hi) = (0.0, 20.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            match flight(mid) {
                Some((t, _)) if t < PERIOD - CONTACT => hi = mid,
                _ => lo = mid,
            }
        }
        let (_, v_catch) = flight(hi).expect("a cycle exists");
        Self { v_push: hi, v_catch }
    }

    /// (z, v_z, in_contact) at time `t`; the cycle starts at the beginning of a contact phase.
    fn ball(&self, t: f64) -> (f64, f64, bool) {
        let s = t.rem_euclid(PERIOD);
        if s < CONTACT {
            let (z, v) = hermite(Z_TOP, self.v_catch, Z_TOP, -self.v_push, CONTACT, s);
            return (z, v, true);
        }
        let f = s - CONTACT;
        let h = Z_TOP - BALL_R;
        let v_impact = (self.v_push * self.v_push + 2.0 * GRAVITY * h).sqrt();
        let t_down = (v_impact - self.v_push) / GRAVITY;
        if f < t_down {
            (Z_TOP - self.v_push * f - 0.5 * GRAVITY * f * f, -self.v_push - GRAVITY * f, false)
        } else {
            let u = f - t_down;
            let v_up = RESTITUTION * v_impact;
            (BALL_R + v_up * u - 0.5 * GRAVITY * u * u, v_up - GRAVITY * u, false)
        }
    }

    /// Palm height (m) at time `t`: on the ball's top in contact, a Hermite dip in flight that
    /// leaves and returns with [`HAND_FOLLOW`] of the ball's speeds.
    fn hand_z(&self, t: f64) -> f64 {
        let s = t.rem_euclid(PERIOD);
        if s < CONTACT {
            return self.ball(t).0 + BALL_R;
        }
        let top = Z_TOP + BALL_R;
        hermite(
            top,
            -HAND_FOLLOW * self.v_push,
            top,
            HAND_FOLLOW * self.v_catch,
            PERIOD - CONTACT,
            s - CONTACT,
        )
        .0
    }
}

/// Cubic Hermite from (p0, v0) to (p1, v1) over duration `d`, evaluated at `t`: (position,
/// velocity).
fn hermite(p0: f64, v0: f64, p1: f64, v1: f64, d: f64, t: f64) -> (f64, f64) {
    let s = t / d;
    let (s2, s3) = (s * s, s * s * s);
    let p = (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * d * v0
        + (-2.0 * s3 + 3.0 * s2) * p1
        + (s3 - s2) * d * v1;
    let v = ((6.0 * s2 - 6.0 * s) * p0
        + (3.0 * s2 - 4.0 * s + 1.0) * d * v0
        + (-6.0 * s2 + 6.0 * s) * p1
        + (3.0 * s2 - 2.0 * s) * d * v1)
        / d;
    (p, v)
}

/// Set the joint of skeleton body `b` to rotation vector `v` in a qpos array.
fn set_joint(scene: &Scene, qpos: &mut [f64], b: usize, v: Vec3) {
    let a = scene.joint_addr(b).expect("articulated body").qpos;
    qpos[a..a + 4].copy_from_slice(&Quat::from_rotvec(v).to_wxyz());
}

fn joint_quat(scene: &Scene, qpos: &[f64], b: usize) -> Quat {
    let a = scene.joint_addr(b).expect("articulated body").qpos;
    Quat::from_wxyz([qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]])
}

/// Solve the 6×6 (or smaller) symmetric positive definite system `a x = b` in place (Cholesky).
fn solve_spd(a: &mut [[f64; 6]; 6], b: &mut [f64; 6]) {
    let n = 6;
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= a[i][k] * b[k];
        }
        b[i] = s / a[i][i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= a[k][i] * b[k];
        }
        b[i] = s / a[i][i];
    }
}

/// World position of `point_local` (wrist frame) in the current kinematics of `d`.
fn wrist_point(d: &Data, wrist_id: usize, point_local: Vec3) -> Vec3 {
    add(d.xpos()[wrist_id], Quat::from_wxyz(d.xquat()[wrist_id]).rotate(point_local))
}

/// Largest rotation (rad) of one joint in one IK iteration.
const MAX_IK_STEP: f64 = 0.1;
/// Gain of the secondary task that pulls the chain towards its rest pose inside the null space of
/// the hand task.
const REST_GAIN: f64 = 0.2;

/// Damped-least-squares IK: move the arm chain so that `point_local` of the wrist reaches
/// `target` and the wrist orientation approaches `target_rot` (world frame).
///
/// A 12-DoF chain (four ball joints) has a 6-D null space for this 6-D task; left alone, the
/// solution drifts along it from frame to frame into implausible poses (measured before this
/// term existed: thorax and wrist rotations near π, joints jumping 2–3.8 rad between frames).
/// Each iteration therefore also moves the chain towards `rest` (per-joint rotation vectors in the
/// joint's local frame, MuJoCo's ball-joint velocity convention) through the projector
/// `I − Jᵀ(JJᵀ + λ²I)⁻¹J`, and every joint's step is limited to [`MAX_IK_STEP`] rad.
#[allow(clippy::too_many_arguments)]
fn solve_arm(
    scene: &Scene,
    d: &mut Data,
    chain: &[usize],
    rest: &[Quat],
    wrist: usize,
    point_local: Vec3,
    target: Vec3,
    target_rot: Quat,
) -> f64 {
    let wrist_id = scene.body_ids[wrist];
    let dofs: Vec<usize> = chain
        .iter()
        .flat_map(|&b| (0..3).map(move |k| scene.joint_addr(b).unwrap().qvel + k))
        .collect();
    for _ in 0..200 {
        d.kinematics();
        d.com_pos();
        let xq = Quat::from_wxyz(d.xquat()[wrist_id]);
        let p = wrist_point(d, wrist_id, point_local);
        let e_pos = sub(target, p);
        let e_rot = target_rot.mul(xq.conj()).to_rotvec();
        const W_ROT: f64 = 0.3;
        let err =
            [e_pos[0], e_pos[1], e_pos[2], W_ROT * e_rot[0], W_ROT * e_rot[1], W_ROT * e_rot[2]];
        let mut qpos = d.qpos().to_vec();
        // secondary task: rotation from each joint's current value to its rest value
        let z: Vec<f64> = chain
            .iter()
            .zip(rest)
            .flat_map(|(&b, r)| joint_quat(scene, &qpos, b).conj().mul(*r).to_rotvec())
            .collect();
        let z_norm2: f64 = z.iter().map(|x| x * x).sum();
        if err.iter().map(|x| x * x).sum::<f64>() < 1e-12 && z_norm2 < 1e-8 {
            break;
        }
        let (jp, jr) = d.jac(true, true, &p, wrist_id);
        let nv = d.qvel().len();
        let row =
            |r: usize, c: usize| if r < 3 { jp[r * nv + c] } else { W_ROT * jr[(r - 3) * nv + c] };
        // (J Jᵀ + λ² I) y = e − J·k z ;  Δq = k z + Jᵀ y  (primary task + projected rest pull)
        let lambda2 = 1e-3;
        let mut a = [[0.0; 6]; 6];
        for (i, ai) in a.iter_mut().enumerate() {
            for (k, aik) in ai.iter_mut().enumerate() {
                *aik = dofs.iter().map(|&c| row(i, c) * row(k, c)).sum::<f64>()
                    + if i == k { lambda2 } else { 0.0 };
            }
        }
        let mut y: [f64; 6] = std::array::from_fn(|r| {
            err[r]
                - dofs.iter().enumerate().map(|(ci, &c)| row(r, c) * REST_GAIN * z[ci]).sum::<f64>()
        });
        solve_spd(&mut a, &mut y);
        for (ci, &b) in chain.iter().enumerate() {
            let mut dq: Vec3 = std::array::from_fn(|k| {
                let c = dofs[3 * ci + k];
                REST_GAIN * z[3 * ci + k] + (0..6).map(|r| row(r, c) * y[r]).sum::<f64>()
            });
            let step = norm(dq);
            if step > MAX_IK_STEP {
                dq = dq.map(|x| x * MAX_IK_STEP / step);
            }
            let q = joint_quat(scene, &qpos, b).mul(Quat::from_rotvec(dq)).normalized();
            let a = scene.joint_addr(b).unwrap().qpos;
            qpos[a..a + 4].copy_from_slice(&q.to_wxyz());
        }
        d.qpos_mut().copy_from_slice(&qpos);
    }
    d.kinematics();
    // remaining distance (m) of the palm point from its target
    norm(sub(target, wrist_point(d, wrist_id, point_local)))
}

/// Lowest point (world z) of the foot geoms (boxes) in the current kinematics.
fn lowest_foot_point(scene: &Scene, d: &Data) -> f64 {
    let m = scene.model();
    let mut low = f64::INFINITY;
    for name in ["L_Ankle", "L_Toe", "R_Ankle", "R_Toe"] {
        let b = body_index(name).unwrap();
        let body_id = scene.body_ids[b];
        for g in 0..m.ffi().ngeom as usize {
            if m.geom_bodyid()[g] as usize != body_id {
                continue;
            }
            let (c, r, s) = (d.geom_xpos()[g], d.geom_xmat()[g], m.geom_size()[g]);
            // box: lowest corner = centre z − Σ |R[2][k]| · half_k
            let z = c[2] - (r[6].abs() * s[0] + r[7].abs() * s[1] + r[8].abs() * s[2]);
            low = low.min(z);
        }
    }
    low
}

/// Synthesise the stand-and-dribble clip for `hand`.
pub fn stand_dribble(hand: Hand) -> Result<Clip, SimError> {
    synthesise(hand).map(|(clip, _)| clip)
}

/// The clip and the largest IK position residual over its frames (m).
fn synthesise(hand: Hand) -> Result<(Clip, f64), SimError> {
    let scene = Scene::default_for(HandModel::Full)?;
    let mut d: Data = MjData::new(Arc::clone(scene.model()));
    let b = |n: &str| body_index(n).unwrap();
    let (side, other, label, sign) = match hand {
        Hand::Right => ("R", "L", LABEL_RIGHT, -1.0),
        Hand::Left => ("L", "R", LABEL_LEFT, 1.0),
    };

    // standing pose: upright root (skeleton Y-up -> Z-up), soft knees, hanging free arm
    let upright = Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]);
    let mut qpos = d.qpos().to_vec();
    let root = scene.root_qpos.unwrap();
    qpos[root..root + 3].copy_from_slice(&[0.0, 0.0, 1.0]);
    qpos[root + 3..root + 7].copy_from_slice(&upright.to_wxyz());
    for j in 1..NUM_BODIES {
        set_joint(&scene, &mut qpos, j, [0.0; 3]);
    }
    for s in ["L", "R"] {
        set_joint(&scene, &mut qpos, b(&format!("{s}_Hip")), [-0.25, 0.0, 0.0]);
        set_joint(&scene, &mut qpos, b(&format!("{s}_Knee")), [0.45, 0.0, 0.0]);
        set_joint(&scene, &mut qpos, b(&format!("{s}_Ankle")), [-0.2, 0.0, 0.0]);
    }
    set_joint(&scene, &mut qpos, b("Spine"), [0.12, 0.0, 0.0]);
    // free arm down along the side (left arm points +x, right arm −x in the skeleton frame)
    let free_sign = -sign;
    set_joint(&scene, &mut qpos, b(&format!("{other}_Shoulder")), [0.0, 0.0, free_sign * -1.35]);
    set_joint(&scene, &mut qpos, b(&format!("{other}_Elbow")), [0.0, free_sign * -0.3, 0.0]);
    // dribbling arm start: down and bent forward (refined by IK)
    set_joint(&scene, &mut qpos, b(&format!("{side}_Shoulder")), [0.0, 0.0, sign * -0.9]);
    set_joint(&scene, &mut qpos, b(&format!("{side}_Elbow")), [0.0, sign * -1.2, 0.0]);
    d.qpos_mut().copy_from_slice(&qpos);
    d.kinematics();
    // feet on the floor
    let lift = lowest_foot_point(&scene, &d);
    d.qpos_mut()[root + 2] -= lift;
    d.kinematics();

    // ball beside and in front of the dribbling hand (the character faces world −y)
    let root_pos = [d.qpos()[root], d.qpos()[root + 1], d.qpos()[root + 2]];
    let ball_xy = [root_pos[0] + sign * BALL_SIDE, root_pos[1] - BALL_FRONT];
    // palm: a point just under the wrist axis towards the fingers (fingers run along ∓x of the
    // hand); on the ball top it makes the hand capsules press ~6 mm into the ball in contact frames
    let palm_local: Vec3 = [sign * 0.05, -0.004, 0.012];
    // palm down, fingers forward: the T-pose hand turned a quarter turn about world z
    let target_rot = Quat::about_z(-sign * std::f64::consts::FRAC_PI_2).mul(upright);
    let chain: Vec<usize> = ["Thorax", "Shoulder", "Elbow", "Wrist"]
        .iter()
        .map(|p| b(&format!("{side}_{p}")))
        .collect();
    let wrist = b(&format!("{side}_Wrist"));
    // rest pose of the chain: the starting arm pose above
    let rest: Vec<Quat> = chain.iter().map(|&j| joint_quat(&scene, d.qpos(), j)).collect();

    let dribble = Dribble::new();
    let mut rows = vec![0.0f32; FRAMES * PT_WIDTH];
    let mut worst_residual = 0.0f64;
    for f in 0..FRAMES {
        let t = f as f64 / FPS;
        let (bz, _, contact) = dribble.ball(t);
        let target = [ball_xy[0], ball_xy[1], dribble.hand_z(t)];
        worst_residual = worst_residual
            .max(solve_arm(&scene, &mut d, &chain, &rest, wrist, palm_local, target, target_rot));
        let r = &mut rows[f * PT_WIDTH..(f + 1) * PT_WIDTH];
        let qp = d.qpos();
        for k in 0..3 {
            r[k] = qp[root + k] as f32;
        }
        let e =
            Quat::from_wxyz([qp[root + 3], qp[root + 4], qp[root + 5], qp[root + 6]]).to_rotvec();
        for k in 0..3 {
            r[3 + k] = e[k] as f32;
            r[6 + k] = e[k] as f32;
        }
        for j in 1..NUM_BODIES {
            let v = joint_quat(&scene, qp, j).normalized().to_rotvec();
            for (k, i) in dof_range(j).enumerate() {
                r[9 + i] = v[k] as f32;
            }
        }
        for body in 0..NUM_BODIES {
            let p = d.xpos()[scene.body_ids[body]];
            for k in 0..3 {
                r[165 + 3 * body + k] = p[k] as f32;
            }
        }
        r[324] = ball_xy[0] as f32;
        r[325] = ball_xy[1] as f32;
        r[326] = bz as f32;
        r[336] = if contact { 1.0 } else { 0.0 };
    }
    debug_assert_eq!(BODIES.len(), NUM_BODIES);
    debug_assert_eq!(NUM_DOFS, 156);
    let name = format!(
        "{label:03}_synth_stand_dribble_{}",
        if hand == Hand::Right { "right" } else { "left" }
    );
    let source = format!(
        "skillmimic synth-motions: IK stand-and-dribble, {} hand, {FRAMES} frames at {FPS} fps, \
            cycle {PERIOD} s, contact {CONTACT} s",
        if hand == Hand::Right { "right" } else { "left" }
    );
    Ok((Clip::from_rows(name, source, label, FPS, FRAMES, &rows), worst_residual))
}

/// All shipped demo clips.
pub fn demo_clips() -> Result<Vec<Clip>, SimError> {
    Ok(vec![stand_dribble(Hand::Right)?, stand_dribble(Hand::Left)?])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dribble_cycle_closes_and_is_continuous() {
        let dr = Dribble::new();
        // contact starts and ends at the top, flight ends at the top again
        let (z0, v0, c0) = dr.ball(0.0);
        assert!(c0 && (z0 - Z_TOP).abs() < 1e-12 && (v0 - dr.v_catch).abs() < 1e-9);
        let eps = 1e-9;
        let (z1, _, c1) = dr.ball(PERIOD - eps);
        assert!(!c1 && (z1 - Z_TOP).abs() < 1e-6, "{z1}");
        let (za, va, _) = dr.ball(CONTACT - eps);
        let (zb, vb, _) = dr.ball(CONTACT + eps);
        assert!((za - zb).abs() < 1e-6 && (va - vb).abs() < 1e-6);
        // the ball touches the floor once per cycle
        let lowest =
            (0..600).map(|k| dr.ball(k as f64 * PERIOD / 600.0).0).fold(f64::INFINITY, f64::min);
        assert!((lowest - BALL_R).abs() < 1e-3, "{lowest}");
    }

    /// The IK keeps the palm on its target, the arm moves continuously (no branch flips between
    /// frames) and every joint stays well below π, where exp maps flip sign and the clip's
    /// backward-difference joint velocities would spike.
    #[test]
    fn synthesised_arm_motion_is_continuous_and_on_target() {
        for hand in [Hand::Right, Hand::Left] {
            let (clip, residual) = synthesise(hand).unwrap();
            assert!(residual < 0.01, "{hand:?}: IK residual {residual} m");
            let rot = |f: usize, j: usize| {
                let v = &clip.dof_rot[(f * (NUM_BODIES - 1) + j) * 3..][..3];
                Quat::from_rotvec([v[0] as f64, v[1] as f64, v[2] as f64])
            };
            let (mut max_angle, mut max_step) = (0.0f64, 0.0f64);
            for f in 0..clip.num_frames {
                for j in 0..NUM_BODIES - 1 {
                    let q = rot(f, j);
                    max_angle = max_angle.max(norm(q.to_rotvec()));
                    if f > 0 {
                        max_step = max_step.max(norm(rot(f - 1, j).conj().mul(q).to_rotvec()));
                    }
                }
            }
            println!(
                "{hand:?}: IK residual {residual:.2e} m, largest joint angle {max_angle:.3} rad, \
                    largest per-frame joint rotation {max_step:.3} rad"
            );
            assert!(max_angle < 2.5, "{hand:?}: joint angle {max_angle} rad");
            assert!(max_step < 0.35, "{hand:?}: a joint turns {max_step} rad between frames");
        }
    }

    #[test]
    fn hermite_matches_its_end_conditions() {
        let (p, v) = hermite(1.0, 2.0, 3.0, -1.0, 0.5, 0.0);
        assert!((p - 1.0).abs() < 1e-15 && (v - 2.0).abs() < 1e-12);
        let (p, v) = hermite(1.0, 2.0, 3.0, -1.0, 0.5, 0.5);
        assert!((p - 3.0).abs() < 1e-12 && (v + 1.0).abs() < 1e-12);
    }
}
