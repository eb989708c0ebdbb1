//! The unified HOI imitation reward (SkillMimic seed 000 §4, reference-facts §5) and its variants.
//!
//! Every term is exp(−w · e) with e a mean of squared differences between the simulated state
//! after the step and the reference frame it should reach:
//!
//! | term | e | default w |
//! |---|---|---|
//! | r_p | mean over 54 of (root ⊕ 17 key-body positions) | 20 |
//! | r_r | mean over 159 of (root exp map ⊕ 156 joint exp maps), plain component difference | 20 |
//! | r_pv | mean over 51 of key-body velocities | 0 |
//! | r_rv | mean over 156 of joint velocities | 0 |
//! | r_reg | mean over 156 of (v_t − v_{t−1})² / (1 + 10¹²·v̂²) (v sim joint velocity, v̂ reference) | 0.1 |
//! | r_op | mean over 3 of ball position | 1 |
//! | r_or | squared rotation angle of the ball | 0 |
//! | r_opv | mean over 3 of ball velocity | 0 |
//! | r_orv | mean over 3 of ball angular velocity | 0 |
//! | r_ig | mean over 54 of (root − ball ⊕ key bodies − ball) | 20 |
//! | r_cg | ∏ exp(−w_k·\|c_k − ĉ_k\|) over the contact-graph entries | 5 each |
//!
//! r = r_b · r_o · r_ig · r_cg with r_b = r_p r_r r_pv r_rv r_reg and r_o = r_op r_or r_opv r_orv.
//! For clips without a ball (skill labels 0 and 10) only r_b counts.

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_motion::NUM_KEY;

use crate::compat::Compat;
use crate::config::{ContactGraphMode, RewardConfig, RewardVariant};
use crate::hoi::{ContactGraph, HoiState};

/// Names of the entries of [`RewardTerms::as_array`].
pub const TERM_NAMES: [&str; 12] =
    ["p", "r", "pv", "rv", "reg", "op", "or", "opv", "orv", "ig", "cg", "total"];
/// Number of reward entries reported per step.
pub const NUM_TERMS: usize = TERM_NAMES.len();

/// All sub-rewards of one step (each in (0, 1]) and the combined reward.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RewardTerms {
    pub p: f64,
    pub r: f64,
    pub pv: f64,
    pub rv: f64,
    pub reg: f64,
    pub op: f64,
    pub or: f64,
    pub opv: f64,
    pub orv: f64,
    pub ig: f64,
    pub cg: f64,
    pub total: f64,
}

impl RewardTerms {
    /// Entries in [`TERM_NAMES`] order.
    pub fn as_array(&self) -> [f64; NUM_TERMS] {
        [
            self.p, self.r, self.pv, self.rv, self.reg, self.op, self.or, self.opv, self.orv,
            self.ig, self.cg, self.total,
        ]
    }
}

#[inline]
fn sq3(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Mean squared error of root + key-body positions (54 numbers).
pub fn err_body_pos(s: &HoiState, r: &HoiState) -> f64 {
    let mut e = sq3(s.root_pos, r.root_pos);
    for k in 0..NUM_KEY {
        e += sq3(s.key_pos[k], r.key_pos[k]);
    }
    e / (3.0 * (NUM_KEY + 1) as f64)
}

/// Mean squared error of root exp map + joint exp maps (159 numbers, no angle wrapping).
pub fn err_body_rot(s: &HoiState, r: &HoiState) -> f64 {
    let mut e = sq3(s.root_rotvec, r.root_rotvec);
    for j in 0..NUM_DOFS {
        e += (s.dof_pos[j] - r.dof_pos[j]).powi(2);
    }
    e / (3 + NUM_DOFS) as f64
}

/// Mean squared error of key-body velocities (51 numbers).
pub fn err_body_vel(s: &HoiState, r: &HoiState) -> f64 {
    (0..NUM_KEY).map(|k| sq3(s.key_vel[k], r.key_vel[k])).sum::<f64>() / (3 * NUM_KEY) as f64
}

/// Mean squared error of joint velocities (156 numbers).
pub fn err_dof_vel(s: &HoiState, r: &HoiState) -> f64 {
    (0..NUM_DOFS).map(|j| (s.dof_vel[j] - r.dof_vel[j]).powi(2)).sum::<f64>() / NUM_DOFS as f64
}

/// Velocity regulariser error: mean of (v_t − v_{t−1})² / (1 + scale·v̂²).
pub fn err_regulariser(
    s: &HoiState,
    prev_dof_vel: &[f64; NUM_DOFS],
    r: &HoiState,
    scale: f64,
) -> f64 {
    (0..NUM_DOFS)
        .map(|j| {
            (s.dof_vel[j] - prev_dof_vel[j]).powi(2) / (1.0 + scale * r.dof_vel[j] * r.dof_vel[j])
        })
        .sum::<f64>()
        / NUM_DOFS as f64
}

/// Mean squared error of the ball position.
pub fn err_ball_pos(s: &HoiState, r: &HoiState) -> f64 {
    sq3(s.ball_pos, r.ball_pos) / 3.0
}

/// Squared rotation angle between the ball orientations.
pub fn err_ball_rot(s: &HoiState, r: &HoiState) -> f64 {
    s.ball_quat.conj().mul(r.ball_quat).angle().powi(2)
}

/// Mean squared error of the ball linear velocity.
pub fn err_ball_linvel(s: &HoiState, r: &HoiState) -> f64 {
    sq3(s.ball_linvel, r.ball_linvel) / 3.0
}

/// Mean squared error of the ball angular velocity (world frame).
pub fn err_ball_angvel(s: &HoiState, r: &HoiState) -> f64 {
    sq3(s.ball_angvel, r.ball_angvel) / 3.0
}

/// Mean squared error of the interaction-graph vectors (root and key bodies minus the ball).
pub fn err_relative(s: &HoiState, r: &HoiState) -> f64 {
    let rel = |a: [f64; 3], ball: [f64; 3]| [a[0] - ball[0], a[1] - ball[1], a[2] - ball[2]];
    let mut e = sq3(rel(s.root_pos, s.ball_pos), rel(r.root_pos, r.ball_pos));
    for k in 0..NUM_KEY {
        e += sq3(rel(s.key_pos[k], s.ball_pos), rel(r.key_pos[k], r.ball_pos));
    }
    e / (3.0 * (NUM_KEY + 1) as f64)
}

/// Contact-graph reward ∏ exp(−w_k |c_k − ĉ_k|) with the weights of the configured mode.
pub fn contact_graph_reward(
    sim: &ContactGraph,
    reference: &ContactGraph,
    cfg: &RewardConfig,
) -> f64 {
    let w: [f64; 4] = match cfg.contact_graph {
        ContactGraphMode::Exact => {
            [cfg.w_cg_hand_ball, cfg.w_cg_body_ball, cfg.w_cg_hand_body, cfg.w_cg_body_floor]
        }
        ContactGraphMode::ForceThreshold => [cfg.w_cg2_ball, cfg.w_cg1_body, 0.0, 0.0],
    };
    (0..sim.len).map(|i| (-w[i] * (sim.values[i] - reference.values[i]).abs()).exp()).product()
}

/// Compute every term and the combined reward.
///
/// `prev_dof_vel` are the simulated joint velocities of the previous step (or of the reset
/// state); `ball_free` marks clips without a ball (skill labels 0 and 10); `compat` decides how
/// the DeepMimic baseline combines its terms (mean: `paper`, sum: `code`).
#[allow(clippy::too_many_arguments)]
pub fn compute(
    sim: &HoiState,
    prev_dof_vel: &[f64; NUM_DOFS],
    reference: &HoiState,
    cg_sim: &ContactGraph,
    cg_ref: &ContactGraph,
    cfg: &RewardConfig,
    compat: Compat,
    ball_free: bool,
) -> RewardTerms {
    let ex = |w: f64, e: f64| (-w * e).exp();
    if cfg.variant == RewardVariant::Deepmimic {
        let d = &cfg.deepmimic;
        let p = ex(d.w_p, err_body_pos(sim, reference));
        let r = ex(d.w_r, err_body_rot(sim, reference));
        let rv = ex(d.w_rv, err_dof_vel(sim, reference));
        let op = if ball_free { 1.0 } else { ex(d.w_op, err_ball_pos(sim, reference)) };
        let sum = p + r + rv + op;
        let total = if compat.is_code() { sum } else { sum / 4.0 };
        return RewardTerms {
            p,
            r,
            pv: 1.0,
            rv,
            reg: 1.0,
            op,
            or: 1.0,
            opv: 1.0,
            orv: 1.0,
            ig: 1.0,
            cg: 1.0,
            total,
        };
    }
    let p = ex(cfg.w_p, err_body_pos(sim, reference));
    let r = ex(cfg.w_r, err_body_rot(sim, reference));
    let pv = ex(cfg.w_pv, err_body_vel(sim, reference));
    let rv = ex(cfg.w_rv, err_dof_vel(sim, reference));
    let reg = ex(cfg.w_reg, err_regulariser(sim, prev_dof_vel, reference, cfg.reg_scale));
    let (op, or, opv, orv, ig, cg) = if ball_free {
        (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    } else {
        (
            ex(cfg.w_op, err_ball_pos(sim, reference)),
            ex(cfg.w_or, err_ball_rot(sim, reference)),
            ex(cfg.w_opv, err_ball_linvel(sim, reference)),
            ex(cfg.w_orv, err_ball_angvel(sim, reference)),
            ex(cfg.w_ig, err_relative(sim, reference)),
            contact_graph_reward(cg_sim, cg_ref, cfg),
        )
    };
    let rb = p * r * pv * rv * reg;
    let ro = op * or * opv * orv;
    let total = match cfg.variant {
        RewardVariant::Skillmimic => rb * ro * ig * cg,
        RewardVariant::NoContactGraph => rb * ro * ig,
        RewardVariant::Additive => (rb + ro + ig + cg) / 4.0,
        RewardVariant::Deepmimic => unreachable!("handled above"),
    };
    RewardTerms { p, r, pv, rv, reg, op, or, opv, orv, ig, cg, total }
}
