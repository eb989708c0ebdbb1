//! `env.compat` at the level of its formulas: each switch changes exactly its quantity, checked
//! against hand computations from reference-facts §9.5, §9.7 and §1.8 (not from our code).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::{Quat, wrap_angle};
use skillmimic_env::Compat;
use skillmimic_env::config::{AtsConfig, ContactGraphMode, NoiseEps, RewardConfig, RewardVariant};
use skillmimic_env::hoi::{ContactGraph, HoiState};
use skillmimic_env::reward;
use skillmimic_env::v2::ats::AdaptiveSampler;
use skillmimic_env::v2::similarity::{
    bridge_steps, code_similarity, connection_similarity, masked_steps, masked_steps_code,
    similarity,
};
use skillmimic_env::v2::transition::{from_roll_pitch_yaw, perturb, to_roll_pitch_yaw};
use skillmimic_motion::testing::synthetic_rows;
use skillmimic_motion::{Clip, MotionLibrary, NUM_KEY};
use skillmimic_sim::ResetState;

fn base_state() -> ResetState {
    let mut s = ResetState {
        root_pos: [0.4, -0.3, 0.9],
        root_quat: from_roll_pitch_yaw([0.3, -0.2, 1.1]),
        root_linvel: [0.5, 0.1, 0.0],
        root_angvel_local: [0.0, 0.2, -0.1],
        ..Default::default()
    };
    let b = s.ball_mut();
    b.pos = [0.8, 0.2, 1.0];
    b.quat = from_roll_pitch_yaw([-0.4, 0.25, 2.0]);
    b.linvel = [1.0, -0.5, 2.0];
    b.angvel_local = [3.0, 0.0, 0.0];
    s
}

/// Mean and standard deviation.
fn stats(x: &[f64]) -> (f64, f64) {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (m, (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len() as f64).sqrt())
}

#[test]
fn roll_pitch_yaw_round_trips_and_composes_z_y_x() {
    let e = [0.3, -0.7, 2.5];
    let q = from_roll_pitch_yaw(e);
    let back = to_roll_pitch_yaw(q);
    assert!(e.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-12), "{back:?}");
    // R_z(yaw) R_y(pitch) R_x(roll) applied to x: (cy cp, sy cp, −sp)
    let v = q.rotate([1.0, 0.0, 0.0]);
    let want = [e[2].cos() * e[1].cos(), e[2].sin() * e[1].cos(), -e[1].sin()];
    assert!(v.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{v:?}");
}

#[test]
fn code_noise_is_the_released_codes_biased_gaussian_without_xy_noise() {
    let eps = NoiseEps::default();
    let base = base_state();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (mut dof, mut dof_v, mut lin, mut ball_v, mut dz, mut bz) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut max_euler = 0.0f64;
    for _ in 0..4000 {
        let mut s = base.clone();
        perturb(&mut s, &eps, true, Compat::Code, false, &mut rng);
        // no x/y noise on the root or the ball
        assert_eq!(
            (s.root_pos[0], s.root_pos[1], s.ball().pos[0], s.ball().pos[1]),
            (base.root_pos[0], base.root_pos[1], base.ball().pos[0], base.ball().pos[1])
        );
        dz.push(s.root_pos[2] - base.root_pos[2]);
        bz.push(s.ball().pos[2] - base.ball().pos[2]);
        for (q, b) in [(s.root_quat, base.root_quat), (s.ball().quat, base.ball().quat)] {
            let (a, c) = (to_roll_pitch_yaw(q), to_roll_pitch_yaw(b));
            for k in 0..3 {
                max_euler = max_euler.max(wrap_angle(a[k] - c[k]).abs());
            }
        }
        dof.extend(s.dof_pos.iter().zip(&base.dof_pos).map(|(a, b)| a - b));
        dof_v.extend(s.dof_vel.iter().zip(&base.dof_vel).map(|(a, b)| a - b));
        lin.extend(s.root_linvel.iter().zip(&base.root_linvel).map(|(a, b)| a - b));
        ball_v.extend(s.ball().linvel.iter().zip(&base.ball().linvel).map(|(a, b)| a - b));
    }
    // heights: upward only, uniform on [0, 0.1] (mean 0.05)
    for h in [&dz, &bz] {
        assert!(h.iter().all(|&d| (0.0..=0.1).contains(&d)));
        assert!((stats(h).0 - 0.05).abs() < 0.003, "{:?}", stats(h));
    }
    // Euler angles each within ±0.1 and using the range
    assert!(max_euler <= 0.1 + 1e-9 && max_euler > 0.095, "{max_euler}");
    // 0.1·(2·N(0,1) − 1): mean −0.1, std 0.2
    for (name, x) in [("dof", &dof), ("dof vel", &dof_v), ("root vel", &lin), ("ball vel", &ball_v)]
    {
        let (m, sd) = stats(x);
        assert!((m + 0.1).abs() < 0.01 && (sd - 0.2).abs() < 0.01, "{name}: mean {m}, std {sd}");
    }
    // after a get-up episode: w = 1 for the root height and joints 0.5·(2·N − 1)
    let mut d2 = vec![];
    let mut max_h = 0.0f64;
    for _ in 0..1000 {
        let mut s = base.clone();
        perturb(&mut s, &eps, true, Compat::Code, true, &mut rng);
        d2.extend(s.dof_pos.iter().zip(&base.dof_pos).map(|(a, b)| a - b));
        max_h = max_h.max(s.root_pos[2] - base.root_pos[2]);
    }
    let (m, sd) = stats(&d2);
    assert!((m + 0.5).abs() < 0.02 && (sd - 1.0).abs() < 0.02, "after get-up: mean {m}, std {sd}");
    assert!(max_h > 0.9 && max_h <= 1.0);
    // the paper profile: uniform, zero mean, x/y perturbed
    let mut p = vec![];
    let mut moved_xy = false;
    for _ in 0..1000 {
        let mut s = base.clone();
        perturb(&mut s, &eps, true, Compat::Paper, true, &mut rng);
        p.extend(s.dof_pos.iter().zip(&base.dof_pos).map(|(a, b)| a - b));
        moved_xy |= s.root_pos[0] != base.root_pos[0];
    }
    let (m, sd) = stats(&p);
    assert!(
        m.abs() < 0.005 && (sd - 0.1 / 3f64.sqrt()).abs() < 0.003 && moved_xy,
        "paper: mean {m}, std {sd}"
    );
}

fn hoi() -> HoiState {
    HoiState {
        root_pos: [0.1, -0.2, 0.9],
        root_rotvec: [0.0, 0.0, 0.7],
        dof_pos: [0.0; NUM_DOFS],
        dof_vel: [0.0; NUM_DOFS],
        ball_pos: [0.5, 0.1, 1.0],
        ball_quat: Quat::IDENTITY,
        ball_linvel: [1.0, 0.0, -2.0],
        ball_angvel: [0.0; 3],
        key_pos: std::array::from_fn(|k| [0.02 * k as f64, 0.2, 0.05 * k as f64]),
        key_vel: [[0.1, 0.2, 0.3]; NUM_KEY],
    }
}

#[test]
fn code_similarity_matches_a_hand_computation() {
    let r = hoi();
    let mut s = hoi();
    s.key_pos[0][0] += 0.3; // key body 0 moves by (0.3, 0, 0.4): Euclidean distance 0.5
    s.key_pos[0][2] += 0.4;
    s.key_vel[3][1] += 1.0; // one velocity component off by 1: 1/51
    s.root_rotvec[2] += 0.2; // root turned by 0.2 rad about z: 0.04
    s.dof_pos[3 * 5 + 1] = 0.3; // joint 5 turned by 0.3 rad: 0.09 / 52
    s.ball_pos[2] += 0.3; // ball 0.3 up: mean 0.09 / 3
    s.ball_linvel[0] += 0.6; // ball velocity: 0.36 / 3
    s.root_pos[2] += 0.1; // root height (only in the ball-free form)
    // key − ball vectors: 16 bodies change by (0, 0, −0.3) → 16·0.09; body 0 by (0.3, 0, 0.1) → 0.1
    let d_rel: f64 = (16.0 * 0.09 + 0.1) / 51.0;
    let pose = (-2.0 * 0.5 - 0.1 / 51.0 - 2.0 * 0.04 - 2.0 * 0.09 / 52.0f64).exp();
    let obj = (-0.09 / 3.0 - 0.1 * 0.36 / 3.0f64).exp();
    let want = pose * obj * (-2.0 * d_rel).exp();
    let got = code_similarity(&s, &r, false);
    assert!((got / want - 1.0).abs() < 1e-12, "{got} vs {want}");
    // ball-free clips: weights 1, 0.1, 1, 1 and exp(−Δz²), no ball terms
    let want_free = (-0.5 - 0.1 / 51.0 - 0.04 - 0.09 / 52.0 - 0.01f64).exp();
    assert!((code_similarity(&s, &r, true) / want_free - 1.0).abs() < 1e-12);
    // the switch picks the similarity, and the two differ on this state
    let cfg = RewardConfig::default();
    assert_eq!(connection_similarity(&s, &r, &cfg, false, Compat::Code), got);
    assert_eq!(
        connection_similarity(&s, &r, &cfg, false, Compat::Paper),
        similarity(&s, &r, &cfg, false)
    );
    assert!((similarity(&s, &r, &cfg, false) - got).abs() > 1e-3);
    assert_eq!(code_similarity(&r, &r, false), 1.0);
}

#[test]
fn code_bridge_counts_use_floor_and_the_one_half_cut_off() {
    for (beta, want) in [
        (0.9, 0),
        (0.5000001, 0),
        (0.5, 1),
        (0.3, 1),
        (0.1, 1),
        (0.05, 2),
        (0.01, 2),
        (0.0099, 3),
        (1e-5, 5),
        (1e-12, 10),
        (0.0, 10),
        (f64::NAN, 10),
    ] {
        assert_eq!(masked_steps_code(beta, 10), want, "beta {beta}");
        assert_eq!(bridge_steps(beta, 10, 1e-10, Compat::Code), want);
        assert_eq!(bridge_steps(beta, 10, 1e-10, Compat::Paper), masked_steps(beta, 10, 1e-10));
    }
    // where the two rules differ: 0.3 (paper 0: 10^-1 < 0.3), 0.0099 (paper ⌈2.004⌉ = 2 vs code 3)
    assert_eq!((masked_steps(0.3, 10, 1e-10), masked_steps(0.0099, 10, 1e-10)), (0, 2));
}

#[test]
fn masked_reward_rule_follows_the_profile_unless_set() {
    use skillmimic_env::config::{BridgeConfig, MaskedReward};
    let b = BridgeConfig::default();
    assert_eq!(b.masked_reward(Compat::Paper), MaskedReward::Exclude);
    assert_eq!(b.masked_reward(Compat::Code), MaskedReward::ReplaceWithClipMean);
    let set = BridgeConfig { masked_reward: Some(MaskedReward::Exclude), ..b };
    assert_eq!(set.masked_reward(Compat::Code), MaskedReward::Exclude);
}

fn clip(name: &str, skill: u32) -> Clip {
    Clip::from_rows(name.into(), "compat test".into(), skill, 60.0, 12, &synthetic_rows(12))
}

#[test]
fn ats_starts_from_the_class_balanced_weights_in_the_code_profile() {
    // pickup (label 1) twice, class 2 three times: class-balanced weights with pickup doubled
    // are 1/2·2 = 1 per pickup clip and 1/3 per class-2 clip → [1/3, 1/3, 1/9, 1/9, 1/9]
    let lib = MotionLibrary::from_clips(vec![
        clip("001_a", 1),
        clip("001_b", 1),
        clip("002_a", 2),
        clip("002_b", 2),
        clip("002_c", 2),
    ])
    .unwrap();
    let want_code = [1.0 / 3.0, 1.0 / 3.0, 1.0 / 9.0, 1.0 / 9.0, 1.0 / 9.0];
    let want_paper = [0.25, 0.25, 1.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0];
    let cfg = AtsConfig { enabled: true, update_interval: 2, ..Default::default() };
    let mut code = AdaptiveSampler::new(&lib, &cfg, Some(lib.weights()));
    let mut paper = AdaptiveSampler::new(&lib, &cfg, None);
    for (p, w) in code.clip_probs().iter().zip(want_code) {
        assert!((p - w).abs() < 1e-12, "{p} vs {w}");
    }
    for (p, w) in paper.clip_probs().iter().zip(want_paper) {
        assert!((p - w).abs() < 1e-12, "{p} vs {w}");
    }
    // frames are uniform in both; after the first update both follow the same ATS rule
    assert_eq!(code.frame_probs(2), paper.frame_probs(2));
    for s in [&mut code, &mut paper] {
        s.record(0, 3, 0.4);
        s.tick();
        assert!(s.tick());
    }
    assert_eq!(code.clip_probs(), paper.clip_probs());
}

#[test]
fn deepmimic_baseline_sums_its_terms_in_the_code_profile() {
    let r = hoi();
    let mut s = hoi();
    s.key_pos[2][1] += 0.2;
    s.dof_pos[7] = 0.3;
    s.ball_pos[0] += 0.1;
    let cfg = RewardConfig {
        variant: RewardVariant::Deepmimic,
        contact_graph: ContactGraphMode::ForceThreshold,
        ..Default::default()
    };
    let cg = ContactGraph::reference(0.0, ContactGraphMode::ForceThreshold);
    let prev = [0.0; NUM_DOFS];
    let paper = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Paper, false);
    let code = reward::compute(&s, &prev, &r, &cg, &cg, &cfg, Compat::Code, false);
    // every term identical, the total is the sum instead of the mean
    let (mut a, mut b) = (paper.as_array(), code.as_array());
    let (ta, tb) = (a[a.len() - 1], b[b.len() - 1]);
    a[a.len() - 1] = 0.0;
    b[b.len() - 1] = 0.0;
    assert_eq!(a, b);
    assert!((tb - (code.p + code.r + code.rv + code.op)).abs() < 1e-15);
    assert!((tb - 4.0 * ta).abs() < 1e-15 && tb > 1.0);
    // the unified reward does not depend on the profile
    let sm = RewardConfig { variant: RewardVariant::Skillmimic, ..cfg };
    assert_eq!(
        reward::compute(&s, &prev, &r, &cg, &cg, &sm, Compat::Paper, false).as_array(),
        reward::compute(&s, &prev, &r, &cg, &cg, &sm, Compat::Code, false).as_array()
    );
}
