//! Physical sanity of the generated scene and of the batched core: ball bounce, PD tracking,
//! stability under random actions, determinism across thread counts.

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::{BODIES, JointGroup, NUM_DOFS, dof_range};
use skillmimic_core::math::Quat;
use skillmimic_sim::mjcf::scene_xml;
use skillmimic_sim::{
    BALL, BatchSim, ContactPair, HandModel, ResetState, RootJoint, Scene, SceneOptions,
};

/// Deterministic uniform numbers in [-1, 1] (no RNG dependency in the sim crate).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }
}

#[test]
fn ball_dropped_from_1_5_m_bounces_with_the_combined_floor_restitution_0_805() {
    let scene = Arc::new(Scene::default_for(HandModel::Full).unwrap());
    let mut sim = BatchSim::new(scene, 1, 1).unwrap();
    let r = 0.12;
    let h = 1.5; // height of the ball centre at release
    let mut s = ResetState::default();
    s.root_pos = [5.0, 0.0, 0.95]; // humanoid out of the way
    s.ball_mut().pos = [0.0, 0.0, h];
    sim.reset(&[true], &[s]).unwrap();
    let zero = vec![0.0f32; NUM_DOFS];
    let (mut in_contact_seen, mut left_floor, mut apex) = (false, false, 0.0f64);
    let (mut v_in, mut v_out) = (0.0f64, 0.0f64);
    let mut prev_vz = 0.0;
    for _ in 0..240 {
        sim.step(&zero).unwrap();
        let st = sim.state().env(0);
        let (z, vz) = (st.pos(BALL)[2], st.linvel(BALL)[2]);
        let c = st.has_contact(ContactPair::BallFloor);
        if c && !in_contact_seen {
            in_contact_seen = true;
            v_in = prev_vz;
        }
        if in_contact_seen && !c && !left_floor {
            left_floor = true;
            v_out = vz;
        }
        if left_floor {
            if vz < 0.0 {
                break;
            }
            apex = apex.max(z);
        }
        prev_vz = vz;
    }
    assert!(left_floor, "the ball never bounced");
    let e_height = ((apex - r) / (h - r)).sqrt();
    let e_speed = -v_out / v_in;
    println!(
        "ball drop from {h} m: restitution from apex height {e_height:.3}, from speeds {e_speed:.3}"
    );
    assert!((e_height - 0.805).abs() <= 0.03, "restitution {e_height:.3} not within 0.805 ± 0.03");
    assert!((e_speed - 0.805).abs() <= 0.04, "speed ratio {e_speed:.3}");
}

#[test]
fn ball_resting_on_floor_carries_its_weight() {
    // sign and frame of the per-body contact force: the floor pushes the ball up with m·g
    let scene = Arc::new(Scene::default_for(HandModel::Box).unwrap());
    let mass = scene.model().body_mass()[scene.body_ids[BALL]];
    let mut sim = BatchSim::new(scene, 1, 1).unwrap();
    let mut s = ResetState::default();
    s.root_pos = [5.0, 0.0, 0.95];
    s.ball_mut().pos = [0.0, 0.0, 0.11];
    sim.reset(&[true], &[s]).unwrap();
    // the resting ball micro-bounces (see mjcf::ball_floor_solref), so average the vertical
    // contact force over 2 s: it must carry the weight, sideways forces stay zero
    let (mut fz, mut steps_in_contact) = (0.0, 0);
    for _ in 0..240 {
        sim.step(&vec![0.0; NUM_DOFS]).unwrap();
        let st = sim.state().env(0);
        let f = st.contact_force(BALL);
        assert!(f[0].abs() < 1e-6 && f[1].abs() < 1e-6, "{f:?}");
        assert_eq!(st.has_contact(ContactPair::BallFloor), f[2] > 0.0);
        steps_in_contact += usize::from(f[2] > 0.0);
        fz += f[2];
    }
    // forces are those of the last of the 2 sub-steps: their mean over policy steps is the weight
    let mean = fz / 240.0;
    println!(
        "ball mass {mass:.3} kg, mean floor force {mean:.2} N (m g = {:.2} N), in contact \
            {steps_in_contact}/240 steps",
        mass * 9.81
    );
    assert!((mean - mass * 9.81).abs() < 0.1 * mass * 9.81);
}

#[test]
fn pd_drives_track_a_step_target_within_0_05_rad_after_half_a_second() {
    // root welded at 2 m, upright; gravity and contacts off to isolate the drive dynamics
    let upright = Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]);
    let options = SceneOptions {
        root: RootJoint::Fixed { pos: [0.0, 0.0, 2.0], quat: upright },
        ..Default::default()
    };
    let xml = scene_xml(&options).replace(
        "<option timestep",
        "<option gravity=\"0 0 0\"><flag contact=\"disable\"/></option>\n  <option timestep",
    );
    let scene = Arc::new(Scene::from_xml(xml, options).unwrap());
    let target = [0.3, -0.25, 0.2];
    for group in JointGroup::ACTUATED {
        let mut sim = BatchSim::new(scene.clone(), 1, 1).unwrap();
        let mut actions = vec![0.0f32; NUM_DOFS];
        let bodies: Vec<usize> = (1..BODIES.len()).filter(|&b| BODIES[b].group == group).collect();
        for &b in &bodies {
            for (k, i) in dof_range(b).enumerate() {
                actions[i] = (target[k] / std::f64::consts::PI) as f32;
            }
        }
        for _ in 0..30 {
            sim.step(&actions).unwrap(); // 30 policy steps = 0.5 s
        }
        let st = sim.state().env(0);
        let mut worst = 0.0f64;
        for &b in &bodies {
            for (k, i) in dof_range(b).enumerate() {
                worst = worst.max((st.dof_pos[i] - target[k]).abs());
            }
        }
        println!(
            "{group:?}: {} bodies, worst tracking error after 0.5 s = {worst:.4} rad",
            bodies.len()
        );
        assert!(worst < 0.05, "{group:?}: error {worst} rad");
    }
}

fn random_rollout(
    hands: HandModel,
    threads: usize,
    envs: usize,
    steps: usize,
    seed: u64,
) -> (BatchSim, bool) {
    let scene = Arc::new(Scene::default_for(hands).unwrap());
    let mut sim = BatchSim::new(scene, envs, threads).unwrap();
    let mut rng = Lcg(seed);
    let mut actions = vec![0.0f32; envs * NUM_DOFS];
    let mut unstable = false;
    for _ in 0..steps {
        actions.iter_mut().for_each(|a| *a = rng.next());
        sim.step(&actions).unwrap();
        unstable |= sim.state().unstable.iter().any(|&u| u != 0);
    }
    (sim, unstable)
}

#[test]
fn random_actions_for_ten_seconds_stay_finite_and_stable() {
    for hands in [HandModel::Full, HandModel::Box] {
        let (sim, unstable) = random_rollout(hands, 2, 4, 600, 7);
        let st = sim.state();
        let finite = st
            .body_pos
            .iter()
            .chain(&st.body_linvel)
            .chain(&st.dof_pos)
            .chain(&st.contact_force)
            .all(|x| x.is_finite());
        println!(
            "{hands:?}: 10 s of uniform random actions, unstable = {unstable}, finite = {finite}"
        );
        assert!(finite && !unstable);
    }
}

#[test]
fn results_are_bit_identical_for_one_and_two_threads() {
    for hands in [HandModel::Full, HandModel::Box] {
        let (a, _) = random_rollout(hands, 1, 6, 40, 99);
        let (b, _) = random_rollout(hands, 2, 6, 40, 99);
        assert_eq!(a.state(), b.state(), "{hands:?}: batch state differs between 1 and 2 threads");
        for i in 0..6 {
            assert_eq!(a.qpos(i), b.qpos(i));
            assert_eq!(a.qvel(i), b.qvel(i));
        }
    }
}

#[test]
fn reset_clears_history_so_a_reset_env_repeats_a_fresh_one() {
    let scene = Arc::new(Scene::default_for(HandModel::Box).unwrap());
    let mut sim = BatchSim::new(scene, 2, 1).unwrap();
    let mut rng = Lcg(3);
    let mut actions = vec![0.0f32; 2 * NUM_DOFS];
    // env 1 runs for a while, then both are reset to the same state and must evolve identically
    for _ in 0..20 {
        actions.iter_mut().for_each(|a| *a = rng.next());
        sim.step(&actions).unwrap();
    }
    let s = ResetState::default();
    sim.reset(&[true, true], &[s.clone(), s]).unwrap();
    for _ in 0..20 {
        let row: Vec<f32> = (0..NUM_DOFS).map(|_| rng.next()).collect();
        actions[..NUM_DOFS].copy_from_slice(&row);
        actions[NUM_DOFS..].copy_from_slice(&row);
        sim.step(&actions).unwrap();
    }
    assert_eq!(sim.qpos(0), sim.qpos(1));
    assert_eq!(sim.qvel(0), sim.qvel(1));
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let scene = Arc::new(Scene::default_for(HandModel::Box).unwrap());
    let mut sim = BatchSim::new(scene, 2, 1).unwrap();
    let e = sim.step(&[0.0; 10]).unwrap_err().to_string();
    assert!(e.contains("expected 312") && e.contains("2 x 156"), "{e}");
    let mut a = vec![0.0f32; 2 * NUM_DOFS];
    a[NUM_DOFS + 5] = f32::NAN;
    let e = sim.step(&a).unwrap_err().to_string();
    assert!(e.contains("environment 1, entry 5"), "{e}");
    let mut s = ResetState::default();
    s.ball_mut().pos[2] = f64::INFINITY;
    assert!(sim.reset(&[false, true], &[ResetState::default(), s]).is_err());
    assert!(BatchSim::new(sim.scene().clone(), 0, 1).is_err());
}

#[test]
fn read_out_matches_mujoco_object_velocity_and_joint_quaternions() {
    use mujoco_rs::wrappers::mj_model::MjtObjBase;
    use skillmimic_sim::NUM_STATE_BODIES;
    let (sim, _) = random_rollout(HandModel::Full, 2, 3, 25, 5);
    let scene = sim.scene().clone();
    for i in 0..3 {
        let st = sim.state().env(i);
        let d = sim.data(i);
        for b in 0..NUM_STATE_BODIES {
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, scene.body_ids[b], false);
            let (w, l) = (st.angvel(b), st.linvel(b));
            for k in 0..3 {
                assert!(
                    (w[k] - v[k]).abs() < 1e-10 && (l[k] - v[3 + k]).abs() < 1e-10,
                    "env {i} body {b}: {w:?} {l:?} vs {v:?}"
                );
            }
            assert_eq!(st.pos(b), d.xpos()[scene.body_ids[b]]);
        }
        // joint rotation vectors rebuild the joint quaternions
        for j in 0..52 {
            let a = scene.joint_addr(j + 1).unwrap().qpos;
            let q = Quat::from_rotvec([
                st.dof_pos[3 * j],
                st.dof_pos[3 * j + 1],
                st.dof_pos[3 * j + 2],
            ]);
            let qp = &sim.qpos(i)[a..a + 4];
            let s = if q.w * qp[0] < 0.0 { -1.0 } else { 1.0 };
            let n = (qp.iter().map(|x| x * x).sum::<f64>()).sqrt();
            for (x, y) in q.to_wxyz().iter().zip(qp) {
                assert!((s * x - y / n).abs() < 1e-12);
            }
        }
    }
}
