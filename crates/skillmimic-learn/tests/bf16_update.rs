//! The bf16 update (`ppo.precision = "bf16"`) against float32 on the same minibatch, with the
//! paper's network ([1024, 512, 512] actor and critic, 902 observations, 156 actions, σ = e^−2.9)
//! and with ModSkill's modular attention actor.
//!
//! Stated tolerance: every parameter gradient within 2 % relative L2 difference of the float32
//! path, and a cosine similarity above 0.999; the loss terms, clip fraction and approx-KL are
//! identical (the forward stays float32). Also measured: the log-ratio noise a bf16 forward would
//! add (the reason the forward stays float32).

use rand::{Rng, SeedableRng};
use skillmimic_learn::config::{PpoConfig, Precision};
use skillmimic_learn::policy::{Policy, neglogp_row};
use skillmimic_learn::ppo::Minibatch;
use skillmimic_learn::ppo::fast::{UpdateWorkspace, loss_and_grads_fast};
use skillmimic_learn::ppo::mlp_grad::{Mm, forward_keep};

const TOL: f64 = 0.02;

fn normal<R: Rng>(rng: &mut R) -> f32 {
    let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random_range(0.0..1.0));
    ((-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()) as f32
}

struct Batch {
    obs: Vec<f32>,
    act: Vec<f32>,
    old: Vec<f32>,
    adv: Vec<f32>,
    ret: Vec<f32>,
}

/// Observations ~ N(0, 1) clamped to ±5 (normalised), actions sampled from the policy, old
/// log-probabilities shifted by N(0, 0.1) so that some samples are clipped.
fn batch(p: &mut Policy, n: usize, rng: &mut impl Rng) -> Batch {
    let (d, a) = (p.obs_dim(), p.act_dim());
    p.normalize_input = false;
    p.normalize_value = false;
    let obs: Vec<f32> = (0..n * d).map(|_| normal(rng).clamp(-5.0, 5.0)).collect();
    let mut buf = Default::default();
    let (mut mu, mut v) = (vec![0.0; n * a], vec![0.0; n]);
    p.infer(&obs, n, &mut buf, &mut mu, &mut v, 1);
    let act: Vec<f32> =
        mu.iter().enumerate().map(|(i, m)| m + p.log_std[i % a].exp() * normal(rng)).collect();
    let old = (0..n)
        .map(|i| {
            neglogp_row(&act[i * a..(i + 1) * a], &mu[i * a..(i + 1) * a], &p.log_std) as f32
                + 0.1 * normal(rng)
        })
        .collect();
    let adv = (0..n).map(|_| normal(rng)).collect();
    let ret = (0..n).map(|_| normal(rng)).collect();
    Batch { obs, act, old, adv, ret }
}

fn compare(name: &str, p: &Policy, b: &Batch, cfg: &PpoConfig) {
    let n = b.ret.len();
    let mb = Minibatch {
        n,
        obs_n: &b.obs,
        actions: &b.act,
        old_neglogp: &b.old,
        advantages: &b.adv,
        returns_n: &b.ret,
    };
    let run = |precision| {
        let c = PpoConfig { precision, ..cfg.clone() };
        let mut ws = UpdateWorkspace::default();
        let l = loss_and_grads_fast(p, &mb, &c, &mut ws, 2);
        (l, ws.grads)
    };
    let (l32, g32) = run(Precision::F32);
    let (l16, g16) = run(Precision::Bf16);
    println!(
        "{name}: clip frac {:.4}, approx-KL {:.3e} (both precisions)",
        l32.clip_frac, l32.approx_kl
    );
    for (a, b) in [
        (l32.actor, l16.actor),
        (l32.critic, l16.critic),
        (l32.bounds, l16.bounds),
        (l32.clip_frac, l16.clip_frac),
        (l32.approx_kl, l16.approx_kl),
    ] {
        assert_eq!(a, b, "{name}: the forward and the loss terms must not change");
    }
    let names: Vec<String> = p
        .actor
        .param_names("actor")
        .into_iter()
        .chain(p.critic.param_names("critic"))
        .map(|x| x.0)
        .collect();
    let mut worst = (0.0f64, String::new());
    for ((name_p, a), b) in names.iter().zip(&g32).zip(&g16) {
        let dot: f64 = a.iter().zip(b).map(|(x, y)| *x as f64 * *y as f64).sum();
        let na: f64 = a.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
        let nb: f64 = b.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
        let diff: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>().sqrt();
        if na == 0.0 {
            assert_eq!(nb, 0.0, "{name} {name_p}");
            continue;
        }
        let (rel, cos) = (diff / na, dot / (na * nb));
        assert!(
            rel <= TOL && cos >= 0.999,
            "{name} {name_p}: relative L2 difference {rel:.3e}, cosine {cos:.6}"
        );
        if rel > worst.0 {
            worst = (rel, name_p.clone());
        }
    }
    println!("{name}: worst relative L2 gradient difference {:.2e} ({})", worst.0, worst.1);
}

#[test]
fn bf16_gradients_within_tolerance_of_f32() {
    if !skillmimic_nn::bf16::available() {
        eprintln!(
            "SKIP: this CPU has no AVX512-BF16; `ppo.precision = \"bf16\"` runs in float32 here"
        );
        assert!(
            !Mm::new(2, Precision::Bf16).bf16,
            "without the instructions the update must fall back to float32"
        );
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let cfg = PpoConfig::default();
    let mut p = Policy::new(902, 156, &cfg, &mut rng);
    let b = batch(&mut p, 2048, &mut rng);
    compare("paper MLP at initialisation", &p, &b, &cfg);
    // a trained-like policy: action means of order 1 (bounds loss active) and larger activations
    let actor = p.actor.as_mlp_mut().unwrap();
    let last = actor.num_layers() - 1;
    actor.weights[last].iter_mut().for_each(|w| *w *= 25.0);
    actor.biases.iter_mut().flatten().for_each(|x| *x = rng.random_range(-0.3..0.3));
    let b = batch(&mut p, 2048, &mut rng);
    compare("paper MLP, |mu| ~ 1", &p, &b, &cfg);

    let mut mcfg = PpoConfig { policy: "modular_attention".into(), ..Default::default() };
    mcfg.modular.controller = vec![256, 128];
    let mut p =
        Policy::build(902, skillmimic_env::ActionSpace::Box { dim: 156 }, &mcfg, &mut rng).unwrap();
    assert!(skillmimic_learn::ppo::fast::applies_to(&p));
    let b = batch(&mut p, 1024, &mut rng);
    compare("modular attention", &p, &b, &mcfg);
}

/// Why the forward stays float32: the log-ratio noise a bf16 forward of the actor would add.
#[test]
fn bf16_forward_would_add_log_ratio_noise() {
    if !skillmimic_nn::bf16::available() {
        eprintln!("SKIP: this CPU has no AVX512-BF16");
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
    let cfg = PpoConfig::default();
    let mut p = Policy::new(902, 156, &cfg, &mut rng);
    let n = 1024;
    for scale in [1.0f32, 25.0] {
        let actor = p.actor.as_mlp_mut().unwrap();
        let last = actor.num_layers() - 1;
        actor.weights[last].iter_mut().for_each(|w| *w *= scale);
        let b = batch(&mut p, n, &mut rng);
        let actor = p.actor.as_mlp().unwrap();
        let (mut h32, mut h16) = (Vec::new(), Vec::new());
        forward_keep(actor, &b.obs, n, &mut h32, Mm::f32(2));
        forward_keep(actor, &b.obs, n, &mut h16, Mm { threads: 2, bf16: true });
        let a = 156;
        let (mu32, mu16) = (h32.last().unwrap(), h16.last().unwrap());
        let d: Vec<f64> = (0..n)
            .map(|i| {
                neglogp_row(&b.act[i * a..(i + 1) * a], &mu16[i * a..(i + 1) * a], &p.log_std)
                    - neglogp_row(&b.act[i * a..(i + 1) * a], &mu32[i * a..(i + 1) * a], &p.log_std)
            })
            .collect();
        let mean = d.iter().sum::<f64>() / n as f64;
        let std = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        let rms_mu =
            (mu32.iter().map(|x| (*x as f64).powi(2)).sum::<f64>() / mu32.len() as f64).sqrt();
        println!(
            "action means of rms {rms_mu:.3}: a bf16 forward moves the log-ratio by std {std:.3} \
                (PPO clip range ±0.2)"
        );
        assert!(
            std > 0.02,
            "the reason for a float32 forward no longer holds: log-ratio noise {std:.4}"
        );
    }
}

/// A short training run with `ppo.precision = "bf16"`: finite, deterministic (same seed, same
/// curve), and the run reports the precision it used (float32 where the CPU lacks the
/// instructions).
#[test]
fn bf16_training_run_is_finite_deterministic_and_reported() {
    use skillmimic_learn::config::TrainConfig;
    use skillmimic_learn::trainer::Trainer;
    let run = |tag: &str| {
        let mut c = TrainConfig::preset("tiny").unwrap();
        c.env.motion = vec![skillmimic_core::shared_data::workspace_root().join("motions")];
        c.env.num_envs = 8;
        c.env.threads = 2;
        c.run.iterations = 3;
        c.ppo.precision = Precision::Bf16;
        c.run.out_dir = std::env::temp_dir().join(format!("sm-bf16-{}-{tag}", std::process::id()));
        let mut t = Trainer::new(c, None).unwrap();
        let mut curve = Vec::new();
        skillmimic_learn::runner::train_loop(&mut t, |s| {
            curve.push((s.mean_reward, s.actor_loss, s.critic_loss))
        })
        .unwrap();
        (curve, t.policy.clone(), t.update_precision())
    };
    let (ca, pa, prec) = run("a");
    let (cb, pb, _) = run("b");
    assert_eq!(prec, if skillmimic_nn::bf16::available() { "bf16" } else { "f32" });
    assert!(ca.iter().all(|(r, a, c)| r.is_finite() && a.is_finite() && c.is_finite()), "{ca:?}");
    assert_eq!(ca, cb, "same seed, same curve");
    assert_eq!(pa, pb, "same seed, same parameters");
}
