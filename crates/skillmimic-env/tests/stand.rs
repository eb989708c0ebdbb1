//! The `stand` task (the worked example of adding a task): start state, observation, reward and
//! termination against values computed here from its definition.

use skillmimic_core::math::{heading, wrap_angle};
use skillmimic_env::registry;
use skillmimic_env::tasks::stand::StandConfig;
use skillmimic_env::{Env, EnvConfig};

fn stand_env(n: usize) -> Box<dyn Env> {
    let cfg = EnvConfig { task: "stand".into(), num_envs: n, threads: 1, ..Default::default() };
    registry::make(&cfg).expect("stand env")
}

#[test]
fn start_state_observation_and_reward_follow_the_definition() {
    let mut env = stand_env(6);
    assert_eq!(env.spec().name, "stand");
    const OBS_DIM: usize = 823 + 3;
    assert_eq!((env.obs_dim(), env.act_dim()), (OBS_DIM, 156));
    env.reset_all(Some(4));
    let c = EnvConfig::default().table::<StandConfig>().clone();
    // start_height 0: the SkillMimic humanoid's rest height
    let start = skillmimic_core::characters::skillmimic::REST_ROOT_HEIGHT;
    assert_eq!(c.start_height, 0.0);
    let headings: Vec<f64> = (0..6).map(|i| heading(env.mujoco().env_state(i).quat(0))).collect();
    // random headings, pelvis at the start height, heading error zero
    assert!(headings.iter().any(|h| h.abs() > 0.3), "{headings:?}");
    for i in 0..6 {
        let st = env.mujoco().env_state(i);
        assert!((st.pos(0)[2] - start).abs() < 1e-9);
        let o = &env.buffers().obs[i * OBS_DIM..(i + 1) * OBS_DIM];
        assert!((o[823] as f64 - (start - c.target_height)).abs() < 1e-6);
        assert!(
            (o[824] - 1.0).abs() < 1e-6 && o[825].abs() < 1e-6,
            "cos/sin of a zero heading error: {:?}",
            &o[823..]
        );
    }
    // hold the start pose (PD targets 0) for half a second: it stands on its feet
    let zeros = vec![0.0f32; 6 * 156];
    for step in 0..30 {
        env.step(&zeros).unwrap();
        let b = env.buffers();
        for (i, &psi0) in headings.iter().enumerate() {
            let st = env.mujoco().env_state(i);
            let (dz, dpsi) =
                (st.pos(0)[2] - c.target_height, wrap_angle(psi0 - heading(st.quat(0))));
            let rh = (-c.height_scale * dz * dz).exp();
            let rpsi = (-c.heading_scale * dpsi * dpsi).exp();
            let want = c.height_weight * rh + (1.0 - c.height_weight) * rpsi;
            assert!(
                (b.reward[i] as f64 - want).abs() < 1e-5,
                "step {step} env {i}: {} vs {want}",
                b.reward[i]
            );
            assert!(
                (b.metrics[2 * i] as f64 - dz.abs()).abs() < 1e-5
                    && (b.metrics[2 * i + 1] as f64 - dpsi.abs()).abs() < 1e-5
            );
            assert_eq!(
                b.terminated[i],
                0,
                "step {step} env {i}: fell from the start pose (pelvis {:.3} m)",
                st.pos(0)[2]
            );
            assert!(
                (st.pos(0)[2] - start).abs() < 0.1,
                "step {step} env {i}: pelvis {:.3} m",
                st.pos(0)[2]
            );
        }
    }
}

#[test]
fn episodes_end_at_the_time_limit_and_when_the_pelvis_falls() {
    let mut cfg = EnvConfig { task: "stand".into(), num_envs: 2, threads: 1, ..Default::default() };
    *cfg.table_mut::<StandConfig>() =
        StandConfig { episode_length: 5, termination_height: 2.0, ..Default::default() };
    let mut env = registry::make(&cfg).unwrap();
    env.step(&vec![0.0; 2 * 156]).unwrap();
    // pelvis (≈0.95 m) below the 2 m termination height: terminated at once
    assert!(env.buffers().terminated.iter().all(|&t| t == 1));
    let mut cfg = EnvConfig { task: "stand".into(), num_envs: 2, threads: 1, ..Default::default() };
    cfg.table_mut::<StandConfig>().episode_length = 5;
    let mut env = registry::make(&cfg).unwrap();
    for k in 1..=5 {
        env.step(&vec![0.0; 2 * 156]).unwrap();
        let want = u8::from(k == 5);
        assert!(env.buffers().truncated.iter().all(|&t| t == want), "step {k}");
    }
    let mut bad = EnvConfig { task: "stand".into(), ..Default::default() };
    bad.table_mut::<StandConfig>().height_weight = 1.5;
    let e = registry::make(&bad).err().unwrap().to_string();
    assert!(e.contains("env.stand.height_weight"), "{e}");
}
