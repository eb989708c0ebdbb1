//! The SkillMimic actor–critic: separate actor and critic MLPs over the normalised observation,
//! a fixed (non-trainable) log standard deviation, the observation and value normalisers.
//!
//! Gaussian policy: a ~ N(μ(s), σ²) per dimension; `neglogp(a) = ½ Σ ((a − μ)/σ)² + ½ A ln 2π +
//! Σ ln σ`. The critic predicts the value in normalised space; [`Policy::value_from_output`] maps
//! it back (clamp ±5, scale, shift).

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

use crate::config::PpoConfig;
use crate::mlp::{Mlp, Workspace};
use crate::normalizer::RunningMeanStd;

/// ½ ln 2π.
pub const HALF_LN_2PI: f64 = 0.918_938_533_204_672_8;

/// Actor, critic, σ and normalisers.
#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    pub actor: Mlp,
    pub critic: Mlp,
    /// Per-dimension log σ (fixed).
    pub log_std: Vec<f32>,
    pub obs_norm: RunningMeanStd,
    pub value_norm: RunningMeanStd,
    pub normalize_input: bool,
    pub normalize_value: bool,
}

/// Preallocated buffers of batched inference.
#[derive(Clone, Debug, Default)]
pub struct InferenceBuffers {
    pub obs_n: Vec<f32>,
    actor_ws: Workspace,
    critic_ws: Workspace,
}

impl Policy {
    /// A freshly initialised policy for `obs_dim` → `act_dim`.
    pub fn new<R: Rng>(obs_dim: usize, act_dim: usize, cfg: &PpoConfig, rng: &mut R) -> Self {
        let mut dims = vec![obs_dim];
        dims.extend(&cfg.hidden);
        let mut adims = dims.clone();
        adims.push(act_dim);
        let mut cdims = dims;
        cdims.push(1);
        Self {
            actor: Mlp::new(&adims, rng),
            critic: Mlp::new(&cdims, rng),
            log_std: vec![cfg.log_std as f32; act_dim],
            obs_norm: RunningMeanStd::new(obs_dim, cfg.norm_eps, cfg.norm_clip),
            value_norm: RunningMeanStd::new(1, cfg.norm_eps, cfg.norm_clip),
            normalize_input: cfg.normalize_input,
            normalize_value: cfg.normalize_value,
        }
    }

    pub fn obs_dim(&self) -> usize {
        self.actor.input_dim()
    }
    pub fn act_dim(&self) -> usize {
        self.actor.output_dim()
    }

    /// Normalised observation rows (or a copy when input normalisation is off).
    pub fn normalize_obs_into(&self, obs: &[f32], out: &mut [f32]) {
        if self.normalize_input {
            self.obs_norm.normalize_into(obs, out);
        } else {
            out.copy_from_slice(obs);
        }
    }

    /// Critic output (normalised space) → value.
    pub fn value_from_output(&self, y: f64) -> f64 {
        if self.normalize_value { self.value_norm.denormalize_scalar(y) } else { y }
    }

    /// Batched deterministic inference: action means `mu` (n × act) and values `values` (n).
    /// With two or more threads the actor and the critic run concurrently, each on half of them.
    pub fn infer(&self, obs: &[f32], n: usize, buf: &mut InferenceBuffers, mu: &mut [f32], values: &mut [f32], threads: usize) {
        let d = self.obs_dim();
        if buf.obs_n.len() < n * d {
            buf.obs_n.resize(n * d, 0.0);
        }
        let InferenceBuffers { obs_n, actor_ws, critic_ws } = buf;
        let obs_n = &mut obs_n[..n * d];
        self.normalize_obs_into(&obs[..n * d], obs_n);
        let obs_n: &[f32] = obs_n;
        let a = self.act_dim();
        let mut run_actor = |t: usize| mu[..n * a].copy_from_slice(self.actor.forward_into(obs_n, n, actor_ws, t));
        let mut run_critic = |t: usize| {
            let v = self.critic.forward_into(obs_n, n, critic_ws, t);
            for (o, &y) in values[..n].iter_mut().zip(v) {
                *o = self.value_from_output(y as f64) as f32;
            }
        };
        if threads >= 2 {
            let ta = threads / 2;
            rayon::join(|| run_actor(ta), || run_critic(threads - ta));
        } else {
            run_actor(threads);
            run_critic(threads);
        }
    }

    /// Values only (for bootstrapping on next observations).
    pub fn infer_values(&self, obs: &[f32], n: usize, buf: &mut InferenceBuffers, values: &mut [f32], threads: usize) {
        let d = self.obs_dim();
        if buf.obs_n.len() < n * d {
            buf.obs_n.resize(n * d, 0.0);
        }
        let obs_n = &mut buf.obs_n[..n * d];
        self.normalize_obs_into(&obs[..n * d], obs_n);
        let v = self.critic.forward_into(obs_n, n, &mut buf.critic_ws, threads);
        for (o, &y) in values[..n].iter_mut().zip(v) {
            *o = self.value_from_output(y as f64) as f32;
        }
    }

    /// Sample actions a = μ + σ·ε for `n` rows and their negative log-probabilities.
    pub fn sample<R: Rng>(&self, mu: &[f32], n: usize, rng: &mut R, actions: &mut [f32], neglogp: &mut [f32]) {
        let a = self.act_dim();
        for k in 0..n * a {
            let eps: f64 = StandardNormal.sample(rng);
            actions[k] = (mu[k] as f64 + (self.log_std[k % a] as f64).exp() * eps) as f32;
        }
        let log_std = &self.log_std;
        neglogp[..n].par_iter_mut().enumerate().for_each(|(i, nl)| {
            *nl = neglogp_row(&actions[i * a..(i + 1) * a], &mu[i * a..(i + 1) * a], log_std) as f32;
        });
    }
}

/// Negative log-probability of `a` under N(μ, diag(exp(log_std))²).
pub fn neglogp_row(a: &[f32], mu: &[f32], log_std: &[f32]) -> f64 {
    let mut s = 0.0f64;
    for k in 0..a.len() {
        let ls = log_std[k] as f64;
        let z = (a[k] as f64 - mu[k] as f64) / ls.exp();
        s += 0.5 * z * z + ls + HALF_LN_2PI;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neglogp_matches_the_gaussian_density() {
        // one dimension, σ = e^-1: a - μ = σ -> z = 1 -> 0.5 - 1 + 0.9189...
        let v = neglogp_row(&[1.0 + (-1.0f32).exp()], &[1.0], &[-1.0]);
        assert!((v - (0.5 - 1.0 + HALF_LN_2PI)).abs() < 1e-6);
        assert!((HALF_LN_2PI - 0.5 * (2.0 * std::f64::consts::PI).ln()).abs() < 1e-15);
    }
}
