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

/// ModSkill's own setting: `modular_attention` tracking on the SMPL humanoid. Each part token
/// reads exactly the columns the released `PartAttentionLayer` reads
/// (`tests/fixtures/modskill_part_tokens_golden.json`: released column indices, mapped here from
/// the released body-major self observation to this project's quantity-major one; the reference
/// block is laid out alike), widths 156, 156, 232, 195, 195; the parts drive the 69 dofs; one
/// iteration trains.
#[test]
fn smpl_tracking_part_tokens_are_the_released_ones() {
    let mut c = tiny("smpl", 1);
    c.env.task = "tracking".into();
    c.env.character = "smpl".into();
    let mut t = Trainer::new(c, None).unwrap();
    let m = t.policy.actor.downcast_ref::<ModularAttention>().expect("a modular actor").clone();
    assert_eq!(m.obs_dim, 358 + 24 * 24);
    // released self column r (root height, then per body: position (not the pelvis's), rotation
    // 6, velocity 3, angular velocity 3) -> this project's column (its own body columns, checked
    // against the released self observation by skillmimic-env's modskill_released_tracking test);
    // the reference block is laid out alike
    let (spec, n) = (skillmimic_core::characters::smpl::spec(), 24);
    let mut ours_of = vec![0usize];
    ours_of.extend((0..n).flat_map(|b| skillmimic_env::proprio::body_columns(&spec.proprio, n, b)));
    ours_of.extend(358..358 + 24 * 24);
    assert_eq!(ours_of.len(), 934);
    let path = workspace_root().join("tests/fixtures/modskill_part_tokens_golden.json");
    let fx: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let released = fx["parts"].as_array().unwrap();
    assert_eq!(m.parts.len(), released.len());
    let mut driven = Vec::new();
    for (part, want) in m.parts.iter().zip(released) {
        let want: Vec<usize> = want
            .as_array()
            .unwrap()
            .iter()
            .map(|v| ours_of[v.as_u64().unwrap() as usize])
            .collect();
        assert_eq!(part.inputs, want, "part {}", part.name);
        driven.extend(part.outputs.iter().copied());
    }
    let widths: Vec<usize> = m.parts.iter().map(|p| p.inputs.len()).collect();
    assert_eq!(widths, [156, 156, 232, 195, 195]);
    driven.sort_unstable();
    assert_eq!(driven, (0..69).collect::<Vec<_>>(), "every dof driven by one part");
    let before = t.policy.actor.clone();
    skillmimic_learn::runner::train_loop(&mut t, |_| {}).unwrap();
    assert_ne!(t.policy.actor, before, "the update moves the modular actor");
}

/// A character without ModSkill body parts, or actions that are not its dofs, are refused with
/// the reason.
#[test]
fn modular_attention_needs_body_parts_and_the_character_dofs() {
    let mut c = tiny("tokenhsi", 1);
    c.env.task = "stand".into();
    c.env.character = "tokenhsi".into();
    let err = Trainer::new(c, None).err().expect("no parts").to_string();
    assert!(
        err.contains("ppo.modular.parts") && err.contains("tokenhsi") && err.contains("none"),
        "{err}"
    );
    let mut c = tiny("smpl_seven", 1);
    c.env.task = "tracking".into();
    c.env.character = "smpl".into();
    c.ppo.modular.parts = "seven".into();
    let err = Trainer::new(c, None).err().expect("no seven on SMPL").to_string();
    assert!(err.contains("'seven'") && err.contains("\"five\""), "{err}");
}
