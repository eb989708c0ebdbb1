//! PPO losses and their gradients (reference-facts §7.3), through candle's autograd.
//!
//! For a minibatch of normalised observations s, actions a, old negative log-probabilities,
//! normalised advantages Â and normalised returns R̂:
//! * ratio r = exp(clamp(neglogp_old − neglogp_new, ±20));
//! * actor loss = mean(max(−Â r, −Â clip(r, 1−ε, 1+ε)));
//! * critic loss = mean((R̂ − V(s))²) (unclipped, normalised value space);
//! * bounds loss = mean over samples of Σ_dims [max(μ − b, 0)² + min(μ + b, 0)²];
//! * total = actor + c_critic · critic + c_bounds · bounds.

use candle_core::{Device, Tensor};

use crate::config::PpoConfig;
use crate::mlp::Mlp;
use crate::policy::{HALF_LN_2PI, Policy};

/// One minibatch (row-major arrays, `n` samples).
#[derive(Clone, Copy, Debug)]
pub struct Minibatch<'a> {
    pub n: usize,
    /// `n × obs_dim`, already normalised.
    pub obs_n: &'a [f32],
    /// `n × act_dim` sampled actions.
    pub actions: &'a [f32],
    pub old_neglogp: &'a [f32],
    /// Normalised advantages.
    pub advantages: &'a [f32],
    /// Returns in normalised value space.
    pub returns_n: &'a [f32],
}

/// Loss values and diagnostics of one minibatch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LossStats {
    pub actor: f64,
    pub critic: f64,
    pub bounds: f64,
    pub total: f64,
    /// Fraction of samples whose ratio left [1−ε, 1+ε].
    pub clip_frac: f64,
    /// mean(neglogp_new − neglogp_old).
    pub approx_kl: f64,
}

/// Gradients in `Policy` parameter order: actor layers, then critic layers.
pub type Grads = Vec<Vec<f32>>;

fn err(e: candle_core::Error) -> String {
    format!("candle: {e}")
}

/// The candle device named by `ppo.device` ("cpu", or "cuda" with the `cuda` feature).
pub fn device(name: &str) -> Result<Device, String> {
    match name {
        "cpu" => Ok(Device::Cpu),
        #[cfg(feature = "cuda")]
        "cuda" => Device::new_cuda(0).map_err(err),
        other => Err(format!("device '{other}' is not available in this build")),
    }
}

/// Losses and gradients of one minibatch with candle autograd.
pub fn loss_and_grads(policy: &Policy, mb: &Minibatch<'_>, cfg: &PpoConfig) -> Result<(LossStats, Grads), String> {
    let dev = device(&cfg.device)?;
    let (n, d, a_dim) = (mb.n, policy.obs_dim(), policy.act_dim());
    let avars = policy.actor.candle_vars(&dev).map_err(err)?;
    let cvars = policy.critic.candle_vars(&dev).map_err(err)?;
    let run = || -> candle_core::Result<(LossStats, Grads)> {
        let x = Tensor::from_slice(mb.obs_n, (n, d), &dev)?;
        let mu = Mlp::candle_forward(&avars, &x)?;
        let v = Mlp::candle_forward(&cvars, &x)?.squeeze(1)?;
        let act = Tensor::from_slice(mb.actions, (n, a_dim), &dev)?;
        let inv_sigma: Vec<f32> = policy.log_std.iter().map(|l| (-l).exp()).collect();
        let inv_sigma = Tensor::from_vec(inv_sigma, a_dim, &dev)?;
        let konst: f64 = policy.log_std.iter().map(|&l| l as f64 + HALF_LN_2PI).sum();
        let z = (act - &mu)?.broadcast_mul(&inv_sigma)?;
        let neglogp = (z.sqr()?.sum(1)? * 0.5)?.affine(1.0, konst)?;
        let old = Tensor::from_slice(mb.old_neglogp, n, &dev)?;
        let ratio = (&old - &neglogp)?.clamp(-20f32, 20f32)?.exp()?;
        let adv = Tensor::from_slice(mb.advantages, n, &dev)?;
        let eps = cfg.clip as f32;
        let surr1 = (&adv * &ratio)?;
        let surr2 = (&adv * ratio.clamp(1.0 - eps, 1.0 + eps)?)?;
        let actor = surr1.neg()?.maximum(&surr2.neg()?)?.mean_all()?;
        let ret = Tensor::from_slice(mb.returns_n, n, &dev)?;
        let critic = (&v - &ret)?.sqr()?.mean_all()?;
        let b = cfg.bound;
        let upper = mu.affine(1.0, -b)?.relu()?.sqr()?;
        let lower = mu.affine(-1.0, -b)?.relu()?.sqr()?;
        let bounds = (upper + lower)?.sum(1)?.mean_all()?;
        let total = ((&actor + (&critic * cfg.critic_coef)?)? + (&bounds * cfg.bounds_coef)?)?;
        let store = total.backward()?;
        let mut grads = Vec::with_capacity(avars.len() + cvars.len());
        for var in avars.iter().chain(&cvars) {
            let g = match store.get(var.as_tensor()) {
                Some(g) => g.flatten_all()?.to_vec1::<f32>()?,
                None => vec![0.0; var.as_tensor().elem_count()],
            };
            grads.push(g);
        }
        let ratio_v: Vec<f32> = ratio.to_vec1()?;
        let clip_frac = ratio_v.iter().filter(|&&r| (r - 1.0).abs() > eps).count() as f64 / n as f64;
        let approx_kl = (&neglogp - &old)?.mean_all()?.to_scalar::<f32>()? as f64;
        let s = |t: &Tensor| t.to_scalar::<f32>().map(|x| x as f64);
        Ok((LossStats { actor: s(&actor)?, critic: s(&critic)?, bounds: s(&bounds)?, total: s(&total)?, clip_frac, approx_kl }, grads))
    };
    run().map_err(err)
}

/// A minibatch of raw (unnormalised) observations.
#[derive(Clone, Copy, Debug)]
pub struct RawMinibatch<'a> {
    pub n: usize,
    pub obs: &'a [f32],
    pub actions: &'a [f32],
    pub old_neglogp: &'a [f32],
    pub advantages: &'a [f32],
    pub returns_n: &'a [f32],
}

/// Buffers reused by [`update_minibatch`] across minibatches and iterations.
#[derive(Default)]
pub struct UpdateBuffers {
    pub obs_n: Vec<f32>,
    pub fast: crate::fast::UpdateWorkspace,
}

/// One optimisation step on a minibatch, as rl_games does it: update the observation normaliser
/// with the batch, normalise with the updated statistics, compute the losses and gradients
/// (`cfg.backend`), clip them if configured, and take an Adam step.
pub fn update_minibatch(
    policy: &mut Policy,
    adam: &mut crate::adam::Adam,
    mb: &RawMinibatch<'_>,
    buf: &mut UpdateBuffers,
    cfg: &PpoConfig,
    threads: usize,
) -> Result<LossStats, String> {
    if policy.normalize_input {
        policy.obs_norm.update(mb.obs);
    }
    buf.obs_n.resize(mb.obs.len(), 0.0);
    policy.normalize_obs_into(mb.obs, &mut buf.obs_n);
    let batch = Minibatch { n: mb.n, obs_n: &buf.obs_n, actions: mb.actions, old_neglogp: mb.old_neglogp, advantages: mb.advantages, returns_n: mb.returns_n };
    let (l, mut owned);
    let grads: &mut Vec<Vec<f32>> = match cfg.backend {
        crate::config::Backend::Fast => {
            l = crate::fast::loss_and_grads_fast(policy, &batch, cfg, &mut buf.fast, threads);
            &mut buf.fast.grads
        }
        crate::config::Backend::Candle => {
            (l, owned) = loss_and_grads(policy, &batch, cfg)?;
            &mut owned
        }
    };
    if cfg.truncate_grads {
        crate::adam::clip_global_norm(grads, cfg.grad_norm);
    }
    let mut params: Vec<&mut Vec<f32>> = policy.actor.params_mut();
    params.extend(policy.critic.params_mut());
    adam.update(&mut params, grads);
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mlp::Mlp;
    use crate::normalizer::RunningMeanStd;

    /// A 1-input, 1-action policy whose actor is the identity map (μ = s) and whose critic
    /// outputs 2·s: losses can be computed by hand.
    fn tiny_policy() -> Policy {
        Policy {
            actor: Mlp::from_parts(vec![1, 1], vec![vec![1.0]], vec![vec![0.0]]),
            critic: Mlp::from_parts(vec![1, 1], vec![vec![2.0]], vec![vec![0.0]]),
            log_std: vec![0.0],
            obs_norm: RunningMeanStd::new(1, 1e-5, 5.0),
            value_norm: RunningMeanStd::new(1, 1e-5, 5.0),
            normalize_input: true,
            normalize_value: true,
        }
    }

    #[test]
    fn loss_terms_match_hand_computed_values() {
        let p = tiny_policy();
        let cfg = PpoConfig { critic_coef: 5.0, bounds_coef: 10.0, bound: 1.0, clip: 0.2, ..Default::default() };
        // samples: s = 0.5 and s = 1.5 (μ = s), actions 0.5 and 1.0, σ = 1
        // neglogp_new = 0.5 (a-μ)^2 + 0.9189: [0.9189, 1.0439]
        // old neglogp chosen so that ratios are e^0.1 (inside) and e^-0.5 (clipped)
        let c = HALF_LN_2PI as f32;
        let old = [c + 0.1, 1.0439385 - 0.5];
        let mb = Minibatch {
            n: 2,
            obs_n: &[0.5, 1.5],
            actions: &[0.5, 1.0],
            old_neglogp: &old,
            advantages: &[1.0, -2.0],
            returns_n: &[0.0, 4.0],
        };
        let (l, g) = loss_and_grads(&p, &mb, &cfg).unwrap();
        let r1 = 0.1f64.exp(); // sample 2 ratio e^-0.5 = 0.607 is clipped at 0.8
        // sample 1: A = 1, r1 = 1.105 inside the clip range -> -A r1
        // sample 2: A = -2, r2 = 0.607 < 0.8 -> max(2 r2, 2 * 0.8) = 1.6
        let actor = (-r1 + 1.6) / 2.0;
        assert!((l.actor - actor).abs() < 1e-5, "{} vs {actor}", l.actor);
        // critic: V = 2 s = [1, 3], returns [0, 4] -> mean((1)^2, (1)^2) = 1
        assert!((l.critic - 1.0).abs() < 1e-6);
        // bounds: μ = [0.5, 1.5] -> (1.5 - 1)^2 = 0.25 for sample 2, mean 0.125
        assert!((l.bounds - 0.125).abs() < 1e-6);
        assert!((l.total - (actor + 5.0 * 1.0 + 10.0 * 0.125)).abs() < 1e-5);
        assert!((l.clip_frac - 0.5).abs() < 1e-12);
        // gradient of the critic weight: d/dw 5 * mean((w s - R)^2) = 5 * mean(2 (w s - R) s)
        //   = 5 * (2*(1)*0.5 + 2*(-1)*1.5)/2 = -5
        assert!((g[2][0] + 5.0).abs() < 1e-4, "critic weight grad {}", g[2][0]);
        // actor weight: only sample 1 (unclipped) and the bounds term depend on it:
        //   actor part: -A r1 * d(-neglogp)/dw = -(1) r1 * (a-μ) s / 2 = 0 (a = μ for sample 1)
        //   bounds part: 10 * d/dw mean((w s - 1)^2 [sample 2]) = 10 * 2 * 0.5 * 1.5 / 2 = 7.5
        assert!((g[0][0] - 7.5).abs() < 1e-4, "actor weight grad {}", g[0][0]);
    }
}
