//! Policy adaptation of a token transformer (TokenHSI seed 004 §E): a base policy trained on
//! `hsi_follow` + `hsi_sit` is frozen and extended for `hsi_carry` (a new tokenizer, zero
//! adapters, a new critic). Before training the adapted policy acts exactly as the base policy on
//! base-task observations; after an adaptation run every frozen tensor and the base groups'
//! observation statistics are bit-identical to the base checkpoint, the gated adapters leave the
//! base tasks' actions unchanged, while the new parameters and the new task's actions moved.

use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_env::tasks::multi::config::MultiConfig;
use skillmimic_learn::checkpoint;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_learn::trainer::Trainer;
use skillmimic_nn::token::TokenTransformer;

fn config(tag: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = "hsi_multi".into();
    c.env.table_mut::<MultiConfig>().tasks = vec!["hsi_follow".into(), "hsi_sit".into()];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.ppo.policy = "token_transformer".into();
    c.ppo.hidden = vec![32, 16];
    c.ppo.token.tokenizer = vec![32];
    c.ppo.token.embed = 16;
    c.ppo.token.layers = 2;
    c.ppo.token.feedforward = 32;
    c.ppo.token.head = vec![48, 24];
    c.ppo.horizon = 8;
    c.ppo.minibatch = 16;
    c.ppo.mini_epochs = 2;
    c.ppo.lr = 1e-3;
    c.run.out_dir =
        std::env::temp_dir().join(format!("skillmimic-token-adapt-{tag}-{}", std::process::id()));
    c
}

fn actions(p: &Policy, obs: &[f32], n: usize) -> Vec<f32> {
    let (mut mu, mut v) = (vec![0.0; n * p.act_dim()], vec![0.0; n]);
    p.infer(obs, n, &mut InferenceBuffers::default(), &mut mu, &mut v, 1);
    mu
}

/// `p` with its new tokenizer's first weight reset to `w0` and zero adapters (its initial state
/// as far as the new task's actions go).
fn perturbed_free(p: &Policy, w0: &[f32]) -> Policy {
    let mut q = p.clone();
    if let Some(t) = q.actor.downcast_mut::<TokenTransformer>() {
        for x in t.tensors.iter_mut() {
            if x.name.starts_with("adapters.") {
                x.data.iter_mut().for_each(|v| *v = 0.0);
            }
            if x.name == "tokenizers.3.0.weight" {
                x.data.copy_from_slice(w0);
            }
        }
    }
    q
}

fn token(p: &Policy) -> &skillmimic_nn::token::TokenTransformer {
    p.actor.downcast_ref::<TokenTransformer>().expect("a token transformer")
}

#[test]
fn adaptation_freezes_the_base_and_starts_from_its_actions() {
    let base_cfg = config("base");
    let mut base = Trainer::new(base_cfg.clone(), None).unwrap();
    for _ in 0..2 {
        base.iteration().unwrap();
    }
    let base_path = base_cfg.run.out_dir.join("base.safetensors");
    base.save(&base_path).unwrap();
    let base_policy = checkpoint::load(&base_path, None).unwrap().policy;
    let n = base.env.num_envs();
    let old_obs = base.env.buffers().obs.clone();
    let d0 = base.env.obs_dim();

    let mut c = config("adapt");
    c.env.table_mut::<MultiConfig>().tasks = vec!["hsi_carry".into()];
    c.env.table_mut::<MultiConfig>().groups =
        vec!["hsi_follow".into(), "hsi_sit".into(), "hsi_carry".into()];
    c.ppo.token.adapt_from = base_path.clone();
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let d1 = t.env.obs_dim();
    let spec = token(&t.policy).spec.clone();
    assert!(spec.adapters && spec.groups.len() == 4 && spec.mask == 3, "{spec:?}");
    // only the new tokenizer and the adapters train
    let trained: Vec<String> =
        t.policy.actor.param_names("actor").into_iter().map(|x| x.0).collect();
    assert!(
        trained
            .iter()
            .all(|nm| nm.starts_with("actor.tokenizers.3.") || nm.starts_with("actor.adapters.")),
        "{trained:?}"
    );
    assert!(!trained.is_empty());

    // base-task observations in the new layout (the carry group zero and masked out)
    let old_groups = d0 - 2; // proprioception, follow, sit
    let carry = d1 - 3 - old_groups;
    let mut new_obs = vec![0.0f32; n * d1];
    for i in 0..n {
        let (src, dst) = (&old_obs[i * d0..(i + 1) * d0], &mut new_obs[i * d1..(i + 1) * d1]);
        dst[..old_groups].copy_from_slice(&src[..old_groups]);
        dst[old_groups + carry..old_groups + carry + 2].copy_from_slice(&src[old_groups..]);
    }
    let a0 = actions(&base_policy, &old_obs, n);
    let a1 = actions(&t.policy, &new_obs, n);
    let diff = a0.iter().zip(&a1).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    println!(
        "initial actions, adapted vs base policy on base-task observations: max |diff| {diff:.2e}"
    );
    assert!(diff <= 1e-6, "{diff}");
    // the check can fail: non-zero adapters change the actions where the new task is active
    // (and, gated, nowhere else)
    let mut perturbed = t.policy.clone();
    if let Some(tt) = perturbed.actor.downcast_mut::<TokenTransformer>() {
        tt.tensors
            .iter_mut()
            .filter(|x| x.name == "adapters.0.weight")
            .for_each(|x| x.data.iter_mut().for_each(|v| *v = 0.05));
    }
    let new_task_obs = t.env.buffers().obs.clone();
    let (b1, b2) = (actions(&t.policy, &new_task_obs, n), actions(&perturbed, &new_task_obs, n));
    assert!(b1.iter().zip(&b2).any(|(x, y)| (x - y).abs() > 1e-4));
    assert_eq!(a1, actions(&perturbed, &new_obs, n));

    let init_new = token(&t.policy)
        .tensors
        .iter()
        .find(|x| x.name == "tokenizers.3.0.weight")
        .unwrap()
        .data
        .clone();
    for _ in 0..3 {
        let s = t.iteration().unwrap();
        assert!(s.actor_loss.is_finite());
    }
    let out = c.run.out_dir.join("adapted.safetensors");
    t.save(&out).unwrap();
    let adapted = checkpoint::load(&out, None).unwrap().policy;
    // gated adapters (default): the base tasks keep the base policy's actions after training,
    // while the new task's actions moved
    let after = actions(&adapted, &new_obs, n);
    let diff = a0.iter().zip(&after).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    println!("after adaptation, base-task actions vs base policy: max |diff| {diff:.2e}");
    assert!(diff <= 1e-6, "{diff}");
    let carry_obs = new_task_obs;
    let (now, before) = (
        actions(&adapted, &carry_obs, n),
        actions(&perturbed_free(&t.policy, &init_new), &carry_obs, n),
    );
    assert!(
        now.iter().zip(&before).any(|(x, y)| (x - y).abs() > 1e-5),
        "the new task's actions changed"
    );
    let (old, new) = (token(&base_policy), token(&adapted));
    for o in &old.tensors {
        let x = new.tensors.iter().find(|x| x.name == o.name).unwrap();
        assert!(
            o.data.iter().zip(&x.data).all(|(a, b)| a.to_bits() == b.to_bits()),
            "frozen tensor {} changed",
            o.name
        );
    }
    for col in 0..old_groups {
        assert_eq!(
            adapted.obs_norm.mean[col].to_bits(),
            base_policy.obs_norm.mean[col].to_bits(),
            "statistics of column {col}"
        );
        assert_eq!(adapted.obs_norm.var[col].to_bits(), base_policy.obs_norm.var[col].to_bits());
    }
    let moved = |name: &str| {
        new.tensors.iter().find(|x| x.name == name).unwrap().data.iter().any(|&v| v != 0.0)
    };
    assert!(moved("adapters.0.weight") && moved("adapters.1.weight"), "the adapters trained");
    let now = &new.tensors.iter().find(|x| x.name == "tokenizers.3.0.weight").unwrap().data;
    assert!(now.iter().zip(&init_new).any(|(a, b)| a != b), "the new tokenizer trained");
    let _ = std::fs::remove_dir_all(&base_cfg.run.out_dir);
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}

/// SkillMimic's high-level tasks as task tokens: one categorical token controller over the frozen
/// skill policy trains on heading + circling, then a new high-level task with the same skill
/// choices (steering) is added by adaptation with the base frozen; a task with another choice
/// table (scoring: 7 choices) is refused, as the frozen output layer cannot serve it.
#[test]
fn a_new_high_level_task_is_added_by_adaptation() {
    #[path = "common/mod.rs"]
    mod common;
    let mut c = config("hlc-base");
    c.env.task = "hlc_multi".into();
    c.env.table_mut::<MultiConfig>().tasks = vec!["heading".into(), "circling".into()];
    c.env.motion = vec![common::workspace_root().join("motions")];
    c.env.table_mut::<HlcConfig>().llc = common::skill_policy("token-adapt");
    c.ppo.policy = "token_transformer_categorical".into();
    let mut base = Trainer::new(c.clone(), None).unwrap();
    let groups: Vec<String> = token(&base.policy).spec.groups.iter().map(|g| g.0.clone()).collect();
    assert_eq!(groups, ["state", "heading", "circling"]);
    assert_eq!(token(&base.policy).spec.mask, 2);
    base.iteration().unwrap();
    let path = c.run.out_dir.join("hl_base.safetensors");
    base.save(&path).unwrap();

    let mut a = c.clone();
    a.env.table_mut::<MultiConfig>().tasks = vec!["scoring".into()];
    a.env.table_mut::<MultiConfig>().groups =
        vec!["heading".into(), "circling".into(), "scoring".into()];
    a.ppo.token.adapt_from = path.clone();
    a.run.out_dir = c.run.out_dir.join("adapt");
    let err = Trainer::new(a.clone(), None).err().expect("another action space").to_string();
    assert!(err.contains("Discrete { n: 3 }") && err.contains("Discrete { n: 7 }"), "{err}");
    a.env.table_mut::<MultiConfig>().tasks = vec!["steering".into()];
    a.env.table_mut::<MultiConfig>().groups =
        vec!["heading".into(), "circling".into(), "steering".into()];
    let mut t = Trainer::new(a, None).unwrap();
    let spec = &token(&t.policy).spec;
    assert!(spec.adapters && spec.groups.len() == 4 && spec.groups[3].0 == "steering");
    t.iteration().unwrap();
    let base_policy = checkpoint::load(&path, None).unwrap().policy;
    for o in &token(&base_policy).tensors {
        let x = token(&t.policy).tensors.iter().find(|x| x.name == o.name).unwrap();
        assert_eq!(o.data, x.data, "frozen tensor {} changed", o.name);
    }
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}
