//! ModSkill skill reuse (seed 001 §3.5): a high-level task over a `modular_attention` checkpoint
//! takes continuous part embeddings, projects each onto the unit sphere and drives the frozen
//! part controllers; the learner defaults to a Gaussian high-level policy and trains it; the
//! `steering` task's command, reward and redraws follow its documented rules.

mod common;
use common::workspace_root;
use skillmimic_env::ActionSpace;
use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_env::tasks::hlc::config::ReachConfig;
use skillmimic_env::tasks::hlc::config::SteeringConfig;
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::{PpoConfig, TrainConfig};
use skillmimic_learn::policy::Policy;
use skillmimic_learn::trainer::Trainer;
use skillmimic_nn::modular::ModularAttention;

/// A small modular checkpoint (observation 902, 156 actions, 5 parts × 16-wide embeddings).
fn modular_llc(tag: &str) -> (std::path::PathBuf, Policy) {
    let mut cfg =
        PpoConfig { policy: "modular_attention".into(), hidden: vec![32], ..Default::default() };
    cfg.modular.embed = 16;
    cfg.modular.proj_hidden = 32;
    cfg.modular.controller = vec![48, 32];
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(5);
    let p = Policy::build(902, ActionSpace::Box { dim: 156 }, &cfg, &mut rng).unwrap();
    let dir = std::env::temp_dir().join(format!("skillmimic-{tag}-modllc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("llc.safetensors");
    checkpoint::save(&path, &p, None, &Progress::default(), "").unwrap();
    (path, p)
}

fn config(task: &str, llc: &std::path::Path, out: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.into();
    c.env.table_mut::<HlcConfig>().llc = llc.to_path_buf();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.ppo.horizon = 8;
    c.run.out_dir =
        std::env::temp_dir().join(format!("skillmimic-modreuse-{out}-{}", std::process::id()));
    c
}

/// The controllers applied by hand: unit-sphere projection per part, controller, clamp.
fn by_hand(p: &Policy, latent: &[f32]) -> Vec<f32> {
    let Some(m) = p.actor.downcast_ref::<ModularAttention>() else {
        panic!("modular actor expected")
    };
    let e = m.shape.embed;
    let mut out = vec![0.0f32; 156];
    for (k, part) in m.parts.iter().enumerate() {
        let z = &latent[k * e..(k + 1) * e];
        let norm = z.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
        let zn: Vec<f32> = z.iter().map(|v| (*v as f64 / norm) as f32).collect();
        let mut ws = skillmimic_nn::mlp::Workspace::default();
        let y = part.controller.forward_into(&zn, 1, &mut ws, 1).to_vec();
        for (&c, v) in part.outputs.iter().zip(y) {
            out[c] = v.clamp(-1.0, 1.0);
        }
    }
    out
}

#[test]
fn part_embeddings_drive_the_frozen_part_controllers() {
    let (llc, p) = modular_llc("drive");
    for task in ["steering", "heading"] {
        let c = config(task, &llc, task);
        let mut env = skillmimic_env::registry::make(&c.env).unwrap();
        assert_eq!(
            env.spec().action_space,
            ActionSpace::Box { dim: 5 * 16 },
            "{task}: one 16-wide embedding per part"
        );
        assert_eq!(env.spec().steps_per_action, 1, "{task}: latent_steps = 1 by default");
        assert!(env.spec().choice_labels.is_empty());
        env.reset_all(Some(2));
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(9);
        let n = env.num_envs();
        for _ in 0..5 {
            let latent: Vec<f32> =
                (0..n * 80).map(|_| rand::Rng::random_range(&mut rng, -1.0..1.0)).collect();
            env.step(&latent).unwrap();
            let targets = env.pd_targets().to_vec();
            for i in 0..n {
                let want = by_hand(&p, &latent[i * 80..(i + 1) * 80]);
                let got = &targets[i * 156..(i + 1) * 156];
                let err = want.iter().zip(got).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
                assert!(
                    err < 1e-5,
                    "{task}: env {i}: PD targets differ from the hand-applied controllers by {err}"
                );
            }
            // the projection makes each part's embedding scale-free
            let scaled: Vec<f32> =
                latent.iter().enumerate().map(|(j, v)| v * (1.0 + (j / 16 % 5) as f32)).collect();
            let a = by_hand(&p, &latent[..80]);
            let b = by_hand(&p, &scaled[..80]);
            assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5));
        }
    }
}

#[test]
fn the_learner_trains_a_gaussian_high_level_policy_over_modular_skills() {
    let (llc, _) = modular_llc("train");
    let mut c = config("steering", &llc, "train");
    c.ppo.hidden = PpoConfig::default().hidden;
    c.use_high_level_defaults();
    assert_eq!(c.ppo.policy, "gaussian_mlp", "part embeddings are continuous");
    assert_eq!(c.ppo.hidden, vec![1024, 512]);
    c.ppo.hidden = vec![32];
    c.run.iterations = 2;
    c.run.eval_episodes = 1;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let before = t.policy.clone();
    let mut stats = Vec::new();
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| stats.push(s.clone())).unwrap();
    assert!(
        stats.iter().all(|s| s.mean_reward.is_finite() && (0.0..=1.0).contains(&s.mean_reward)),
        "steering rewards are in [0, 1]"
    );
    assert_ne!(t.policy.actor, before.actor);
    let back = checkpoint::load(&last, Some((838 + 3, 80))).unwrap();
    assert_eq!(back.policy, t.policy);
    // alone its ONNX export would output embeddings, not PD targets: refused, --fused named
    let err = skillmimic_learn::onnx::export::export_checkpoint(
        &last,
        &c.run.out_dir.join("p.onnx"),
        false,
        None,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("part embeddings") && err.contains("--fused"), "{err}");
    // a discrete skill policy keeps the categorical high-level policy
    let gaussian = common::skill_policy("modreuse-discrete");
    let mut d = config("steering", &gaussian, "discrete");
    d.use_high_level_defaults();
    assert_eq!(d.ppo.policy, "categorical_mlp");
    let env = skillmimic_env::registry::make(&d.env).unwrap();
    assert_eq!(env.spec().action_space, ActionSpace::Discrete { n: 3 });
    assert_eq!(env.spec().steps_per_action, 3);
}

#[test]
fn steering_commands_rewards_and_redraws() {
    let (llc, _) = modular_llc("steer");
    let mut c = config("steering", &llc, "steer");
    c.env.table_mut::<SteeringConfig>().change_steps_min = 5;
    c.env.table_mut::<SteeringConfig>().change_steps_max = 5;
    c.env.table_mut::<SteeringConfig>().speed_min = 1.0;
    c.env.table_mut::<SteeringConfig>().speed_max = 2.0;
    let mut env = skillmimic_env::registry::make(&c.env).unwrap();
    let spec = env.spec().clone();
    assert_eq!(spec.info_names, ["dir_x", "dir_y", "speed"]);
    assert_eq!(spec.metric_names, ["speed_error", "dir_speed"]);
    env.reset_all(Some(4));
    let n = env.num_envs();
    let zeros = vec![0.5f32; n * 80];
    let mut commands = Vec::new();
    for step in 1..=12 {
        let before = env.buffers().info.to_vec();
        env.step(&zeros).unwrap();
        let b = env.buffers();
        for i in 0..n {
            if b.terminated[i] != 0 || b.truncated[i] != 0 {
                continue;
            }
            let (dx, dy, s) =
                (before[3 * i] as f64, before[3 * i + 1] as f64, before[3 * i + 2] as f64);
            assert!(
                ((dx * dx + dy * dy).sqrt() - 1.0).abs() < 1e-6 && (1.0..2.0).contains(&s),
                "command {dx} {dy} {s}"
            );
            // reward with the command in force during the step, from the pelvis's world velocity
            let v = env.mujoco().env_state(i).linvel(0);
            let e2 = (s * dx - v[0]).powi(2) + (s * dy - v[1]).powi(2);
            let want = (-0.25 * e2).exp();
            assert!(
                (b.reward[i] as f64 - want).abs() < 1e-5,
                "step {step} env {i}: reward {} vs {want}",
                b.reward[i]
            );
            assert!((b.metrics[2 * i] as f64 - e2.sqrt()).abs() < 1e-5);
        }
        commands.push(b.info[..3].to_vec());
    }
    // the command of env 0 holds for 5 steps, then a new one is drawn
    assert_eq!(commands[0], commands[3]);
    assert_ne!(commands[4], commands[3], "a new command after 5 steps");
    assert_eq!(commands[5], commands[8]);
    assert_ne!(commands[9], commands[8]);
    let bad = {
        let mut c = c.clone();
        c.env.table_mut::<SteeringConfig>().change_steps_min = 0;
        skillmimic_env::registry::make(&c.env).err().unwrap().to_string()
    };
    assert!(bad.contains("env.steering.change_steps_min"), "{bad}");
    let mut r = c.clone();
    r.env.task = "reach".into();
    r.env.table_mut::<ReachConfig>().hand_body = "R_Hand".into();
    let bad = skillmimic_env::registry::make(&r.env).err().unwrap().to_string();
    assert!(bad.contains("env.reach.hand_body") && bad.contains("R_Middle1"), "{bad}");
}

/// ModSkill's normalised return (Tab. 4) of a steering evaluation: each episode's return over
/// the largest an episode can earn (1 per step × the episode's steps), so a fall forfeits the
/// rest of the episode — unlike the mean reward per step, which ignores how long episodes last.
#[test]
fn steering_reports_the_normalised_return_with_falls_counted() {
    let (llc, _) = modular_llc("nr");
    let mut c = config("steering", &llc, "nr");
    c.env.table_mut::<HlcConfig>().episode_length = 600;
    let mut env = skillmimic_env::registry::make(&c.env).unwrap();
    let spec = env.spec().clone();
    assert_eq!((spec.max_step_reward, spec.max_episode_steps), (Some(1.0), 599));
    let hl = PpoConfig { hidden: vec![16], ..Default::default() };
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
    let p = Policy::build(spec.obs_dim, spec.action_space, &hl, &mut rng).unwrap();
    let actor = skillmimic_learn::episode_eval::Actor::Policy { policy: &p, stochastic: false };
    let r = skillmimic_learn::episode_eval::evaluate_actor(actor, env.as_mut(), 8, 4, 1).unwrap();
    let nr = r.normalised_return.expect("steering has a bounded reward");
    println!(
        "steering, untrained: normalised return {nr:.4}, reward/step {:.4}, length {:.1} of 599, \
            early end {:.0} %",
        r.mean_reward_per_step,
        r.mean_episode_length,
        100.0 * r.early_termination_rate
    );
    assert!((nr - r.mean_return / 599.0).abs() < 1e-12);
    assert!((0.0..=1.0).contains(&nr));
    // untrained controllers fall: the episodes are short and the normalised return is below the
    // mean reward per step by the share of the episode that was lost
    assert!(r.early_termination_rate > 0.0, "no episode ended early");
    let want = r.mean_reward_per_step * r.mean_episode_length / 599.0;
    assert!((nr - want).abs() < 1e-9 && nr < r.mean_reward_per_step);
    // a task without a bounded reward reports none
    let mut h = skillmimic_env::registry::make(&config("heading", &llc, "nr_h").env).unwrap();
    let hs = h.spec().clone();
    let p = Policy::build(hs.obs_dim, hs.action_space, &hl, &mut rng).unwrap();
    let actor = skillmimic_learn::episode_eval::Actor::Policy { policy: &p, stochastic: false };
    let r = skillmimic_learn::episode_eval::evaluate_actor(actor, h.as_mut(), 2, 4, 1).unwrap();
    assert_eq!(r.normalised_return, None);
}
