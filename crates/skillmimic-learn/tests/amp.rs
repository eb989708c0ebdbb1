//! The AMP discriminator on the shipped demo clips: trained on reference windows (clips posed in
//! the scene) against windows of a random policy in the imitation task, its loss falls, it scores
//! reference windows above simulated ones and their style reward is higher; its gradient-penalty
//! gradients equal central finite differences of the loss.

use skillmimic_learn::amp_reward::AmpReward;
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_env::EnvConfig;
use skillmimic_env::amp::{FEATURE_DIM, clip_features, frame_features, window};
use skillmimic_env::tasks::imitation::load_motion_library;
use skillmimic_learn::amp::{AmpLoss, DiscConfig, Discriminator};
use skillmimic_sim::Scene;

const K: usize = 10;

fn motion() -> Vec<std::path::PathBuf> {
    vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")]
}

/// `n` reference windows at random clips and end frames.
fn reference_windows(rows: &[Vec<f32>], n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    let mut out = vec![0.0f32; n * K * FEATURE_DIM];
    for w in out.chunks_exact_mut(K * FEATURE_DIM) {
        let c = rng.random_range(0..rows.len());
        let end = rng.random_range(0..rows[c].len() / FEATURE_DIM);
        window(&rows[c], end, K, w);
    }
    out
}

/// Windows of a random policy (uniform actions in ±0.5) in the imitation task.
fn policy_windows(steps: usize) -> Vec<f32> {
    let mut c = EnvConfig { num_envs: 8, threads: 1, ..Default::default() };
    c.motion = motion();
    let mut env = skillmimic_env::registry::make(&c).unwrap();
    env.reset_all(Some(2));
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut frames: Vec<Vec<f32>> = vec![Vec::new(); 8];
    let mut out = Vec::new();
    for _ in 0..steps {
        let a: Vec<f32> = (0..8 * 156).map(|_| rng.random_range(-0.5..0.5)).collect();
        env.step(&a).unwrap();
        for (i, f) in frames.iter_mut().enumerate() {
            let mut row = vec![0.0f32; FEATURE_DIM];
            frame_features(&env.buffers().obs[i * 902..(i + 1) * 902], &mut row);
            f.extend(row);
            if f.len() >= K * FEATURE_DIM {
                out.extend_from_slice(&f[f.len() - K * FEATURE_DIM..]);
            }
        }
        env.reset_done();
    }
    out
}

#[test]
fn discriminator_separates_reference_from_random_policy_windows() {
    let c = EnvConfig { motion: motion(), ..Default::default() };
    let lib = load_motion_library(&c.motion).unwrap();
    let rows = clip_features(
        Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c).unwrap()).unwrap()),
        &lib,
    )
    .unwrap();
    let sim = policy_windows(40);
    let n_sim = sim.len() / (K * FEATURE_DIM);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let cfg = DiscConfig { hidden: vec![128, 64], lr: 1e-3, ..Default::default() };
    let mut disc = Discriminator::new(K * FEATURE_DIM, cfg, &mut rng);
    let mut losses = Vec::new();
    for _ in 0..60 {
        let r = reference_windows(&rows, 64, &mut rng);
        let pick: Vec<usize> = (0..64).map(|_| rng.random_range(0..n_sim)).collect();
        let s: Vec<f32> = pick
            .iter()
            .flat_map(|&k| sim[k * K * FEATURE_DIM..(k + 1) * K * FEATURE_DIM].iter().copied())
            .collect();
        losses.push(disc.update(&r, 64, &s, 64).unwrap());
    }
    let (first, last) = (losses[0], losses[losses.len() - 1]);
    println!(
        "discriminator loss {:.4} -> {:.4} (adversarial {:.4} -> {:.4}); mean logits ref {:.2} \
            sim {:.2}",
        first.total, last.total, first.adversarial, last.adversarial, last.mean_ref, last.mean_sim
    );
    assert!(last.adversarial < 0.5 * first.adversarial, "the adversarial loss falls");
    assert!(last.mean_ref > last.mean_sim);
    let r = reference_windows(&rows, 64, &mut rng);
    let rr: f32 = disc.style_reward(&r, 64).iter().sum::<f32>() / 64.0;
    let rs: f32 = disc.style_reward(&sim[..64 * K * FEATURE_DIM], 64).iter().sum::<f32>() / 64.0;
    println!("style reward: reference windows {rr:.3}, random-policy windows {rs:.3}");
    assert!(rr > rs);
}

#[test]
fn loss_gradients_equal_finite_differences() {
    for (loss, gp, wd) in [
        (AmpLoss::Logistic, 0.0, 0.0),
        (AmpLoss::Logistic, 5.0, 0.0),
        (AmpLoss::LeastSquares, 5.0, 0.0),
        (AmpLoss::Logistic, 5.0, 0.05),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let cfg = DiscConfig {
            hidden: vec![16, 8],
            loss,
            grad_penalty: gp,
            logit_reg: 0.05,
            weight_decay: wd,
            ..Default::default()
        };
        let mut disc = Discriminator::new(6, cfg, &mut rng);
        for b in disc.mlp.biases.iter_mut() {
            b.iter_mut().for_each(|v| *v = rng.random_range(-0.3..0.3));
        }
        let xr: Vec<f32> = (0..12 * 6).map(|_| rng.random_range(-1.5..1.5)).collect();
        let xs: Vec<f32> = (0..10 * 6).map(|_| rng.random_range(-1.5..1.5)).collect();
        let (_, grads) = disc.loss_and_grads(&xr, 12, &xs, 10).unwrap();
        let mut worst = 0.0f64;
        for (k, g) in grads.iter().enumerate() {
            for idx in (0..g.len()).step_by(7) {
                let h = 1e-3f32;
                let eval = |delta: f32| {
                    let mut d2 = disc.clone();
                    d2.mlp.params_mut()[k][idx] += delta;
                    d2.loss_and_grads(&xr, 12, &xs, 10).unwrap().0.total
                };
                let fd = (eval(h) - eval(-h)) / (2.0 * h as f64);
                worst = worst.max((fd - g[idx] as f64).abs() / (1.0 + fd.abs()));
            }
        }
        println!(
            "{loss:?} gp {gp} decay {wd}: max |finite difference - gradient| / (1 + |fd|) = \
                {worst:.2e}"
        );
        assert!(worst < 1e-3, "{loss:?}: {worst}");
        // the decay term is wd · Σ of every layer's squared weights (biases excluded)
        let mut plain = disc.clone();
        plain.cfg.weight_decay = 0.0;
        let sq: f64 = disc.mlp.weights.iter().flatten().map(|&w| (w as f64) * (w as f64)).sum();
        let (with, without) = (
            disc.loss_and_grads(&xr, 12, &xs, 10).unwrap().0.total,
            plain.loss_and_grads(&xr, 12, &xs, 10).unwrap().0.total,
        );
        assert!((with - without - wd * sq).abs() < 1e-4 * (1.0 + wd * sq), "{with} {without} {sq}");
    }
}

/// A 2-iteration run of preset `tiny` with the motion prior on the demo clips: 8 environments,
/// 2 threads, networks [32], discriminator batch 32 and buffer 256, output in `temp/<tag>-<pid>`.
fn tiny_amp_run(tag: &str) -> skillmimic_learn::config::TrainConfig {
    let mut c = skillmimic_learn::config::TrainConfig::preset("tiny").unwrap();
    c.env.motion = motion();
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.ppo.hidden = vec![32];
    c.ppo.amp.enabled = true;
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 32;
    c.ppo.amp.buffer = 256;
    c.run.iterations = 2;
    c.run.save_every = 2;
    c.run.eval_episodes = 2;
    c.run.out_dir = std::env::temp_dir().join(format!("{tag}-{}", std::process::id()));
    c
}

#[test]
fn motion_prior_trains_inside_ppo_and_resumes_from_the_checkpoint() {
    use skillmimic_learn::trainer::Trainer;
    let c = tiny_amp_run("sm-amp");
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let before = t.extension::<AmpReward>().unwrap().disc().mlp.clone();
    let mut seen = Vec::new();
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    let s = &seen[1];
    let term =
        |name: &str| s.reward_terms.iter().find(|(n, _)| n == name).map(|(_, v)| *v).unwrap();
    let (task, style) = (term("task"), term("style"));
    println!("terms {:?}", s.reward_terms);
    println!(
        "mixed reward {:.4} = 0.5 x task {task:.4} + 0.5 x style {style:.4}; discriminator loss \
            {:.4}",
        s.mean_reward, s.disc_loss
    );
    assert!((s.mean_reward - 0.5 * (task + style)).abs() < 1e-5);
    assert!(s.disc_loss > 0.0 && style.is_finite() && style >= 0.0);
    assert_ne!(t.extension::<AmpReward>().unwrap().disc().mlp, before, "the discriminator trains");
    let t2 = Trainer::new(c, Some(&last)).unwrap();
    let (a, b) =
        (&t.extension::<AmpReward>().unwrap().disc(), &t2.extension::<AmpReward>().unwrap().disc());
    assert_eq!(a.mlp, b.mlp);
    assert_eq!(
        (a.norm.mean.clone(), a.adam.step, a.adam.m.clone()),
        (b.norm.mean.clone(), b.adam.step, b.adam.m.clone())
    );
}

/// ModSkill's setting: preset `modskill` turns the prior on with the released settings, and on the
/// SMPL humanoid's tracking task the discriminator reads the released 232 features per frame
/// (`skillmimic_env::tasks::tracking::prior`) of the state, its references the tracking clips.
#[test]
fn modskill_preset_trains_the_released_prior_on_smpl_tracking() {
    use skillmimic_env::tasks::tracking::prior::SMPL_PRIOR_DIM;
    use skillmimic_learn::config::TrainConfig;
    use skillmimic_learn::trainer::Trainer;
    let preset = TrainConfig::preset("modskill").unwrap();
    let a = &preset.ppo.amp;
    assert!(a.enabled && a.window == 10 && a.hidden == vec![1024, 512]);
    assert_eq!((a.logit_reg, a.weight_decay, a.grad_penalty), (0.01, 1e-4, 5.0));
    assert_eq!((a.reward_scale, a.task_weight, a.style_weight), (2.0, 0.5, 0.5));
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.ppo.amp = preset.ppo.amp.clone();
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 32;
    c.ppo.amp.buffer = 256;
    c.env.task = "tracking".into();
    c.env.character = "smpl".into();
    c.env.motion = motion();
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.ppo.hidden = vec![32];
    c.run.iterations = 2;
    c.run.save_every = 2;
    c.run.eval_episodes = 2;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-amp-smpl-{}", std::process::id()));
    let mut t = Trainer::new(c.clone(), None).unwrap();
    assert_eq!(t.extension::<AmpReward>().unwrap().disc().input_dim(), 10 * SMPL_PRIOR_DIM);
    let mut seen = Vec::new();
    skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    let s = &seen[1];
    let term =
        |name: &str| s.reward_terms.iter().find(|(n, _)| n == name).map(|(_, v)| *v).unwrap();
    let (task, style) = (term("task"), term("style"));
    println!(
        "SMPL tracking with the prior: task {task:.4}, style {style:.4}, disc loss {:.4}",
        s.disc_loss
    );
    assert!((s.mean_reward - 0.5 * (task + style)).abs() < 1e-5);
    assert!(s.disc_loss > 0.0 && style.is_finite() && style >= 0.0);
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}

/// Data-parallel discriminator steps: 2 ranks, each with half of the windows, take the step one
/// process takes on all of them (parameters, Adam moments, normaliser to float rounding), and the
/// replicas stay bit-identical.
#[test]
fn two_ranks_take_the_single_process_discriminator_step() {
    use skillmimic_learn::collective::threads::ThreadGroup;
    let c = EnvConfig { motion: motion(), ..Default::default() };
    let lib = load_motion_library(&c.motion).unwrap();
    let rows = clip_features(
        Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c).unwrap()).unwrap()),
        &lib,
    )
    .unwrap();
    let sim = policy_windows(40);
    let w = K * FEATURE_DIM;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let batches: Vec<(Vec<f32>, Vec<f32>)> =
        (0..3).map(|_| (reference_windows(&rows, 32, &mut rng), sim[..32 * w].to_vec())).collect();
    let cfg = DiscConfig { hidden: vec![64, 32], lr: 1e-3, ..Default::default() };
    let fresh = Discriminator::new(w, cfg, &mut ChaCha8Rng::seed_from_u64(7));
    let mut single = fresh.clone();
    for (r, s) in &batches {
        single.update(r, 32, s, 32).unwrap();
    }
    let group = ThreadGroup::new_group(2);
    let ranks: Vec<Discriminator> = std::thread::scope(|sc| {
        let hs: Vec<_> = group
            .into_iter()
            .enumerate()
            .map(|(k, mut g)| {
                let (mut d, batches) = (fresh.clone(), &batches);
                sc.spawn(move || {
                    for (r, s) in batches {
                        let half = |x: &[f32]| x[k * 16 * w..(k + 1) * 16 * w].to_vec();
                        d.update_with(&half(r), 16, &half(s), 16, &mut g).unwrap();
                    }
                    d
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(ranks[0].mlp, ranks[1].mlp, "replicas stay equal");
    assert_eq!(ranks[0].norm.mean, ranks[1].norm.mean);
    let worst = |a: &[&[f32]], b: &[&[f32]]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| x.iter().zip(*y).map(|(p, q)| (p - q).abs()).fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max)
    };
    let dp = worst(&single.mlp.params(), &ranks[0].mlp.params());
    let dm = single
        .norm
        .mean
        .iter()
        .zip(&ranks[0].norm.mean)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    println!(
        "2 ranks vs 1 process after 3 steps: max |d param| {dp:.2e}, max |d norm mean| {dm:.2e}"
    );
    // float32 sums in another order differ by rounding; Adam divides by sqrt(v), so a gradient
    // component near zero turns rounding into up to ~lr per step: 5e-5 = lr / 20 after 3 steps
    // (measured 2e-6 to 2e-5 depending on the episode starts); a wrong reduction moves by ~lr
    assert!(dp < 5e-5 && dm < 1e-9, "{dp} {dm}");
}

/// The motion prior in a 2-rank training run: the ranks' discriminators stay equal, the style
/// reward is reported, and a batch that does not split over the ranks is a clear error.
#[test]
fn motion_prior_trains_data_parallel() {
    use skillmimic_learn::collective::threads::ThreadGroup;
    use skillmimic_learn::config::TrainConfig;
    use skillmimic_learn::trainer::Trainer;
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = motion();
    c.env.num_envs = 8;
    c.env.threads = 1;
    c.run.learner_threads = 1;
    c.ppo.hidden = vec![32];
    c.ppo.horizon = 16;
    c.ppo.minibatch = 32;
    c.ppo.amp.enabled = true;
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 32;
    c.ppo.amp.buffer = 256;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-amp-dp-{}", std::process::id()));
    let run = |c: &TrainConfig| -> Vec<Result<(Discriminator, f64), String>> {
        let group = ThreadGroup::new_group(2);
        std::thread::scope(|sc| {
            let hs: Vec<_> = group
                .into_iter()
                .map(|g| {
                    let c = c.clone();
                    sc.spawn(move || {
                        let mut t = Trainer::with_collective(c, None, Box::new(g))
                            .map_err(|e| e.to_string())?;
                        let mut style = 0.0;
                        for _ in 0..2 {
                            let s = t.iteration().map_err(|e| e.to_string())?;
                            style = s
                                .reward_terms
                                .iter()
                                .find(|(n, _)| n == "style")
                                .map(|(_, v)| *v)
                                .unwrap();
                        }
                        Ok((t.extension::<AmpReward>().unwrap().disc().clone(), style))
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        })
    };
    let out = run(&c);
    let (a, b) = (out[0].as_ref().unwrap(), out[1].as_ref().unwrap());
    assert_eq!(a.0.mlp, b.0.mlp, "the ranks' discriminators are equal");
    assert_eq!(a.0.adam.step, 2 * c.ppo.amp.updates as u64);
    assert!(a.1 > 0.0 && a.1 == b.1, "the style reward is reduced over the ranks: {} {}", a.1, b.1);
    let mut bad = c.clone();
    bad.ppo.amp.batch = 33;
    let err =
        run(&bad).into_iter().find_map(Result::err).expect("33 windows do not split over 2 ranks");
    assert!(err.contains("ppo.amp.batch"), "{err}");
    let mut bad = c.clone();
    bad.ppo.amp.schedule = skillmimic_learn::config::AmpSchedule::PerMinibatch;
    let err = run(&bad).into_iter().find_map(Result::err).expect("per_minibatch is one-process");
    assert!(err.contains("ppo.amp.schedule") && err.contains("per_iteration"), "{err}");
}

/// The released agent's schedule (`ppo.amp.schedule = "per_minibatch"`, with its per-frame
/// normaliser): one discriminator step in every PPO minibatch (Adam counts iterations ×
/// mini-epochs × minibatches), the style reward mixed in as with the default schedule, and the
/// discriminator resumes from the checkpoint.
#[test]
fn the_released_schedule_steps_the_discriminator_in_every_minibatch() {
    use skillmimic_learn::config::AmpSchedule;
    use skillmimic_learn::trainer::Trainer;
    let mut c = tiny_amp_run("sm-amp-mb");
    c.ppo.horizon = 16;
    c.ppo.minibatch = 32;
    c.ppo.mini_epochs = 3;
    c.ppo.amp.batch = 16;
    c.ppo.amp.buffer = 64;
    c.ppo.amp.schedule = AmpSchedule::PerMinibatch;
    c.ppo.amp.normalizer = skillmimic_learn::config::AmpNormalizer::PerFrame;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    assert_eq!(t.extension::<AmpReward>().unwrap().disc().norm.dim(), FEATURE_DIM, "per frame");
    let mut seen = Vec::new();
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    let disc = t.extension::<AmpReward>().unwrap().disc().clone();
    // 128 samples per iteration in minibatches of 32, 3 epochs, 2 iterations
    assert_eq!(disc.adam.step, 2 * 3 * (128 / 32));
    for s in &seen {
        let term =
            |name: &str| s.reward_terms.iter().find(|(n, _)| n == name).map(|(_, v)| *v).unwrap();
        assert!((s.mean_reward - 0.5 * (term("task") + term("style"))).abs() < 1e-5);
        assert!(s.disc_loss.is_finite() && s.disc_loss > 0.0, "{}", s.disc_loss);
    }
    let t2 = Trainer::new(c.clone(), Some(&last)).unwrap();
    let back = t2.extension::<AmpReward>().unwrap().disc();
    assert_eq!((&disc.mlp, disc.adam.step), (&back.mlp, back.adam.step));
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}
