//! The `modular_attention` family (ModSkill) end to end on the shipped demo clips: it trains (the
//! fast path's hand-written gradients by default, candle's with `ppo.backend = "candle"`), writes
//! checkpoints that load back bit-identically and resume, and a bad network configuration is a
//! clear error.

use skillmimic_core::shared_data::workspace_root;
use skillmimic_learn::checkpoint;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::trainer::Trainer;
use skillmimic_nn::modular::ModularAttention;

fn tiny(out: &str, iterations: usize) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.ppo.policy = "modular_attention".into();
    c.ppo.hidden = vec![64, 32];
    c.ppo.modular.controller = vec![64, 32];
    c.ppo.modular.proj_hidden = 64;
    c.ppo.modular.embed = 32;
    c.run.iterations = iterations;
    c.run.save_every = 2;
    c.run.eval_episodes = 2;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-modular-{}-{out}", std::process::id()));
    c
}

#[test]
fn modular_attention_trains_saves_loads_and_resumes() {
    let cfg = tiny("a", 2);
    let mut t = Trainer::new(cfg.clone(), None).unwrap();
    assert!(t.policy.actor.downcast_ref::<ModularAttention>().is_some_and(|m| m.parts.len() == 5));
    let before = t.policy.clone();
    let mut seen = Vec::new();
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    assert!(seen.iter().all(|s| s.mean_reward.is_finite()
        && s.actor_loss.is_finite()
        && s.critic_loss.is_finite()));
    assert_ne!(t.policy.actor, before.actor, "the update must move the modular actor");
    let c = checkpoint::load(&last, Some((902, 156))).unwrap();
    assert_eq!(c.policy, t.policy);
    let mut cfg2 = cfg.clone();
    cfg2.run.iterations = 3;
    let mut t2 = Trainer::new(cfg2, Some(&last)).unwrap();
    assert_eq!((t2.progress.iteration, t2.adam.step), (2, t.adam.step));
    skillmimic_learn::runner::train_loop(&mut t2, |_| {}).unwrap();
    assert_eq!(t2.progress.iteration, 3);
}

#[test]
fn bad_modular_settings_are_clear_errors() {
    let mut cfg = tiny("bad", 1);
    cfg.ppo.modular.heads = 5;
    let err = Trainer::new(cfg, None).err().expect("32 is not a multiple of 5").to_string();
    assert!(err.contains("ppo.modular") && err.contains("heads"), "{err}");
    let mut cfg = tiny("bad2", 1);
    cfg.ppo.modular.parts = "three".into();
    let err = Trainer::new(cfg, None).err().unwrap().to_string();
    assert!(err.contains("ppo.modular.parts") && err.contains("\"five\""), "{err}");
}
