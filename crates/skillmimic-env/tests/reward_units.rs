//! Hand-computed checks of each reward term, the heading frame, tan-norm 6D, the observation
//! blocks and the contact graph.

use std::f64::consts::{FRAC_PI_2, PI};

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::{Quat, heading, heading_inverse, tan_norm};
use skillmimic_env::Compat;
use skillmimic_env::config::{ContactGraphMode, RewardConfig, RewardVariant};
use skillmimic_env::hoi::{ContactGraph, HoiState};
use skillmimic_env::reward::{self, contact_graph_reward};
use skillmimic_motion::NUM_KEY;

fn base() -> HoiState {
    HoiState {
        root_pos: [0.0, 0.0, 1.0],
        root_rotvec: [FRAC_PI_2, 0.0, 0.0],
        dof_pos: [0.0; NUM_DOFS],
        dof_vel: [0.0; NUM_DOFS],
        ball_pos: [0.5, 0.0, 1.0],
        ball_quat: Quat::IDENTITY,
        ball_linvel: [0.0; 3],
        ball_angvel: [0.0; 3],
        key_pos: [[0.0, 0.0, 1.0]; NUM_KEY],
        key_vel: [[0.0; 3]; NUM_KEY],
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn each_term_matches_a_hand_computed_value() {
    let cfg = RewardConfig::default();
    let r = base();
    let mut s = base();
    let prev = [0.0; NUM_DOFS];
    let cg = ContactGraph::reference(0.0, ContactGraphMode::Exact);

    // identical states: every term is 1
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, false);
    assert!(t.as_array().iter().all(|&v| close(v, 1.0)), "{t:?}");

    // body position: root off by 0.1 m in x -> e_p = 0.01 / 54, and the root-ball vector moves
    // by the same 0.1 m -> e_ig = 0.01 / 54
    s.root_pos[0] = 0.1;
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, false);
    assert!(close(t.p, (-20.0f64 * 0.01 / 54.0).exp()));
    assert!(close(t.ig, (-20.0f64 * 0.01 / 54.0).exp()));
    assert!(close(t.total, t.p * t.ig));

    // body rotation: one dof off by 0.3 rad -> e_r = 0.09 / 159
    let mut s = base();
    s.dof_pos[10] = 0.3;
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, false);
    assert!(close(t.r, (-20.0f64 * 0.09 / 159.0).exp()));

    // ball 0.2 m higher: e_op = 0.04/3; the interaction graph sees all 18 vectors shift by 0.2 m
    let mut s = base();
    s.ball_pos[2] += 0.2;
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, false);
    assert!(close(t.op, (-0.04f64 / 3.0).exp()));
    assert!(close(t.ig, (-20.0f64 * 18.0 * 0.04 / 54.0).exp()));

    // regulariser: dof 3 accelerates by 2 rad/s where the reference is static, dof 4 by 2 rad/s
    // where the reference moves at 0.5 rad/s (denominator 1 + 1e12 * 0.25)
    let mut s = base();
    let mut r2 = base();
    s.dof_vel[3] = 2.0;
    s.dof_vel[4] = 2.0;
    r2.dof_vel[4] = 0.5;
    let e = (4.0 + 4.0 / (1.0 + 1e12 * 0.25)) / 156.0;
    let t = reward::compute(&s, &prev, &r2, &cg, &cg, &cfg, Compat::Paper, false);
    assert!(close(t.reg, (-0.1f64 * e).exp()));
    // with w_rv = 0 the velocity mismatch itself does not count
    assert!(close(t.rv, 1.0));

    // velocity terms with non-zero weights
    let mut c2 = cfg.clone();
    c2.w_rv = 0.5;
    c2.w_pv = 2.0;
    c2.w_opv = 3.0;
    let mut s = base();
    s.dof_vel[0] = 1.0;
    s.key_vel[2] = [0.0, 0.3, 0.0];
    s.ball_linvel = [0.0, 0.0, -1.5];
    let t = reward::compute(&s, &s.dof_vel, &r, &cg, &cg, &c2, Compat::Paper, false);
    assert!(close(t.rv, (-0.5f64 / 156.0).exp()));
    assert!(close(t.pv, (-2.0f64 * 0.09 / 51.0).exp()));
    assert!(close(t.opv, (-3.0f64 * 2.25 / 3.0).exp()));

    // ball rotation term: 90 degrees about z -> angle^2 = (pi/2)^2
    let mut c3 = cfg.clone();
    c3.w_or = 1.0;
    let mut s = base();
    s.ball_quat = Quat::about_z(FRAC_PI_2);
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &c3, Compat::Paper, false);
    assert!((t.or - (-(FRAC_PI_2 * FRAC_PI_2)).exp()).abs() < 1e-12);

    // ball-free clips: only the body part counts
    let mut s = base();
    s.ball_pos = [9.0, 9.0, 0.12];
    let t = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, true);
    assert!(close(t.op, 1.0) && close(t.ig, 1.0) && close(t.total, 1.0));
}

#[test]
fn variants_combine_the_terms_as_documented() {
    let r = base();
    let mut s = base();
    s.root_pos[0] = 0.2;
    s.ball_pos[2] += 0.3;
    let prev = [0.0; NUM_DOFS];
    let cg_ref = ContactGraph::reference(1.0, ContactGraphMode::Exact);
    let cg_sim = ContactGraph { values: [0.0, 0.0, 0.0, 0.0], len: 4 }; // missed hand-ball contact
    let mut cfg = RewardConfig::default();
    let t = reward::compute(&s, &prev, &r, &cg_sim, &cg_ref, &cfg, Compat::Paper, false);
    assert!(close(t.cg, (-5.0f64).exp()));
    assert!(close(
        t.total,
        t.p * t.r * t.pv * t.rv * t.reg * t.op * t.or * t.opv * t.orv * t.ig * t.cg
    ));
    cfg.variant = RewardVariant::NoContactGraph;
    let u = reward::compute(&s, &prev, &r, &cg_sim, &cg_ref, &cfg, Compat::Paper, false);
    assert!(close(u.total, t.total / t.cg));
    cfg.variant = RewardVariant::Additive;
    let a = reward::compute(&s, &prev, &r, &cg_sim, &cg_ref, &cfg, Compat::Paper, false);
    assert!(close(
        a.total,
        (t.p * t.r * t.pv * t.rv * t.reg + t.op * t.or * t.opv * t.orv + t.ig + t.cg) / 4.0
    ));
    cfg.variant = RewardVariant::Deepmimic;
    let d = reward::compute(&s, &prev, &r, &cg_sim, &cg_ref, &cfg, Compat::Paper, false);
    let e_p = 0.04 / 54.0;
    let e_op = 0.09 / 3.0;
    assert!(close(d.p, (-40.0f64 * e_p).exp()) && close(d.op, (-40.0f64 * e_op).exp()));
    assert!(close(d.total, (d.p + 1.0 + 1.0 + d.op) / 4.0));
}

#[test]
fn contact_graph_modes_by_hand() {
    // the paper's force-threshold graph is the default; the exact-pair graph is the option
    assert_eq!(RewardConfig::default().contact_graph, ContactGraphMode::ForceThreshold);
    let cfg = RewardConfig { contact_graph: ContactGraphMode::Exact, ..RewardConfig::default() };
    let sim = ContactGraph { values: [1.0, 1.0, 0.0, 1.0], len: 4 };
    let r = ContactGraph::reference(1.0, ContactGraphMode::Exact);
    // hand-ball correct, body-ball wrong (w 5), hand-body correct, body-floor wrong (w 5)
    assert!(close(contact_graph_reward(&sim, &r, &cfg), (-10.0f64).exp()));
    assert!(!sim.matches(&r));
    assert!(close(sim.sq_error(&r), 0.5));
    let mut c2 = cfg.clone();
    c2.contact_graph = ContactGraphMode::ForceThreshold;
    c2.w_cg2_ball = 2.0;
    c2.w_cg1_body = 3.0;
    let sim = ContactGraph { values: [0.0, 1.0, 0.0, 0.0], len: 2 };
    let r = ContactGraph::reference(1.0, ContactGraphMode::ForceThreshold);
    assert!(close(contact_graph_reward(&sim, &r, &c2), (-2.0f64 - 3.0).exp()));
}

#[test]
fn heading_frame_and_tan_norm_by_hand() {
    // the upright skeleton (Y-up turned to Z-up) has its left side (+x local) along world +x
    let upright = Quat::from_rotvec([FRAC_PI_2, 0.0, 0.0]);
    assert!(heading(upright).abs() < 1e-15);
    // turned by 30 degrees about world z
    let yaw = PI / 6.0;
    let q = Quat::about_z(yaw).mul(upright);
    assert!((heading(q) - yaw).abs() < 1e-12);
    // a world vector along the character's left side maps to +x of the heading frame
    let v = heading_inverse(q).rotate([yaw.cos(), yaw.sin(), 0.3]);
    assert!((v[0] - 1.0).abs() < 1e-12 && v[1].abs() < 1e-12 && (v[2] - 0.3).abs() < 1e-12);
    // tan-norm of the upright root in its own heading frame: x stays x, local z (forward) -> world
    // -y
    let t = tan_norm(heading_inverse(q).mul(q));
    let want = [1.0, 0.0, 0.0, 0.0, -1.0, 0.0];
    assert!(t.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{t:?}");
}
