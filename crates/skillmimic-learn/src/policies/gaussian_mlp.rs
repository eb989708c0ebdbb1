//! `gaussian_mlp`: a ~ N(μ(s), σ²) per dimension with a fixed (non-trainable) log σ
//! (`Policy::log_std`, `ppo.log_std`), μ from the actor MLP. SkillMimic's policy.
//!
//! `neglogp(a) = ½ Σ ((a − μ)/σ)² + Σ ln σ + ½ A ln 2π`. Extra loss: the bounds loss
//! c_b · mean over samples of Σ_dims [max(μ − b, 0)² + max(−b − μ, 0)²] (rl_games).
//! Checkpoint tensor: `log_std` (A,). PyTorch mirror: `skillmimic_rs.policy.SkillMimicPolicy`.

use candle_core::Tensor;
use rand::RngCore;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use skillmimic_env::ActionSpace;

use super::family::{ExtraLoss, Head, PolicyFamily};
use crate::config::PpoConfig;

/// ½ ln 2π.
pub const HALF_LN_2PI: f64 = 0.918_938_533_204_672_8;

/// The fixed-σ Gaussian family.
pub struct GaussianMlp;

/// The action-independent part of the negative log-probability, Σ_j (ln σ_j + ½ ln 2π): the
/// loss (candle graph) and the fast update add it to ½ Σ z² (float64 sum in dimension order).
pub fn neglogp_offset(log_std: &[f32]) -> f64 {
    log_std.iter().map(|&l| l as f64 + HALF_LN_2PI).sum()
}

/// Negative log-probability of `a` under N(μ, diag(exp(log_std))²), summed per dimension as
/// ½ z² + ln σ + ½ ln 2π (the rollout's recorded values; the same density as
/// [`neglogp_offset`] + ½ Σ z², in another summation order that recorded runs keep).
pub fn neglogp_row(a: &[f32], mu: &[f32], log_std: &[f32]) -> f64 {
    let mut s = 0.0f64;
    for k in 0..a.len() {
        let ls = log_std[k] as f64;
        let z = (a[k] as f64 - mu[k] as f64) / ls.exp();
        s += 0.5 * z * z + ls + HALF_LN_2PI;
    }
    s
}

impl PolicyFamily for GaussianMlp {
    fn name(&self) -> &'static str {
        "gaussian_mlp"
    }
    fn supports(&self, space: &ActionSpace) -> bool {
        matches!(space, ActionSpace::Box { .. })
    }
    fn uses_log_std(&self) -> bool {
        true
    }
    fn actor_outputs(&self, space: &ActionSpace) -> usize {
        space.width()
    }

    /// a = μ + σ·ε, ε ~ N(0, 1) drawn row-major (environment, then dimension).
    fn sample(
        &self,
        head: Head<'_>,
        mu: &[f32],
        n: usize,
        rng: &mut dyn RngCore,
        actions: &mut [f32],
        neglogp: &mut [f32],
    ) {
        let a = head.outputs;
        for k in 0..n * a {
            let eps: f64 = StandardNormal.sample(rng);
            actions[k] = (mu[k] as f64 + (head.log_std[k % a] as f64).exp() * eps) as f32;
        }
        let log_std = head.log_std;
        neglogp[..n].par_iter_mut().enumerate().for_each(|(i, nl)| {
            *nl =
                neglogp_row(&actions[i * a..(i + 1) * a], &mu[i * a..(i + 1) * a], log_std) as f32;
        });
    }

    fn mode(&self, head: Head<'_>, mu: &[f32], n: usize, actions: &mut [f32]) {
        let a = head.outputs;
        actions[..n * a].copy_from_slice(&mu[..n * a]);
    }

    fn neglogp(
        &self,
        head: Head<'_>,
        mu: &Tensor,
        actions: &Tensor,
    ) -> candle_core::Result<Tensor> {
        let dev = mu.device();
        let inv_sigma: Vec<f32> = head.log_std.iter().map(|l| (-l).exp()).collect();
        let inv_sigma = Tensor::from_vec(inv_sigma, head.log_std.len(), dev)?;
        let konst = neglogp_offset(head.log_std);
        let z = (actions - mu)?.broadcast_mul(&inv_sigma)?;
        (z.sqr()?.sum(1)? * 0.5)?.affine(1.0, konst)
    }

    fn extra_loss(&self, mu: &Tensor, cfg: &PpoConfig) -> candle_core::Result<ExtraLoss> {
        let b = cfg.bound;
        let upper = mu.affine(1.0, -b)?.relu()?.sqr()?;
        let lower = mu.affine(-1.0, -b)?.relu()?.sqr()?;
        let bounds = (upper + lower)?.sum(1)?.mean_all()?;
        Ok(ExtraLoss { total: (&bounds * cfg.bounds_coef)?, bounds: Some(bounds), entropy: None })
    }
}
