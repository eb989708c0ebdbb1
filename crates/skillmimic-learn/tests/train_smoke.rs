//! End-to-end training smoke tests on the shipped demo clips: a tiny run writes checkpoints and
//! logs, resumes from its checkpoint, two runs with the same seed are bit-identical, and the fast
//! and candle learner backends take the same parameter updates.

use skillmimic_core::shared_data::workspace_root;
use skillmimic_learn::checkpoint;
use skillmimic_learn::config::{Backend, TrainConfig};
use skillmimic_learn::policy::Policy;
use skillmimic_learn::trainer::Trainer;

fn tiny(out: &str, iterations: usize) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.run.iterations = iterations;
    c.run.save_every = 2;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-train-{}-{out}", std::process::id()));
    c
}

#[test]
fn tiny_run_writes_checkpoints_and_resumes() {
    let cfg = tiny("a", 3);
    let out = cfg.run.out_dir.clone();
    let mut t = Trainer::new(cfg.clone(), None).unwrap();
    let mut seen = Vec::new();
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    assert_eq!(seen.len(), 3);
    assert!(seen.iter().all(|s| s.mean_reward.is_finite() && s.critic_loss.is_finite()));
    println!(
        "iteration stats: {:?}",
        seen.iter().map(|s| (s.mean_reward, s.samples_per_s)).collect::<Vec<_>>()
    );
    assert!(last.ends_with("iter_000003.safetensors"));
    for f in [
        "config.toml",
        "log.jsonl",
        "latest.safetensors",
        "checkpoints/iter_000002.safetensors",
        "checkpoints/iter_000002.toml",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert_eq!(std::fs::read_to_string(out.join("log.jsonl")).unwrap().lines().count(), 3);
    // resume for two more iterations
    let mut cfg2 = cfg.clone();
    cfg2.run.iterations = 5;
    let mut t2 = Trainer::new(cfg2, Some(&last)).unwrap();
    assert_eq!(t2.progress.iteration, 3);
    assert_eq!(t2.adam.step, t.adam.step);
    assert_eq!(t2.policy, t.policy);
    skillmimic_learn::runner::train_loop(&mut t2, |_| {}).unwrap();
    assert_eq!(t2.progress.iteration, 5);
    let c = checkpoint::load(&out.join("latest.safetensors"), Some((902, 156))).unwrap();
    assert_eq!(c.progress.iteration, 5);
    assert_eq!(c.progress.samples, 5 * 8 * 16);
    std::fs::remove_dir_all(&out).ok(); // 32 MB of checkpoints (kept when an assertion fails)
}

#[test]
fn same_seed_gives_bit_identical_runs() {
    let run = |tag: &str| {
        let mut t = Trainer::new(tiny(tag, 2), None).unwrap();
        let mut rewards = Vec::new();
        skillmimic_learn::runner::train_loop(&mut t, |s| {
            rewards.push((s.mean_reward, s.actor_loss, s.critic_loss))
        })
        .unwrap();
        (rewards, t.policy.clone())
    };
    let (ra, pa) = run("s1");
    let (rb, pb) = run("s2");
    assert_eq!(ra, rb);
    assert_eq!(pa, pb);
    for tag in ["s1", "s2"] {
        std::fs::remove_dir_all(tiny(tag, 0).run.out_dir).ok();
    }
}

/// All trained parameters (actor, then critic; optimiser order) as one flat vector.
fn flat_params(p: &Policy) -> Vec<f32> {
    p.actor.params().into_iter().chain(p.critic.params()).flatten().copied().collect()
}

/// Number of actor parameters (the first entries of [`flat_params`]).
fn actor_len(p: &Policy) -> usize {
    p.actor.params().iter().map(|x| x.len()).sum()
}

/// One PPO iteration of both trainers (a: candle, b: fast) on `a`'s rollout from the same state,
/// then compare the parameter change Δθ element-wise and Adam's first moments per tensor.
/// Returns how many actor and critic parameters moved by more than 10× the tolerance.
fn same_update(a: &mut Trainer, b: &mut Trainer) -> (usize, usize) {
    let iteration = a.progress.iteration + 1;
    let theta0 = flat_params(&a.policy);
    assert_eq!(
        theta0,
        flat_params(&b.policy),
        "iteration {iteration}: both start from the same parameters"
    );
    let stats = a.collect_rollout().unwrap();
    b.load_rollout_part(a.rollout_storage());
    let sa = a.update_from_rollout(stats.clone()).unwrap();
    let sb = b.update_from_rollout(stats).unwrap();
    println!(
        "iteration {iteration}: clip fraction {} / {}, approx KL {} / {}",
        sa.clip_frac, sb.clip_frac, sa.approx_kl, sb.approx_kl
    );
    let rel = |x: f64, y: f64| (x - y).abs() / y.abs().max(1e-12);
    for (name, x, y) in [
        ("actor", sa.actor_loss, sb.actor_loss),
        ("critic", sa.critic_loss, sb.critic_loss),
        ("bounds", sa.bounds_loss, sb.bounds_loss),
    ] {
        println!(
            "iteration {iteration} {name} loss: candle {x:.6e}, fast {y:.6e}, relative difference \
                {:.2e}",
            rel(x, y)
        );
        assert!(rel(x, y) < 1e-3 || (x - y).abs() < 1e-7, "{name}: {x} vs {y}");
    }
    let delta = |p: &Policy| -> Vec<f32> {
        flat_params(p).iter().zip(&theta0).map(|(x, x0)| x - x0).collect()
    };
    let (da, db) = (delta(&a.policy), delta(&b.policy));
    // Adam's ε = 1 (see the test) makes each step ≈ lr·m̂/(√v̂ + 1), nearly linear in the
    // gradients: the backends' gradients agree to ≈ 1e-5 relative (tests/fast_grads.rs), but the
    // surrogate's ratio exp(Δ log-prob) over 156 dimensions at σ = 0.055 amplifies the rounding
    // of μ (measured: largest difference 0.6e-4 of the largest step, in the actor's output
    // bias). Tolerance: 3e-4 of the largest step plus the rounding of θ (2 steps, ≤ 1 ulp each).
    let scale = da.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let tol = 3e-4 * scale;
    let theta1 = flat_params(&a.policy);
    let (mut worst, mut worst_at, mut over) = (0.0f32, 0usize, 0usize);
    for (k, (x, y)) in da.iter().zip(&db).enumerate() {
        let tol_k = tol + 4.0 * f32::EPSILON * theta0[k].abs().max(theta1[k].abs());
        let d = (x - y).abs() / tol_k;
        over += usize::from(d > 1.0);
        if d > worst {
            (worst, worst_at) = (d, k);
        }
    }
    let norm = |v: &[f32]| v.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
    let na = actor_len(&a.policy);
    let moved = |v: &[f32]| v.iter().filter(|x| x.abs() > 10.0 * tol).count();
    let (moved_actor, moved_critic) = (moved(&da[..na]), moved(&da[na..]));
    println!(
        "iteration {iteration} Δθ: {} parameters, ‖Δ candle‖ = {:.3e}, ‖Δ fast‖ = {:.3e}, ‖Δ \
            candle − Δ fast‖ = {:.3e}, largest difference / tolerance = {worst:.3} at {worst_at} \
            (tolerance {tol:.1e} + 4 ulp of θ); moved > 10 × tolerance: {moved_actor} of {na} \
            actor, {moved_critic} of {} critic parameters",
        da.len(),
        norm(&da),
        norm(&db),
        norm(&da.iter().zip(&db).map(|(x, y)| x - y).collect::<Vec<_>>()),
        da.len() - na,
    );
    assert_eq!(
        over, 0,
        "iteration {iteration}: {over} elements of Δθ differ by more than the tolerance (worst \
            {worst:.2}× at {worst_at}: candle {}, fast {})",
        da[worst_at], db[worst_at]
    );
    // first moments, per tensor relative to its largest entry (measured: ≤ 5e-5, the same
    // amplification as above)
    let mut worst_m = 0.0f32;
    for (k, (ma, mb)) in a.adam.m.iter().zip(&b.adam.m).enumerate() {
        let scale = ma.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let diff = ma.iter().zip(mb).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(scale > 0.0, "iteration {iteration} tensor {k}: no gradient");
        assert!(
            diff <= 3e-4 * scale,
            "iteration {iteration} tensor {k}: Adam first moments differ by {diff:e} (largest \
                {scale:e})"
        );
        worst_m = worst_m.max(diff / scale);
    }
    println!(
        "iteration {iteration}: largest first-moment difference {worst_m:.2e} of its tensor's \
            largest entry"
    );
    (moved_actor, moved_critic)
}

#[test]
fn fast_and_candle_backends_take_the_same_first_update() {
    // Same seed → same initial policy; the fast trainer updates on the candle trainer's rollout,
    // so both iteration-1 updates (2 mini-epochs × 1 minibatch = 2 Adam steps) see identical
    // data. The parameter change Δθ must agree element-wise to float rounding while most
    // elements are far larger than that tolerance: a gradient with a flipped sign, a dropped
    // loss term or a wrong scale in either backend changes Δθ by the size of the step.
    //
    // Adam's ε is 1 instead of 1e-8: with a tiny ε each element's step is ≈ lr·sign(g) whatever
    // the gradient's size, so the rounding-level gradients of inactive units get full steps of
    // random sign (measured: 21 of 548 381 elements differed by up to 2·lr) and a common scale
    // of the gradients would go unseen. Adam's first moments m are compared too.
    //
    // The observation normaliser is warmed up first (statistics of one rollout, weight 1e9):
    // from its initial statistics (mean 0, variance 1) the first minibatch's normaliser update
    // moves every probability ratio far outside the clip range (measured: clip fraction 1,
    // approx KL 440 and 75 in iterations 1 and 2), and only the critic would learn.
    let make = |backend: Backend, tag: &str| {
        let mut c = tiny(tag, 1);
        c.ppo.backend = backend;
        c.ppo.adam_eps = 1.0;
        c.ppo.lr = 1e-4;
        Trainer::new(c, None).unwrap()
    };
    let mut a = make(Backend::Candle, "upd-candle");
    let mut b = make(Backend::Fast, "upd-fast");
    a.collect_rollout().unwrap();
    let mut norm = a.policy.obs_norm.clone();
    norm.update(&a.rollout_storage().obs);
    norm.count = 1e9;
    a.policy.obs_norm = norm.clone();
    b.policy.obs_norm = norm;
    let (actor, critic) = same_update(&mut a, &mut b);
    let (na, nc) = (actor_len(&a.policy), flat_params(&a.policy).len() - actor_len(&a.policy));
    assert!(actor > na / 2, "the actor learns: {actor} of {na} parameters moved");
    assert!(critic > nc / 2, "the critic learns: {critic} of {nc} parameters moved");
}
