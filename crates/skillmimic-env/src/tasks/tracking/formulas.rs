//! The tracking task's formulas, over world-frame body states (positions in m, quaternions
//! (w, x, y, z), centre-of-mass linear velocities in m/s, angular velocities in rad/s; skeleton
//! body order). One definition shared by the task, evaluation and the tests.

use skillmimic_core::characters::skillmimic::{BODIES, NUM_BODIES};
use skillmimic_core::math::{Quat, heading_inverse, norm, sub, tan_norm};
use skillmimic_sim::EnvState;

use crate::config::TrackingConfig;

/// Values per tracked body in the observation's reference block.
pub const REF_WIDTH: usize = 24;
/// Reward terms.
pub const TERMS: [&str; 6] = ["pos", "rot", "vel", "angvel", "power", "total"];
/// Per-step metrics: global and root-relative mean body position errors (mm), velocity error
/// (mm/frame) and acceleration error (mm/frame²) of the body positions, and `success` (1 at the
/// last step of an episode that reached its clip end without the mean body distance ever
/// exceeding `success_distance`, else 0).
pub const METRICS: [&str; 5] = ["g_mpjpe_mm", "mpjpe_mm", "vel_err_mm", "acc_err_mm", "success"];

/// World-frame states of the 53 bodies at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyFrame {
    pub pos: [[f64; 3]; NUM_BODIES],
    pub quat: [Quat; NUM_BODIES],
    pub linvel: [[f64; 3]; NUM_BODIES],
    pub angvel: [[f64; 3]; NUM_BODIES],
}

impl BodyFrame {
    /// The humanoid bodies of a simulation state.
    pub fn from_state(st: &EnvState<'_>) -> Self {
        Self {
            pos: std::array::from_fn(|b| st.pos(b)),
            quat: std::array::from_fn(|b| st.quat(b)),
            linvel: std::array::from_fn(|b| st.linvel(b)),
            angvel: std::array::from_fn(|b| st.angvel(b)),
        }
    }
}

/// The tracked bodies: all 53, or the 23 that are not fingers.
pub fn tracked_bodies(fingers: bool) -> Vec<usize> {
    (0..NUM_BODIES)
        .filter(|&b| fingers || !skillmimic_core::characters::skillmimic::is_finger(b))
        .collect()
}

/// Errors of a simulated frame against the reference frame over `bodies`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Errors {
    /// Mean ‖Δp‖² (m²).
    pub pos2: f64,
    /// Mean θ² (rad²), θ = angle of q_ref · q_sim⁻¹.
    pub rot2: f64,
    /// Mean ‖Δv‖² ((m/s)²).
    pub vel2: f64,
    /// Mean ‖Δω‖² ((rad/s)²).
    pub angvel2: f64,
    /// Mean ‖Δp‖ (m): the termination and success distance, E_g-mpjpe.
    pub dist: f64,
    /// Mean ‖(p − p_root) − (p_ref − p_ref,root)‖ (m): E_mpjpe.
    pub dist_rel: f64,
}

/// Errors of `sim` against `r` over `bodies`.
pub fn errors(sim: &BodyFrame, r: &BodyFrame, bodies: &[usize]) -> Errors {
    let mut e = Errors::default();
    for &b in bodies {
        let dp = sub(r.pos[b], sim.pos[b]);
        let d = norm(dp);
        e.pos2 += d * d;
        e.dist += d;
        let rel = sub(sub(sim.pos[b], sim.pos[0]), sub(r.pos[b], r.pos[0]));
        e.dist_rel += norm(rel);
        let th = r.quat[b].mul(sim.quat[b].conj()).angle();
        e.rot2 += th * th;
        let dv = norm(sub(r.linvel[b], sim.linvel[b]));
        e.vel2 += dv * dv;
        let dw = norm(sub(r.angvel[b], sim.angvel[b]));
        e.angvel2 += dw * dw;
    }
    let k = bodies.len() as f64;
    Errors {
        pos2: e.pos2 / k,
        rot2: e.rot2 / k,
        vel2: e.vel2 / k,
        angvel2: e.angvel2 / k,
        dist: e.dist / k,
        dist_rel: e.dist_rel / k,
    }
}

/// Mechanical power Σ|τ · q̇| (W) of the joint drives at a state, τ per axis =
/// clamp(kp · (π · clamp(a, −1, 1) − q), ±force_limit) − kd · q̇ (the position actuator and the
/// joint damping); `targets` = the action row applied in the step (156), `active[j]` = whether
/// joint coordinate j is actuated (welded fingers are not).
pub fn power(st: &EnvState<'_>, targets: &[f32], active: &[bool], force_limit: f64) -> f64 {
    let mut p = 0.0;
    for (j, (&a, &on)) in targets.iter().zip(active).enumerate() {
        if !on {
            continue;
        }
        let (kp, kd) = BODIES[j / 3 + 1].group.gains();
        let (q, qd) = (st.dof_pos[j], st.dof_vel[j]);
        let target = (a as f64).clamp(-1.0, 1.0) * std::f64::consts::PI;
        let tau = (kp * (target - q)).clamp(-force_limit, force_limit) - kd * qd;
        p += (tau * qd).abs();
    }
    p
}

/// Reward terms in [`TERMS`] order: w_k · exp(−k · error²) for position, rotation, velocity,
/// angular velocity, then −power_coef · power, then the total.
pub fn reward(e: &Errors, power: f64, cfg: &TrackingConfig) -> [f64; 6] {
    let (w, k) = (cfg.weights, cfg.scales);
    let t = [
        w[0] * (-k[0] * e.pos2).exp(),
        w[1] * (-k[1] * e.rot2).exp(),
        w[2] * (-k[2] * e.vel2).exp(),
        w[3] * (-k[3] * e.angvel2).exp(),
        -cfg.power_coef * power,
    ];
    [t[0], t[1], t[2], t[3], t[4], t.iter().sum()]
}

/// The reference block of the observation: per tracked body, in the simulated root's heading
/// frame (world rotated about +z by −heading): Δp = p_ref − p (3), Δrot = tan-norm 6D of
/// q_ref · q⁻¹ (6), Δv (3), Δω (3), p_ref − p_root (3), tan-norm 6D of q_ref (6).
pub fn write_reference_obs(sim: &BodyFrame, r: &BodyFrame, bodies: &[usize], out: &mut [f32]) {
    let h = heading_inverse(sim.quat[0]);
    let hc = h.conj();
    for (k, &b) in bodies.iter().enumerate() {
        let o = &mut out[k * REF_WIDTH..(k + 1) * REF_WIDTH];
        let v3 = |v: [f64; 3]| h.rotate(v).map(|x| x as f32);
        let r6 = |q: Quat| tan_norm(q).map(|x| x as f32);
        o[0..3].copy_from_slice(&v3(sub(r.pos[b], sim.pos[b])));
        o[3..9].copy_from_slice(&r6(h.mul(r.quat[b].mul(sim.quat[b].conj())).mul(hc)));
        o[9..12].copy_from_slice(&v3(sub(r.linvel[b], sim.linvel[b])));
        o[12..15].copy_from_slice(&v3(sub(r.angvel[b], sim.angvel[b])));
        o[15..18].copy_from_slice(&v3(sub(r.pos[b], sim.pos[0])));
        o[18..24].copy_from_slice(&r6(h.mul(r.quat[b])));
    }
}

/// Mean over `bodies` of ‖(x1 − x0) − (y1 − y0)‖ (velocity error per frame, same units as the
/// positions) and of ‖(x2 − 2x1 + x0) − (y2 − 2y1 + y0)‖ (acceleration error per frame²), for
/// simulated positions x0, x1, x2 (oldest first) and reference positions y0, y1, y2.
pub fn vel_acc_errors(
    x: [&[[f64; 3]; NUM_BODIES]; 3],
    y: [&[[f64; 3]; NUM_BODIES]; 3],
    bodies: &[usize],
) -> (f64, f64) {
    let (mut ve, mut ae) = (0.0, 0.0);
    for &b in bodies {
        let v = std::array::from_fn::<f64, 3, _>(|c| {
            (x[2][b][c] - x[1][b][c]) - (y[2][b][c] - y[1][b][c])
        });
        let a = std::array::from_fn::<f64, 3, _>(|c| {
            (x[2][b][c] - 2.0 * x[1][b][c] + x[0][b][c])
                - (y[2][b][c] - 2.0 * y[1][b][c] + y[0][b][c])
        });
        ve += norm(v);
        ae += norm(a);
    }
    let k = bodies.len() as f64;
    (ve / k, ae / k)
}
