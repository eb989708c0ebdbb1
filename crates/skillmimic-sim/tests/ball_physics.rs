//! The ball's PhysX behaviours as modelled in MuJoCo (`skillmimic_sim::mjcf`, `bounce`), each
//! measured against the same scene with that behaviour switched off: velocity damping 0.01 s⁻¹,
//! the 0.2 m/s floor bounce threshold, and the combined ball–humanoid restitution (0.405).

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::Quat;
use skillmimic_sim::{
    BALL, BallParams, BatchSim, BodyContact, ContactPair, HandModel, ResetState, RootJoint, Scene,
    SceneOptions,
};

fn sim_with(ball: BallParams, root: RootJoint) -> BatchSim {
    let scene = Arc::new(
        Scene::new(SceneOptions {
            character: skillmimic_core::characters::skillmimic::humanoid(HandModel::Box),
            root,
            ball: Some(ball),
            ..Default::default()
        })
        .unwrap(),
    );
    BatchSim::new(scene, 1, 1).unwrap()
}

fn away() -> ResetState {
    ResetState { root_pos: [5.0, 0.0, 0.95], ..Default::default() }
}

/// [`away`] with the ball at `pos`.
fn ball_at(pos: [f64; 3]) -> ResetState {
    let mut s = away();
    s.ball_mut().pos = pos;
    s
}

/// Highest ball centre (m) over `steps` policy steps after a reset to `s`, counted once the ball
/// has touched the floor.
fn apex_after_touch(sim: &mut BatchSim, s: ResetState, steps: usize) -> f64 {
    sim.reset(&[true], &[s]).unwrap();
    let zero = vec![0.0f32; NUM_DOFS];
    let (mut touched, mut apex) = (false, f64::NEG_INFINITY);
    for _ in 0..steps {
        sim.step(&zero).unwrap();
        let st = sim.state().env(0);
        touched |= st.has_contact(ContactPair::BallFloor);
        if touched {
            apex = apex.max(st.pos(BALL)[2]);
        }
    }
    apex
}

#[test]
fn slow_floor_impacts_do_not_bounce_below_the_threshold() {
    let r = 0.12;
    // released 1.5 mm above the floor: impact at 0.17 m/s, below PhysX's 0.2 m/s
    let s = ball_at([0.0, 0.0, r + 0.0015]);
    let with =
        apex_after_touch(&mut sim_with(BallParams::default(), RootJoint::Free), s.clone(), 120);
    let without = apex_after_touch(
        &mut sim_with(BallParams { bounce_threshold: 0.0, ..Default::default() }, RootJoint::Free),
        s.clone(),
        120,
    );
    println!(
        "slow impact (0.17 m/s): highest point after the first touch {:.2} mm above rest with the \
            threshold, {:.2} mm without",
        1e3 * (with - r),
        1e3 * (without - r)
    );
    assert!(with - r < 1e-4, "the ball rebounded to {:.3} mm", 1e3 * (with - r));
    assert!(
        without - r > 3e-4,
        "without the rule the soft contact rebounds ({:.3} mm)",
        1e3 * (without - r)
    );
    // a fast impact still bounces with the floor's combined restitution (0.81 + 0.8)/2
    let h = 1.0;
    let fast = ball_at([0.0, 0.0, h]);
    let apex = apex_after_touch(&mut sim_with(BallParams::default(), RootJoint::Free), fast, 90);
    let e = ((apex - r) / (h - r)).sqrt();
    println!("drop from {h} m: restitution from the apex {e:.3} (target 0.805)");
    assert!((e - 0.805).abs() < 0.03, "{e}");
}

#[test]
fn damping_slows_the_flying_ball_by_one_percent_per_second() {
    let mut s = ball_at([0.0, 0.0, 5.0]);
    s.ball_mut().linvel = [5.0, 0.0, 0.0];
    s.ball_mut().angvel_local = [0.0, 0.0, 20.0];
    s.ball_mut().quat = Quat::IDENTITY;
    let run = |ball: BallParams| {
        let mut sim = sim_with(ball, RootJoint::Free);
        sim.reset(&[true], &[s.clone()]).unwrap();
        for _ in 0..30 {
            sim.step(&vec![0.0f32; NUM_DOFS]).unwrap();
        }
        let st = sim.state().env(0);
        (st.linvel(BALL)[0], st.angvel(BALL)[2])
    };
    let (vx, wz) = run(BallParams::default());
    let (vx0, wz0) = run(BallParams { damping: 0.0, ..Default::default() });
    let decay = (-0.01f64 * 0.5).exp();
    println!(
        "after 0.5 s of flight: vx {vx:.5} m/s (undamped {vx0:.5}), wz {wz:.4} rad/s (undamped \
            {wz0:.4}); expected factor {decay:.5}"
    );
    assert!(
        (vx0 - 5.0).abs() < 1e-9 && (wz0 - 20.0).abs() < 1e-9,
        "undamped flight keeps its speed"
    );
    assert!((vx / vx0 - decay).abs() < 2e-4, "linear damping factor {}", vx / vx0);
    assert!((wz / wz0 - decay).abs() < 2e-4, "angular damping factor {}", wz / wz0);
}

/// Vertical speed (m/s) of the ball just before its first contact with the humanoid and its
/// highest upward vertical speed after, dropped from `drop` m onto the pelvis of a humanoid
/// lying on its back with the pelvis welded in place (a rigid sphere of radius 0.0985 m: the
/// ball and the pelvis are both spheres, so the impact is head-on). The hand is no test surface:
/// its 1 cm finger capsules are thinner than the ball's contact depth at these speeds
/// (v/√k ≈ 1–2 cm), and the 7.2 kg ball pushes the PD-held arm down (measured).
fn body_bounce(body_contact: BodyContact, drop: f64) -> (f64, f64) {
    let root = RootJoint::Fixed { pos: [0.0, 0.0, 0.5], quat: Quat::IDENTITY };
    let mut sim = sim_with(BallParams { body_contact, ..Default::default() }, root);
    let zero = vec![0.0f32; NUM_DOFS];
    let top = 0.5 + 0.0985 + 0.12;
    let mut s = ResetState { root_pos: [0.0, 0.0, 0.5], ..Default::default() };
    s.ball_mut().pos = [0.0, 0.0, top + drop];
    sim.reset(&[true], &[s]).unwrap();
    let (mut v_in, mut prev, mut up) = (None, 0.0, f64::NEG_INFINITY);
    for _ in 0..90 {
        sim.step(&zero).unwrap();
        let st = sim.state().env(0);
        let vz = st.linvel(BALL)[2];
        if st.pos(BALL)[2] < top - 0.05 {
            break; // fell past
        }
        if v_in.is_none() && st.has_contact(ContactPair::BodyBall) {
            v_in = Some(prev);
        }
        if v_in.is_some() {
            up = up.max(vz);
        }
        prev = vz;
    }
    (v_in.expect("the ball never touched the body"), up)
}

#[test]
fn ball_bounces_off_the_body_with_the_combined_restitution() {
    let drop = 0.2;
    let (vi, vo) = body_bounce(BodyContact::Combined, drop);
    let (vi_s, vo_s) = body_bounce(BodyContact::Soft, drop);
    let (e, e_soft) = (-vo / vi, -vo_s / vi_s);
    println!(
        "ball dropped {drop} m onto the (welded) pelvis: v_in {vi:.3} m/s, rebound {vo:.3} m/s, e \
            = {e:.3} (combined, target 0.405); soft contact: e = {e_soft:.3}"
    );
    assert!(vi < -1.5 && vi_s < -1.5);
    assert!((e - 0.405).abs() < 0.06, "combined restitution measured {e}");
    assert!(e_soft < 0.15, "the soft contact barely bounces: {e_soft}");
}
