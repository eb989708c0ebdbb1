//! Dedicated forward/backward of the PPO minibatch loss (the trainer's default path).
//!
//! Same losses as [`super::loss::loss_and_grads`] (candle autograd, kept as the reference), written
//! out by hand for the two ReLU MLPs (a modular attention actor: [`super::fast_modular`]):
//!
//! * forward: z_k = h_{k−1} W_kᵀ + b_k, h_k = max(z_k, 0) (no ReLU after the last layer); all
//!   activations are kept in buffers reused across minibatches and iterations;
//! * output gradients, per sample i and action dimension j (n = minibatch size):
//!   - PPO: r = exp(clamp(old − new, ±20)); ℓ = max(−A r, −A clip(r, 1±ε)); dℓ/dr = −A where the
//!     unclipped term is the maximum (and r is inside the ±20 clamp), else 0; with
//!     ∂new/∂μ_j = −(a_j − μ_j)/σ_j², the actor output gradient is dℓ/dr · (−r) · ∂new/∂μ_j / n;
//!   - bounds: c_b · (2 max(μ_j − b, 0) − 2 max(−b − μ_j, 0)) / n;
//!   - value: c_v · 2 (V − R) / n;
//! * backward: dW_k = g_kᵀ h_{k−1}, db_k = Σ_rows g_k, g_{k−1} = (g_k W_k) ⊙ [h_{k−1} > 0]; the
//!   gradient with respect to the (normalised) observations is never formed.
//!
//! Matrix products go through [`skillmimic_nn::mlp::gemm_raw`], split over the current rayon pool
//! by output blocks; with `ppo.precision = "bf16"` the backward products take bf16 inputs
//! ([`super::mlp_grad::Mm`]; the forward stays float32, see the loss function); reductions use
//! fixed row blocks combined in order, so results do not depend on scheduling.

use rayon::prelude::*;

use super::mlp_grad::{Mm, backward, forward_keep};
use crate::config::PpoConfig;

use super::batch::{LossStats, Minibatch};
use crate::policy::Policy;
use skillmimic_nn::policy_net::FastGradient;

/// Reusable buffers of the fast update.
#[derive(Default)]
pub struct UpdateWorkspace {
    actor_h: Vec<Vec<f32>>,
    critic_h: Vec<Vec<f32>>,
    g_a: Vec<f32>,
    g_b: Vec<f32>,
    scratch: Vec<f32>,
    /// Activations of a modular attention actor.
    modular: super::fast_modular::ModularCache,
    /// Parameter gradients in `Policy` order (actor layers, then critic layers; weight, bias).
    pub grads: Vec<Vec<f32>>,
}

/// Whether the fast path computes `policy`'s loss, by what the policy declares: a family with
/// the fixed-σ Gaussian head ([`PolicyFamily::uses_log_std`](crate::policies::PolicyFamily))
/// over an actor network with a hand-derived gradient
/// ([`skillmimic_nn::policy_net::PolicyNet::fast_gradient`]: the ReLU MLP, or the modular
/// attention network of at most [`super::fast_modular::MAX_PARTS`] parts). Everything else takes
/// the canonical candle loss.
pub fn applies_to(policy: &Policy) -> bool {
    policy.family.uses_log_std()
        && match policy.actor.fast_gradient() {
            Some(FastGradient::Mlp(_)) => true,
            Some(FastGradient::Modular(m)) => m.parts.len() <= super::fast_modular::MAX_PARTS,
            None => false,
        }
}

/// The declared hand-derived gradient of a policy the fast path applies to.
fn fast_gradient(policy: &Policy) -> FastGradient<'_> {
    policy.actor.fast_gradient().expect("checked by applies_to")
}

/// Losses and gradients of one minibatch (see the module docs); gradients land in `ws.grads`.
pub fn loss_and_grads_fast(
    policy: &Policy,
    mb: &Minibatch<'_>,
    cfg: &PpoConfig,
    ws: &mut UpdateWorkspace,
    threads: usize,
) -> LossStats {
    // `ppo.precision = "bf16"` applies to the backward products only: the forward recomputes the
    // log-probability the PPO ratio compares with the rollout's, and with σ = e^−2.9 over 156
    // action dimensions a bf16 forward would put noise of std ≈ 0.04 (at initialisation) to ≈ 0.3
    // (|μ| ≈ 1) into the log-ratio against a clip range of ±0.2 (measured: tests/bf16_update.rs)
    let mm = Mm::new(threads, cfg.precision);
    let fwd = Mm::f32(threads);
    let (n, a_dim) = (mb.n, policy.act_dim());
    match fast_gradient(policy) {
        FastGradient::Mlp(actor) => forward_keep(actor, mb.obs_n, n, &mut ws.actor_h, fwd),
        FastGradient::Modular(m) => ws.modular.forward(m, mb.obs_n, n, fwd),
    }
    forward_keep(&policy.critic, mb.obs_n, n, &mut ws.critic_h, fwd);
    let mu: &[f32] = match fast_gradient(policy) {
        FastGradient::Mlp(_) => ws.actor_h.last().expect("actor layers"),
        FastGradient::Modular(_) => &ws.modular.out,
    };
    let v = ws.critic_h.last().expect("critic layers");
    let inv_var: Vec<f64> = policy.log_std.iter().map(|&l| (-2.0 * l as f64).exp()).collect();
    let inv_sigma: Vec<f64> = policy.log_std.iter().map(|&l| (-(l as f64)).exp()).collect();
    let konst = crate::policies::gaussian_mlp::neglogp_offset(&policy.log_std);
    let (eps, b, cb, cv) = (cfg.clip, cfg.bound, cfg.bounds_coef, cfg.critic_coef);
    let inv_n = 1.0 / n as f64;

    // per-sample loss terms and output gradients (rows are independent)
    ws.g_a.resize(n * a_dim, 0.0);
    ws.g_b.resize(n, 0.0);
    let per_sample: Vec<[f64; 5]> = ws
        .g_a
        .par_chunks_mut(a_dim)
        .zip(ws.g_b.par_iter_mut())
        .enumerate()
        .map(|(i, (ga, gb))| {
            let (act, m) =
                (&mb.actions[i * a_dim..(i + 1) * a_dim], &mu[i * a_dim..(i + 1) * a_dim]);
            let mut sq = 0.0f64;
            let mut bound = 0.0f64;
            for j in 0..a_dim {
                let z = (act[j] as f64 - m[j] as f64) * inv_sigma[j];
                sq += z * z;
                let (up, lo) = ((m[j] as f64 - b).max(0.0), (-b - m[j] as f64).max(0.0));
                bound += up * up + lo * lo;
            }
            let new = 0.5 * sq + konst;
            let d = mb.old_neglogp[i] as f64 - new;
            let clamped = !(-20.0..=20.0).contains(&d);
            let r = d.clamp(-20.0, 20.0).exp();
            let adv = mb.advantages[i] as f64;
            let (s1, s2) = (-adv * r, -adv * r.clamp(1.0 - eps, 1.0 + eps));
            let loss = s1.max(s2);
            // gradient flows through the unclipped branch when it is the maximum
            let dldr = if s1 >= s2 && !clamped { -adv } else { 0.0 };
            for j in 0..a_dim {
                let mj = m[j] as f64;
                let dnew_dmu = -(act[j] as f64 - mj) * inv_var[j];
                let g_ppo = dldr * (-r) * dnew_dmu;
                let g_bound = cb * (2.0 * (mj - b).max(0.0) - 2.0 * (-b - mj).max(0.0));
                ga[j] = ((g_ppo + g_bound) * inv_n) as f32;
            }
            let diff = v[i] as f64 - mb.returns_n[i] as f64;
            *gb = (cv * 2.0 * diff * inv_n) as f32;
            let clipped = ((r - 1.0).abs() > eps) as u8 as f64;
            [loss, diff * diff, bound, clipped, new - mb.old_neglogp[i] as f64]
        })
        .collect();
    let mut sums = [0.0f64; 5];
    for s in &per_sample {
        for k in 0..5 {
            sums[k] += s[k];
        }
    }
    let stats = LossStats {
        actor: sums[0] * inv_n,
        critic: sums[1] * inv_n,
        bounds: sums[2] * inv_n,
        entropy: 0.0,
        total: sums[0] * inv_n + cv * sums[1] * inv_n + cb * sums[2] * inv_n,
        clip_frac: sums[3] * inv_n,
        approx_kl: sums[4] * inv_n,
    };

    // backward
    let na = policy.actor.params().len();
    let sizes: Vec<usize> = policy
        .actor
        .params()
        .iter()
        .chain(policy.critic.params().iter())
        .map(|p| p.len())
        .collect();
    ws.grads.resize_with(sizes.len(), Vec::new);
    for (g, &s) in ws.grads.iter_mut().zip(&sizes) {
        g.resize(s, 0.0);
    }
    let UpdateWorkspace { actor_h, critic_h, g_a, g_b, scratch, grads, modular } = ws;
    let (ga_grads, gc_grads) = grads.split_at_mut(na);
    match fast_gradient(policy) {
        FastGradient::Mlp(actor) => {
            backward(actor, mb.obs_n, n, actor_h, g_a, scratch, ga_grads, mm)
        }
        FastGradient::Modular(m) => modular.backward(m, g_a, n, ga_grads, mm),
    }
    backward(&policy.critic, mb.obs_n, n, critic_h, g_b, scratch, gc_grads, mm);
    stats
}
