//! Data-parallel training on an in-process group of ranks (threads): from one rollout, 2 ranks ×
//! N/2 environments take the update 1 process × N takes (parameters, σ, Adam state and both
//! normalisers), ranks agree bit for bit, a configuration mismatch is an error, and every
//! registered task × compatible policy family trains on 2 ranks.

mod common;
use common::{skill_policy, workspace_root};
use skillmimic_env::registry::TASKS;
use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_learn::collective::threads::ThreadGroup;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policies::FAMILIES;
use skillmimic_learn::storage::Rollout;
use skillmimic_learn::trainer::Trainer;

fn config(task: &str, tag: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.to_string();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 1;
    c.run.learner_threads = 1;
    c.ppo.horizon = 16;
    c.ppo.minibatch = 32;
    c.ppo.mini_epochs = 2;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-dp-{tag}-{}", std::process::id()));
    c
}

/// Everything an update changes, flattened: parameters + σ (f32 → f64), Adam moments, the
/// normalisers' statistics.
fn state(t: &Trainer) -> Vec<(String, Vec<f64>)> {
    let p = &t.policy;
    let mut out: Vec<(String, Vec<f64>)> = Vec::new();
    for (i, x) in p.actor.params().iter().chain(p.critic.params().iter()).enumerate() {
        out.push((format!("param {i}"), x.iter().map(|&v| v as f64).collect()));
    }
    for (i, (m, v)) in t.adam.m.iter().zip(&t.adam.v).enumerate() {
        out.push((format!("adam m {i}"), m.iter().map(|&v| v as f64).collect()));
        out.push((format!("adam v {i}"), v.iter().map(|&v| v as f64).collect()));
    }
    out.push(("obs mean".into(), p.obs_norm.mean.clone()));
    out.push(("obs var".into(), p.obs_norm.var.clone()));
    out.push(("obs count".into(), vec![p.obs_norm.count]));
    out.push((
        "value mean/var/count".into(),
        vec![p.value_norm.mean[0], p.value_norm.var[0], p.value_norm.count],
    ));
    out
}

/// Max over tensors of max|a − b| / max|a| (relative to the tensor's scale).
fn max_rel(a: &[(String, Vec<f64>)], b: &[(String, Vec<f64>)]) -> (f64, String) {
    let mut worst = (0.0, String::new());
    for ((name, x), (_, y)) in a.iter().zip(b) {
        let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-12);
        let d = x.iter().zip(y).fold(0.0f64, |m, (p, q)| m.max((p - q).abs())) / scale;
        if d > worst.0 {
            worst = (d, name.clone());
        }
    }
    worst
}

/// Run `f(rank, trainer)` on `world` ranks built over one in-process group.
fn on_ranks<R: Send>(
    cfg: &TrainConfig,
    world: usize,
    f: impl Fn(&mut Trainer) -> R + Sync,
) -> Vec<R> {
    let group = ThreadGroup::new_group(world);
    std::thread::scope(|s| {
        let hs: Vec<_> = group
            .into_iter()
            .map(|g| {
                let (cfg, f) = (cfg.clone(), &f);
                s.spawn(move || {
                    let mut t = Trainer::with_collective(cfg, None, Box::new(g)).unwrap();
                    f(&mut t)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

#[test]
fn two_ranks_take_the_single_process_update_from_one_rollout() {
    let cfg = config("imitation", "eq");
    let mut one = Trainer::new(cfg.clone(), None).unwrap();
    let before = state(&one);
    let stats = one.collect_rollout().unwrap();
    let full: Rollout = one.rollout_storage().clone();
    let s1 = one.update_from_rollout(stats).unwrap();
    let want = state(&one);
    let ranks = on_ranks(&cfg, 2, |t| {
        assert_eq!(t.shard.local, 4);
        assert_eq!(
            state(t),
            before,
            "rank {} starts from the single process's state",
            t.shard.rank
        );
        t.load_rollout_part(&full);
        let s = t.update_from_rollout(Default::default()).unwrap();
        (state(t), s)
    });
    assert_eq!(ranks[0].0, ranks[1].0, "both ranks hold the same state after the update");
    let (rel, at) = max_rel(&want, &ranks[0].0);
    let params = |s: &[(String, Vec<f64>)]| {
        s.iter().filter(|(n, _)| n.starts_with("param")).cloned().collect::<Vec<_>>()
    };
    let (moved, _) = max_rel(&params(&want), &params(&before));
    println!(
        "1 x 8 vs 2 x 4 environments: max relative difference {rel:.2e} ({at}); the update itself \
            moved the parameters by {moved:.2e}"
    );
    assert!(moved > 1e-5, "the update changed the parameters ({moved:.2e})");
    // float32 rounding of sums taken in another order, amplified by Adam's division by sqrt(v):
    // measured 5e-6 to 1.1e-5 of a tensor's scale depending on the episode starts
    assert!(rel <= 3e-5, "2 ranks differ from 1 process by {rel:.3e} in {at}");
    // the reduced loss statistics are those of the whole minibatches
    for (a, b) in [
        (s1.actor_loss, ranks[0].1.actor_loss),
        (s1.critic_loss, ranks[0].1.critic_loss),
        (s1.clip_frac, ranks[0].1.clip_frac),
    ] {
        assert!((a - b).abs() <= 1e-5 * a.abs().max(1e-3), "loss statistics {a} vs {b}");
    }
    // three ranks over 8 environments (3 + 3 + 2) give the same update
    let three = on_ranks(&cfg, 3, |t| {
        t.load_rollout_part(&full);
        t.update_from_rollout(Default::default()).unwrap();
        state(t)
    });
    let (rel3, at3) = max_rel(&want, &three[2]);
    println!("1 x 8 vs 3 x (3, 3, 2): max relative difference {rel3:.2e} ({at3})");
    assert!(rel3 <= 1e-5 && three[0] == three[2]);
}

#[test]
fn full_iterations_agree_across_ranks_and_a_mismatch_is_an_error() {
    let cfg = config("imitation", "it");
    let out = on_ranks(&cfg, 2, |t| {
        let s = (0..2).map(|_| t.iteration().unwrap()).last().unwrap();
        (state(t), s.mean_reward, s.samples, s.world_size)
    });
    assert_eq!(out[0], out[1], "ranks hold the same state and report the same reduced statistics");
    assert_eq!(out[0].2, 2 * 8 * 16);
    // ranks with different PPO settings must not start
    let group = ThreadGroup::new_group(2);
    let errs: Vec<String> = std::thread::scope(|s| {
        let hs: Vec<_> = group
            .into_iter()
            .enumerate()
            .map(|(r, g)| {
                let mut c = cfg.clone();
                c.ppo.lr *= 1.0 + r as f64;
                s.spawn(move || {
                    Trainer::with_collective(c, None, Box::new(g))
                        .err()
                        .map(|e| e.to_string())
                        .unwrap_or_default()
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(
        errs.iter().all(|e| e.contains("rank 1 disagrees with rank 0 on the configuration")),
        "{errs:?}"
    );
}

#[test]
fn every_task_and_family_trains_on_two_ranks() {
    let llc = skill_policy("dp");
    let mut pairs = 0;
    for (entry, family) in TASKS.iter().flat_map(|e| FAMILIES.iter().map(move |f| (e, *f))) {
        let mut c = config(entry.name, &format!("{}-{}", entry.name, family.name()));
        // a multi-task environment needs one environment per task on every rank
        c.env.num_envs = if entry.name.ends_with("_multi") { 8 } else { 4 };
        c.ppo.token.tokenizer = vec![32];
        c.ppo.token.embed = 16;
        c.ppo.token.layers = 1;
        c.ppo.token.feedforward = 32;
        c.ppo.token.head = vec![32];
        c.ppo.horizon = 8;
        c.ppo.minibatch = 16;
        c.ppo.mini_epochs = 1;
        c.ppo.hidden = vec![32];
        if skillmimic_env::registry::is_high_level(entry.name) {
            c.env.table_mut::<HlcConfig>().llc = llc.clone();
        }
        let env = skillmimic_env::registry::make(&c.env).unwrap();
        let obs = skillmimic_learn::policies::ObsInfo::of_env(
            env.as_ref(),
            skillmimic_env::registry::character(&c.env).unwrap(),
        );
        if !family.acts_on(&env.spec().action_space, &obs) {
            continue;
        }
        pairs += 1;
        c.ppo.policy = family.name().to_string();
        let out = on_ranks(&c, 2, |t| {
            let s = t.iteration().unwrap();
            (state(t), s.mean_reward)
        });
        assert!(out[0].1.is_finite(), "{} / {}", entry.name, family.name());
        assert!(
            out[0].0.iter().all(|(_, v)| v.iter().all(|x| x.is_finite())),
            "{} / {}",
            entry.name,
            family.name()
        );
        assert_eq!(
            out[0],
            out[1],
            "{} / {}: ranks differ after an iteration",
            entry.name,
            family.name()
        );
    }
    assert!(pairs >= TASKS.len(), "every task trained with at least one family");
}
