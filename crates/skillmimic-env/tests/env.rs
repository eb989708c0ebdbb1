//! Environment-level tests on the shipped demo clips: every reward variant / contact-graph mode /
//! hand model / ball override builds and steps without NaN; episodes reset as documented; the
//! observation has the documented size and frames.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use skillmimic_core::math::Quat;
use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::config::{ContactGraphMode, RewardVariant};
use skillmimic_env::obs::{layout, write_observation};
use skillmimic_env::{EnvConfig, SkillEnv, StateInit};
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{BatchSim, HandModel, ResetState, Scene};

fn demo_library() -> Arc<MotionLibrary> {
    Arc::new(MotionLibrary::load(&[workspace_root().join("motions")]).unwrap())
}

fn config(n: usize) -> EnvConfig {
    EnvConfig {
        num_envs: n,
        threads: 2,
        motion: vec![workspace_root().join("motions")],
        ..Default::default()
    }
}

fn run(env: &mut SkillEnv, steps: usize, seed: u64) -> (usize, usize) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n = env.num_envs();
    let mut actions = vec![0.0f32; n * 156];
    let (mut term, mut trunc) = (0, 0);
    for _ in 0..steps {
        actions.iter_mut().for_each(|a| *a = 0.3 * rng.random_range(-1.0f32..1.0));
        env.step(&actions).unwrap();
        let b = env.buffers();
        assert!(b.obs.iter().all(|x| x.is_finite()), "non-finite observation");
        assert!(
            b.reward.iter().all(|r| r.is_finite() && (0.0..=1.0).contains(r)),
            "reward out of (0, 1]: {:?}",
            b.reward
        );
        assert!(b.terms.iter().all(|x| x.is_finite()));
        term += b.terminated.iter().filter(|&&t| t != 0).count();
        trunc += b.truncated.iter().filter(|&&t| t != 0).count();
        env.reset_done();
    }
    (term, trunc)
}

#[test]
fn every_variant_builds_and_steps_without_nan() {
    let lib = demo_library();
    let variants = [
        RewardVariant::Skillmimic,
        RewardVariant::NoContactGraph,
        RewardVariant::Additive,
        RewardVariant::Deepmimic,
    ];
    let modes = [ContactGraphMode::Exact, ContactGraphMode::ForceThreshold];
    let mut cases = 0;
    for (k, variant) in variants.iter().enumerate() {
        for mode in modes {
            let mut c = config(4);
            c.reward.variant = *variant;
            c.reward.contact_graph = mode;
            c.hands = if k % 2 == 0 { "full" } else { "box" }.into();
            let mut env = SkillEnv::new(c, lib.clone()).unwrap();
            let (term, trunc) = run(&mut env, 70, k as u64);
            assert!(term + trunc >= 4, "{variant:?}/{mode:?}: episodes never ended");
            cases += 1;
        }
    }
    // physical-property overrides of the ball (robustness sweeps)
    for (r, d, e) in [(0.8, 1.0, 1.0), (1.2, 1.0, 1.0), (1.0, 0.1, 1.0), (1.0, 1.0, 0.6)] {
        let mut c = config(2);
        c.ball.radius_scale = r;
        c.ball.density_scale = d;
        c.ball.restitution_scale = e;
        let mut env = SkillEnv::new(c, lib.clone()).unwrap();
        let mass =
            env.sim().scene().model().body_mass()[env.sim().scene().body_ids[skillmimic_sim::BALL]];
        let want = 1000.0 * d * 4.0 / 3.0 * std::f64::consts::PI * (0.12 * r).powi(3);
        assert!((mass - want).abs() < 1e-9, "ball mass {mass} vs {want}");
        run(&mut env, 20, 1);
        cases += 1;
    }
    println!("{cases} configurations stepped without NaN");
}

#[test]
fn episodes_follow_the_reference_timeline() {
    let mut c = config(3);
    c.state_init = StateInit::Frame(5);
    c.episode_length = 10;
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    let zero = vec![0.0f32; 3 * 156];
    for k in 1..=9 {
        env.step(&zero).unwrap();
        for i in 0..3 {
            let ep = env.episode(i);
            assert_eq!((ep.ref_start, ep.progress, ep.ref_frame()), (5, k, 5 + k));
            // truncation after E - 1 = 9 steps (reference frames 6 ... 14)
            assert_eq!(env.buffers().truncated[i], u8::from(k == 9));
        }
    }
    env.reset_done();
    assert!((0..3).all(|i| env.episode(i).progress == 0));
    // reward at the first step is computed against the post-reset kinematics (FK on reset):
    // holding the reset pose for one step keeps r_p high
    env.step(&zero).unwrap();
    let p = env.buffers().terms[0];
    assert!(p > 0.5, "r_p after one step {p}");
}

#[test]
fn autoreset_keeps_terminal_observations() {
    let mut c = config(2);
    c.episode_length = 4;
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    env.set_autoreset(true);
    let zero = vec![0.0f32; 2 * 156];
    env.step(&zero).unwrap();
    env.step(&zero).unwrap();
    let before = env.buffers().obs.clone();
    env.step(&zero).unwrap(); // third step: progress 3 = E - 1 -> truncated and reset
    let b = env.buffers();
    assert_eq!(b.truncated, vec![1, 1]);
    assert_eq!(b.final_mask, vec![1, 1]);
    assert_ne!(b.final_obs, before);
    assert_ne!(b.final_obs, b.obs, "obs must be the reset observation");
    assert!((0..2).all(|i| env.episode(i).progress == 0));
}

#[test]
fn observation_sizes_values_and_frames() {
    let scene = Arc::new(Scene::default_for(HandModel::Full).unwrap());
    let mut sim = BatchSim::new(scene, 2, 1).unwrap();
    let lib = demo_library();
    let m = lib.get(0);
    let s0 = skillmimic_env::episode::reset_state_from_clip(m, 40);
    // the same state turned by 0.8 rad about world z and moved by (2, -1) m
    let yaw = Quat::about_z(0.8);
    let mv = |p: [f64; 3]| {
        let r = yaw.rotate(p);
        [r[0] + 2.0, r[1] - 1.0, r[2]]
    };
    let mut s1 = s0.clone();
    s1.root_pos = mv(s0.root_pos);
    s1.root_quat = yaw.mul(s0.root_quat);
    s1.root_linvel = yaw.rotate(s0.root_linvel);
    s1.ball_mut().pos = mv(s0.ball().pos);
    s1.ball_mut().quat = yaw.mul(s0.ball().quat);
    s1.ball_mut().linvel = yaw.rotate(s0.ball().linvel);
    sim.reset(&[true, true], &[s0, s1]).unwrap();
    let mut o = vec![vec![0.0f32; layout::OBS_DIM]; 2];
    for (i, out) in o.iter_mut().enumerate() {
        write_observation(&sim.state().env(i), m.clip.skill, out);
    }
    assert_eq!(o[0].len(), 902);
    for k in 0..layout::OBS_DIM {
        if layout::FINGERTIP_FORCE.contains(&k) {
            continue;
        }
        assert!(
            (o[0][k] - o[1][k]).abs() < 2e-5,
            "entry {k}: {} vs {} (heading frame must remove yaw and xy)",
            o[0][k],
            o[1][k]
        );
    }
    // fingertip forces are world-frame: they turn with the yaw
    for f in 0..10 {
        let a = layout::FINGERTIP_FORCE.start + 3 * f;
        let v = yaw.rotate([o[0][a] as f64, o[0][a + 1] as f64, o[0][a + 2] as f64]);
        for k in 0..3 {
            assert!((v[k] as f32 - o[1][a + k]).abs() < 1e-3 * (1.0 + v[k].abs() as f32));
        }
    }
    assert_eq!(o[0][layout::SKILL.start + m.clip.skill as usize], 1.0);
    assert_eq!(o[0][layout::SKILL].iter().sum::<f32>(), 1.0);

    // hand-computed entries for the upright zero pose: root height, and the left hip offset
    // (0.109716, -0.0365719, 0) in the Y-up skeleton frame = (0.109716, 0, -0.0365719) in the
    // heading frame (x: left side, z: up)
    let s = ResetState::default();
    sim.reset(&[true, false], &[s.clone(), s]).unwrap();
    let mut out = vec![0.0f32; layout::OBS_DIM];
    write_observation(&sim.state().env(0), 3, &mut out);
    assert!((out[0] - 0.95).abs() < 1e-6);
    let hip = &out[layout::BODY_POS.start..layout::BODY_POS.start + 3];
    assert!(
        (hip[0] - 0.109716).abs() < 1e-6
            && hip[1].abs() < 1e-6
            && (hip[2] + 0.0365719).abs() < 1e-6,
        "{hip:?}"
    );
    // root rotation in its heading frame: tan-norm [x axis; z axis] = [(1,0,0); (0,-1,0)]
    let rot = &out[layout::BODY_ROT.start..layout::BODY_ROT.start + 6];
    let want = [1.0, 0.0, 0.0, 0.0, -1.0, 0.0];
    assert!(rot.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6), "{rot:?}");
    // ball at (0, 0.6, 0.12): relative xy in the heading frame, absolute height
    let ball = &out[layout::BALL_POS];
    assert!(
        ball[0].abs() < 1e-6 && (ball[1] - 0.6).abs() < 1e-6 && (ball[2] - 0.12).abs() < 1e-6,
        "{ball:?}"
    );
}
