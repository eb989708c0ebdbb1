//! The tracking task's formulas, over world-frame body states of any character (positions in m,
//! quaternions (w, x, y, z), centre-of-mass linear velocities in m/s, angular velocities in
//! rad/s; the character's body order). One definition shared by the task, evaluation and the
//! tests.

use skillmimic_core::characters::CharacterSpec;
use skillmimic_core::math::{Quat, heading_inverse, norm, sub, tan_norm};
use skillmimic_sim::EnvState;

use super::config::TrackingConfig;

/// Values per tracked body in the observation's reference block.
pub const REF_WIDTH: usize = 24;
/// Reward terms.
pub const TERMS: [&str; 6] = ["pos", "rot", "vel", "angvel", "power", "total"];
/// Per-step metrics: global and root-relative mean body position errors (mm), velocity error
/// (mm/frame) and acceleration error (mm/frame²) of the body positions, and `success` (1 at the
/// last step of an episode that reached its clip end without the mean body distance ever
/// exceeding `success_distance`, else 0).
pub const METRICS: [&str; 5] = ["g_mpjpe_mm", "mpjpe_mm", "vel_err_mm", "acc_err_mm", "success"];

/// World-frame states of a character's bodies at one instant.
pub trait Bodies {
    fn pos(&self, b: usize) -> [f64; 3];
    fn quat(&self, b: usize) -> Quat;
    fn linvel(&self, b: usize) -> [f64; 3];
    fn angvel(&self, b: usize) -> [f64; 3];
}

impl Bodies for EnvState<'_> {
    fn pos(&self, b: usize) -> [f64; 3] {
        EnvState::pos(self, b)
    }
    fn quat(&self, b: usize) -> Quat {
        EnvState::quat(self, b)
    }
    fn linvel(&self, b: usize) -> [f64; 3] {
        EnvState::linvel(self, b)
    }
    fn angvel(&self, b: usize) -> [f64; 3] {
        EnvState::angvel(self, b)
    }
}

/// The tracked bodies of `spec`: all of them; on the SkillMimic humanoid the 30 finger bodies
/// only when `fingers` (the 23 others are the counterpart of the SMPL bodies ModSkill tracks).
pub fn tracked_bodies(spec: &CharacterSpec, fingers: bool) -> Vec<usize> {
    let skillmimic = spec.name == "skillmimic";
    (0..spec.bodies.len())
        .filter(|&b| {
            fingers || !skillmimic || !skillmimic_core::characters::skillmimic::is_finger(b)
        })
        .collect()
}

/// The bodies whose mean distance decides termination and success (see
/// [`TrackingConfig::termination_bodies`]); an unknown name is an error naming it.
pub fn termination_bodies(
    spec: &CharacterSpec,
    tracked: &[usize],
    cfg: &TrackingConfig,
) -> Result<Vec<usize>, String> {
    let index = |name: &str| spec.bodies.iter().position(|b| b.name == name);
    if cfg.termination_bodies.is_empty() {
        // the character's default (`CharacterSpec::tracking_unjudged`)
        return Ok(tracked
            .iter()
            .copied()
            .filter(|&b| !spec.tracking_unjudged.contains(&spec.bodies[b].name))
            .collect());
    }
    cfg.termination_bodies
        .iter()
        .map(|n| {
            index(n).ok_or_else(|| format!("'{n}' is not a body of the {} character", spec.name))
        })
        .collect()
}

/// Mean ‖p_ref − p‖ (m) over `bodies`: the termination and success distance.
pub fn mean_distance(sim: &impl Bodies, r: &impl Bodies, bodies: &[usize]) -> f64 {
    bodies.iter().map(|&b| norm(sub(r.pos(b), sim.pos(b)))).sum::<f64>() / bodies.len() as f64
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
    /// Mean ‖Δp‖ (m): E_g-mpjpe.
    pub dist: f64,
    /// Mean ‖(p − p_root) − (p_ref − p_ref,root)‖ (m): E_mpjpe.
    pub dist_rel: f64,
}

/// Errors of `sim` against `r` over `bodies`.
pub fn errors(sim: &impl Bodies, r: &impl Bodies, bodies: &[usize]) -> Errors {
    let mut e = Errors::default();
    for &b in bodies {
        let dp = sub(r.pos(b), sim.pos(b));
        let d = norm(dp);
        e.pos2 += d * d;
        e.dist += d;
        let rel = sub(sub(sim.pos(b), sim.pos(0)), sub(r.pos(b), r.pos(0)));
        e.dist_rel += norm(rel);
        let th = r.quat(b).mul(sim.quat(b).conj()).angle();
        e.rot2 += th * th;
        let dv = norm(sub(r.linvel(b), sim.linvel(b)));
        e.vel2 += dv * dv;
        let dw = norm(sub(r.angvel(b), sim.angvel(b)));
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

/// Whether the power penalty counts at the `steps`-th step after a reset (1 = the first): the
/// released `progress_buf <= power_free_steps` zeroes it.
pub fn power_counts(steps: usize, cfg: &TrackingConfig) -> bool {
    steps > cfg.power_free_steps
}

/// Whether the distance rule (termination and the success threshold) applies at the `steps`-th
/// step after a reset: the released `progress_buf > 1` with `termination_grace` = 1.
pub fn distance_rule_applies(steps: usize, cfg: &TrackingConfig) -> bool {
    steps > cfg.termination_grace
}

/// Whether a frame with mean body distance `dist` (m) at the `steps`-th step after a reset ends
/// the episode early (the released `compute_humanoid_im_reset`, mean over the bodies, strict `>`).
pub fn terminates(dist: f64, steps: usize, cfg: &TrackingConfig) -> bool {
    distance_rule_applies(steps, cfg) && dist > cfg.termination_distance
}

/// Reward terms in [`TERMS`] order: w_k · exp(−k · error²) for position, rotation, velocity,
/// angular velocity (the vector errors averaged as `cfg.error_mean` says), then
/// −power_coef · power, then the total.
pub fn reward(e: &Errors, power: f64, cfg: &TrackingConfig) -> [f64; 6] {
    let (w, k, m) = (cfg.weights, cfg.scales, cfg.error_mean.divisor());
    let t = [
        w[0] * (-k[0] * e.pos2 / m).exp(),
        w[1] * (-k[1] * e.rot2).exp(),
        w[2] * (-k[2] * e.vel2 / m).exp(),
        w[3] * (-k[3] * e.angvel2 / m).exp(),
        -cfg.power_coef * power,
    ];
    [t[0], t[1], t[2], t[3], t[4], t.iter().sum()]
}

/// The reference block of the observation: per tracked body, in the simulated root's heading
/// frame (world rotated about +z by −heading): Δp = p_ref − p (3), Δrot = tan-norm 6D of
/// q_ref · q⁻¹ (6), Δv (3), Δω (3), p_ref − p_root (3), tan-norm 6D of q_ref (6).
pub fn write_reference_obs(sim: &impl Bodies, r: &impl Bodies, bodies: &[usize], out: &mut [f32]) {
    let h = heading_inverse(sim.quat(0));
    let hc = h.conj();
    for (k, &b) in bodies.iter().enumerate() {
        let o = &mut out[k * REF_WIDTH..(k + 1) * REF_WIDTH];
        let v3 = |v: [f64; 3]| h.rotate(v).map(|x| x as f32);
        let r6 = |q: Quat| tan_norm(q).map(|x| x as f32);
        o[0..3].copy_from_slice(&v3(sub(r.pos(b), sim.pos(b))));
        o[3..9].copy_from_slice(&r6(h.mul(r.quat(b).mul(sim.quat(b).conj())).mul(hc)));
        o[9..12].copy_from_slice(&v3(sub(r.linvel(b), sim.linvel(b))));
        o[12..15].copy_from_slice(&v3(sub(r.angvel(b), sim.angvel(b))));
        o[15..18].copy_from_slice(&v3(sub(r.pos(b), sim.pos(0))));
        o[18..24].copy_from_slice(&r6(h.mul(r.quat(b))));
    }
}

/// Mean over `bodies` of ‖(x1 − x0) − (y1 − y0)‖ (velocity error per frame, same units as the
/// positions) and of ‖(x2 − 2x1 + x0) − (y2 − 2y1 + y0)‖ (acceleration error per frame²), for
/// simulated positions x0, x1, x2 (oldest first) and reference positions y0, y1, y2, each given
/// by body index.
pub fn vel_acc_errors(
    x: [&dyn Fn(usize) -> [f64; 3]; 3],
    y: [&dyn Fn(usize) -> [f64; 3]; 3],
    bodies: &[usize],
) -> (f64, f64) {
    let (mut ve, mut ae) = (0.0, 0.0);
    for &b in bodies {
        let (xb, yb) = ([x[0](b), x[1](b), x[2](b)], [y[0](b), y[1](b), y[2](b)]);
        let v = std::array::from_fn::<f64, 3, _>(|c| (xb[2][c] - xb[1][c]) - (yb[2][c] - yb[1][c]));
        let a = std::array::from_fn::<f64, 3, _>(|c| {
            (xb[2][c] - 2.0 * xb[1][c] + xb[0][c]) - (yb[2][c] - 2.0 * yb[1][c] + yb[0][c])
        });
        ve += norm(v);
        ae += norm(a);
    }
    let k = bodies.len() as f64;
    (ve / k, ae / k)
}
