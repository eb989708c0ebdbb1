//! State similarity S = r_b · r_o · r_rel (SkillMimic-V2, seed 003 §4.3) and the number of
//! masked bridging steps derived from it (App. B.4).
//!
//! S is built from the imitation reward's own error terms and weights (`reward` module), so a
//! state that would earn a high reward against a reference frame is also similar to it:
//! r_b = r_p·r_r·r_pv·r_rv (the velocity regulariser needs a previous step and is left out),
//! r_o = r_op·r_or·r_opv·r_orv, r_rel = r_ig. For clips without a ball (skill labels 0 and 10)
//! S = r_b.
//!
//! With `env.compat = "code"` the connection uses the released code's similarity instead
//! ([`code_similarity`]) and its step count ([`masked_steps_code`]).

use skillmimic_core::characters::skillmimic::NUM_JOINTS;
use skillmimic_core::math::Quat;
use skillmimic_motion::NUM_KEY;

use crate::compat::Compat;
use crate::config::RewardConfig;
use crate::hoi::HoiState;
use crate::reward::{
    err_ball_angvel, err_ball_linvel, err_ball_pos, err_ball_rot, err_body_pos, err_body_rot,
    err_body_vel, err_dof_vel, err_relative,
};

/// Similarity of state `s` to reference state `r`, in (0, 1].
pub fn similarity(s: &HoiState, r: &HoiState, cfg: &RewardConfig, ball_free: bool) -> f64 {
    let ex = |w: f64, e: f64| (-w * e).exp();
    let rb = ex(cfg.w_p, err_body_pos(s, r))
        * ex(cfg.w_r, err_body_rot(s, r))
        * ex(cfg.w_pv, err_body_vel(s, r))
        * ex(cfg.w_rv, err_dof_vel(s, r));
    if ball_free {
        return rb;
    }
    let ro = ex(cfg.w_op, err_ball_pos(s, r))
        * ex(cfg.w_or, err_ball_rot(s, r))
        * ex(cfg.w_opv, err_ball_linvel(s, r))
        * ex(cfg.w_orv, err_ball_angvel(s, r));
    rb * ro * ex(cfg.w_ig, err_relative(s, r))
}

/// The similarity the STF connection uses under `compat` ([`similarity`] or [`code_similarity`]).
pub fn connection_similarity(
    s: &HoiState,
    r: &HoiState,
    cfg: &RewardConfig,
    ball_free: bool,
    compat: Compat,
) -> f64 {
    if compat.is_code() {
        code_similarity(s, r, ball_free)
    } else {
        similarity(s, r, cfg, ball_free)
    }
}

/// Squared rotation angle (rad²) between two rotations given as rotation vectors.
fn sq_angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    Quat::from_rotvec(a).conj().mul(Quat::from_rotvec(b)).angle().powi(2)
}

/// The released code's STF similarity (reference-facts §9.5 step 2), sim_pose·sim_obj·sim_rel:
/// * sim_pose = exp(−2·d_pos)·exp(−0.1·d_posvel)·exp(−2·d_rootrot)·exp(−2·d_rot) with d_pos the
///   Euclidean norm (m) of the 51 key-body coordinate differences, d_posvel their velocities'
///   mean squared difference, d_rootrot the squared root rotation angle (rad²) and d_rot the mean
///   over the 52 joints of the squared joint rotation angle difference;
/// * sim_obj = exp(−mean squared ball-position difference)·exp(−0.1·mean squared ball-velocity
///   difference); sim_rel = exp(−2·mean squared difference of the 51 key-body − ball vectors);
/// * clips without a ball: sim_pose only, with weights 1, 0.1, 1, 1 and a factor
///   exp(−(root height difference)²).
///
/// Two defects of the released code are not reproduced (our choice): it squares the clip's
/// key-body positions before subtracting (operator precedence) and reads the "perturbed" key
/// bodies from the previous episode's last state; here both states are the real ones (the
/// perturbed start after forward kinematics).
pub fn code_similarity(s: &HoiState, r: &HoiState, ball_free: bool) -> f64 {
    let mut d_pos = 0.0;
    let mut d_vel = 0.0;
    for k in 0..NUM_KEY {
        for a in 0..3 {
            d_pos += (s.key_pos[k][a] - r.key_pos[k][a]).powi(2);
            d_vel += (s.key_vel[k][a] - r.key_vel[k][a]).powi(2);
        }
    }
    let d_pos = d_pos.sqrt();
    let d_vel = d_vel / (3 * NUM_KEY) as f64;
    let d_root = sq_angle(s.root_rotvec, r.root_rotvec);
    let d_rot = (0..NUM_JOINTS)
        .map(|j| {
            let v = |x: &[f64]| [x[3 * j], x[3 * j + 1], x[3 * j + 2]];
            sq_angle(v(&s.dof_pos), v(&r.dof_pos))
        })
        .sum::<f64>()
        / NUM_JOINTS as f64;
    if ball_free {
        let dz = s.root_pos[2] - r.root_pos[2];
        return (-d_pos - 0.1 * d_vel - d_root - d_rot - dz * dz).exp();
    }
    let pose = (-2.0 * d_pos - 0.1 * d_vel - 2.0 * d_root - 2.0 * d_rot).exp();
    let obj = (-err_ball_pos(s, r) - 0.1 * err_ball_linvel(s, r)).exp();
    let mut d_rel = 0.0;
    for k in 0..NUM_KEY {
        for a in 0..3 {
            d_rel +=
                ((s.key_pos[k][a] - s.ball_pos[a]) - (r.key_pos[k][a] - r.ball_pos[a])).powi(2);
        }
    }
    pose * obj * (-2.0 * d_rel / (3 * NUM_KEY) as f64).exp()
}

/// Masked bridging steps under `compat`: [`masked_steps`] (paper) or [`masked_steps_code`].
pub fn bridge_steps(beta: f64, n_max: usize, tau: f64, compat: Compat) -> usize {
    if compat.is_code() { masked_steps_code(beta, n_max) } else { masked_steps(beta, n_max, tau) }
}

/// The released code's count: N = 0 for β > 0.5, else min(−⌊log10 β⌋, N_max); N_max for β ≤ 0
/// or NaN.
pub fn masked_steps_code(beta: f64, n_max: usize) -> usize {
    if !(beta > 0.0) {
        return n_max;
    }
    if beta > 0.5 {
        return 0;
    }
    let n = -beta.log10().floor();
    if n >= n_max as f64 { n_max } else { n.max(0.0) as usize }
}

/// Masked bridging steps after a connection of similarity `beta`:
/// N = min(−⌈log10 β⌉, N_max), i.e. the largest n with 10⁻ⁿ ≥ β; N = 0 for β ≥ 1 (β > 0.1
/// gives 0 as well) and N = N_max for β below the floor τ (or NaN).
///
/// Counted without `log10` so that exact powers of ten land on their integer (β = 0.1 → 1,
/// β = 0.01 → 2): 10⁻ⁿ computed as 1/10ⁿ is the correctly rounded decimal literal for n ≤ 22.
pub fn masked_steps(beta: f64, n_max: usize, tau: f64) -> usize {
    if !(beta >= tau) {
        return n_max;
    }
    let mut n = 0;
    while n < n_max && n < 22 && 1.0 / 10f64.powi(n as i32 + 1) >= beta {
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use skillmimic_core::characters::skillmimic::NUM_DOFS;
    use skillmimic_core::math::Quat;
    use skillmimic_motion::NUM_KEY;

    fn state() -> HoiState {
        HoiState {
            root_pos: [0.1, -0.2, 0.9],
            root_rotvec: [1.2, 0.1, -0.3],
            dof_pos: [0.05; NUM_DOFS],
            dof_vel: [0.3; NUM_DOFS],
            ball_pos: [0.5, 0.1, 1.0],
            ball_quat: Quat::IDENTITY,
            ball_linvel: [1.0, 0.0, -2.0],
            ball_angvel: [0.0, 3.0, 0.0],
            key_pos: std::array::from_fn(|k| [0.01 * k as f64, 0.2, 0.05 * k as f64]),
            key_vel: [[0.1, 0.2, 0.3]; NUM_KEY],
        }
    }

    #[test]
    fn similarity_matches_hand_computed_value() {
        let r = state();
        let mut s = state();
        s.root_pos[0] += 0.3;
        s.ball_pos[2] += 0.2;
        s.dof_pos[7] += 0.4;
        let cfg = RewardConfig::default(); // w_p 20, w_r 20, w_op 1, w_ig 20, velocity weights 0
        // body position: root moved 0.3 in x -> 0.09 over 54 numbers
        let e_p: f64 = 0.09 / 54.0;
        // rotation: one joint component off by 0.4 -> 0.16 over 159 numbers
        let e_r: f64 = 0.16 / 159.0;
        // ball: 0.2 in z -> 0.04 over 3
        let e_op: f64 = 0.04 / 3.0;
        // relative: root - ball changes by (0.3, 0, -0.2) -> 0.13; each of 17 key bodies by
        // (0, 0, -0.2) -> 17 * 0.04 = 0.68; 0.81 over 54
        let e_rel: f64 = 0.81 / 54.0;
        let want =
            (-20.0 * e_p).exp() * (-20.0 * e_r).exp() * (-e_op).exp() * (-20.0 * e_rel).exp();
        let got = similarity(&s, &r, &cfg, false);
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        // ball-free clips: only the body terms
        let want_b = (-20.0 * e_p).exp() * (-20.0 * e_r).exp();
        assert!((similarity(&s, &r, &cfg, true) - want_b).abs() < 1e-12);
        // identical states are fully similar
        assert_eq!(similarity(&r, &r, &cfg, false), 1.0);
    }

    #[test]
    fn masked_steps_match_hand_computed_counts() {
        let (n_max, tau) = (10, 1e-10);
        for (beta, want) in [
            (1.0, 0),
            (0.5, 0),
            (0.1000001, 0),
            (0.1, 1),
            (0.05, 1),
            (0.01, 2),
            (0.0099, 2), // -ceil(log10 0.0099) = -ceil(-2.004) = 2
            (1e-5, 5),
            (2e-10, 9),
            (1e-10, 10),
            (5e-11, 10), // below tau: N_max
            (0.0, 10),
            (f64::NAN, 10),
        ] {
            assert_eq!(masked_steps(beta, n_max, tau), want, "beta {beta}");
        }
        assert_eq!(masked_steps(1e-5, 3, tau), 3);
        assert_eq!(masked_steps(0.3, 0, tau), 0);
    }
}
