//! Every registered task × every compatible policy family: build, reset, 30 steps with the
//! policy's sampled actions (checking shapes against the declared spaces and that nothing is
//! NaN), then one PPO iteration through the trainer (MuJoCo Playground style). High-level tasks
//! drive a small skill policy written for the test.

mod common;
use common::{skill_policy, workspace_root};
use skillmimic_env::registry::TASKS;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policies::FAMILIES;
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_learn::trainer::Trainer;

fn config(task: &str, out: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.to_string();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.ppo.horizon = 8;
    c.ppo.minibatch = 16;
    c.ppo.mini_epochs = 1;
    c.run.out_dir =
        std::env::temp_dir().join(format!("skillmimic-every-task-{out}-{}", std::process::id()));
    if skillmimic_env::registry::is_high_level(task) {
        c.env.hlc.llc = skill_policy("every-task");
    }
    // the token transformer at test sizes
    c.ppo.token.tokenizer = vec![32];
    c.ppo.token.embed = 16;
    c.ppo.token.layers = 1;
    c.ppo.token.feedforward = 32;
    c.ppo.token.head = vec![32];
    c
}

#[test]
fn every_task_steps_with_every_compatible_policy_family() {
    assert!(
        TASKS.len() >= 6,
        "imitation, the worked example and the four high-level tasks are registered"
    );
    let mut pairs = 0;
    for (entry, family) in TASKS.iter().flat_map(|e| FAMILIES.iter().map(move |f| (e, *f))) {
        let mut c = config(entry.name, entry.name);
        let space = skillmimic_env::registry::make(&c.env)
            .unwrap_or_else(|e| panic!("{}: {e}", entry.name))
            .spec()
            .action_space;
        if !family.supports(&space) {
            continue;
        }
        pairs += 1;
        c.ppo.policy = family.name().to_string();
        let mut env = skillmimic_env::registry::make(&c.env)
            .unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        let spec = env.spec().clone();
        assert_eq!(spec.name, entry.name);
        let (n, d, a) = (env.num_envs(), spec.obs_dim, spec.act_dim());
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
        let ppo = skillmimic_learn::policies::token_transformer::with_task_groups(&c.ppo, &spec);
        let policy = Policy::build(d, space, &ppo, &mut rng).unwrap();
        let mut buf = InferenceBuffers::default();
        let o = policy.actor_outputs();
        let (mut mu, mut values, mut actions, mut neglogp) =
            (vec![0.0; n * o], vec![0.0; n], vec![0.0; n * a], vec![0.0; n]);
        env.reset_all(Some(3));
        let (mut dones, mut reward_sum) = (0, 0.0f64);
        for step in 0..30 {
            let b = env.buffers();
            assert_eq!(b.obs.len(), n * d, "{}: observation buffer", entry.name);
            assert_eq!(b.terms.len(), n * spec.term_names.len());
            assert_eq!(b.metrics.len(), n * spec.metric_names.len());
            assert_eq!(b.info.len(), n * spec.info_names.len());
            assert!(
                b.obs.iter().all(|v| v.is_finite()),
                "{} step {step}: non-finite observation",
                entry.name
            );
            let obs = b.obs.clone();
            policy.infer(&obs, n, &mut buf, &mut mu, &mut values, 1);
            policy.sample(&mu, n, &mut rng, &mut actions, &mut neglogp);
            assert!(actions.iter().chain(&neglogp).chain(&values).all(|v| v.is_finite()));
            env.step(&actions).unwrap();
            let b = env.buffers();
            for (name, xs) in [
                ("reward", &b.reward),
                ("terms", &b.terms),
                ("metrics", &b.metrics),
                ("info", &b.info),
            ] {
                assert!(
                    xs.iter().all(|v| v.is_finite()),
                    "{} step {step}: non-finite {name}",
                    entry.name
                );
            }
            reward_sum += b.reward.iter().map(|&r| r.abs() as f64).sum::<f64>();
            dones +=
                b.terminated.iter().zip(&b.truncated).filter(|(t, u)| **t != 0 || **u != 0).count();
            env.reset_done();
        }
        let _ = dones;
        // every environment was stepped by its task (a zero-width buffer once stopped them all)
        assert!(reward_sum > 0.0, "{}: no reward in 30 steps", entry.name);
        // one PPO iteration through the trainer on the same task
        let mut t = Trainer::new(c.clone(), None).unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        assert_eq!((t.env.obs_dim(), t.env.act_dim()), (d, a));
        let s = t.iteration().unwrap();
        assert!(
            s.mean_reward.is_finite() && s.actor_loss.is_finite() && s.critic_loss.is_finite(),
            "{}: {s:?}",
            entry.name
        );
        assert_eq!(s.reward_terms.len(), spec.term_names.len());
        assert_eq!(s.low_level_samples, s.samples * spec.steps_per_action as u64);
        let _ = std::fs::remove_dir_all(&c.run.out_dir);
    }
    assert!(pairs >= TASKS.len(), "every task has a compatible family");
}

#[test]
fn an_unknown_task_is_a_clear_error() {
    let c = config("juggle", "unknown");
    let e =
        skillmimic_env::registry::make(&c.env).err().expect("unknown task rejected").to_string();
    assert!(
        e.contains("env.task")
            && e.contains("juggle")
            && e.contains("imitation")
            && e.contains("stand")
            && e.contains("heading")
            && e.contains("scoring"),
        "{e}"
    );
}
