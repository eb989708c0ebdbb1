//! The canonical PPO loss (reference-facts §7.3) over any policy family, with candle autograd.
//!
//! For a minibatch of normalised observations s, actions a, old negative log-probabilities,
//! normalised advantages Â and normalised returns R̂, with the family's neglogp_new(a | actor(s)):
//! * ratio r = exp(clamp(neglogp_old − neglogp_new, ±20));
//! * actor loss = mean(max(−Â r, −Â clip(r, 1−ε, 1+ε)));
//! * critic loss = mean((R̂ − V(s))²) (unclipped, normalised value space);
//! * family extra loss (Gaussian: c_bounds · bounds loss; categorical: −c_e · entropy);
//! * total = actor + c_critic · critic + extra.
//!
//! `ppo::fast` is a specialisation of this loss for `gaussian_mlp`, tested equal to it.

use candle_core::{Device, Tensor};
use skillmimic_nn::mlp::Mlp;

use super::batch::{LossStats, Minibatch};
use crate::config::PpoConfig;
use crate::error::LearnError;
#[cfg(test)]
use crate::policy::HALF_LN_2PI;
use crate::policy::Policy;

/// Gradients in `Policy` parameter order: actor layers, then critic layers.
pub type Grads = Vec<Vec<f32>>;

/// The candle device named by `ppo.device` ("cpu", or "cuda" with the `cuda` feature).
pub fn device(name: &str) -> Result<Device, LearnError> {
    match name {
        "cpu" => Ok(Device::Cpu),
        #[cfg(feature = "cuda")]
        "cuda" => Ok(Device::new_cuda(0)?),
        other => Err(LearnError::Device(other.to_string())),
    }
}

/// Losses and gradients of one minibatch with candle autograd.
pub fn loss_and_grads(
    policy: &Policy,
    mb: &Minibatch<'_>,
    cfg: &PpoConfig,
) -> Result<(LossStats, Grads), LearnError> {
    let dev = device(&cfg.device)?;
    let (n, d, a_dim) = (mb.n, policy.obs_dim(), policy.act_dim());
    let avars = policy.actor.candle_vars(&dev)?;
    let cvars = policy.critic.candle_vars(&dev)?;
    let family = policy.family;
    let run = || -> candle_core::Result<(LossStats, Grads)> {
        let x = Tensor::from_slice(mb.obs_n, (n, d), &dev)?;
        let out = policy.actor.candle_forward(&avars, &x)?;
        let v = Mlp::candle_forward(&cvars, &x)?.squeeze(1)?;
        let act = Tensor::from_slice(mb.actions, (n, a_dim), &dev)?;
        let neglogp = family.neglogp(policy.head(), &out, &act)?;
        let old = Tensor::from_slice(mb.old_neglogp, n, &dev)?;
        let ratio = (&old - &neglogp)?.clamp(-20f32, 20f32)?.exp()?;
        let adv = Tensor::from_slice(mb.advantages, n, &dev)?;
        let eps = cfg.clip as f32;
        let surr1 = (&adv * &ratio)?;
        let surr2 = (&adv * ratio.clamp(1.0 - eps, 1.0 + eps)?)?;
        let actor = surr1.neg()?.maximum(&surr2.neg()?)?.mean_all()?;
        let ret = Tensor::from_slice(mb.returns_n, n, &dev)?;
        let critic = (&v - &ret)?.sqr()?.mean_all()?;
        let extra = family.extra_loss(&out, cfg)?;
        let total = ((&actor + (&critic * cfg.critic_coef)?)? + &extra.total)?;
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
        let clip_frac =
            ratio_v.iter().filter(|&&r| (r - 1.0).abs() > eps).count() as f64 / n as f64;
        let approx_kl = (&neglogp - &old)?.mean_all()?.to_scalar::<f32>()? as f64;
        let s = |t: &Tensor| t.to_scalar::<f32>().map(|x| x as f64);
        let opt = |t: &Option<Tensor>| t.as_ref().map_or(Ok(0.0), s);
        let stats = LossStats {
            actor: s(&actor)?,
            critic: s(&critic)?,
            bounds: opt(&extra.bounds)?,
            entropy: opt(&extra.entropy)?,
            total: s(&total)?,
            clip_frac,
            approx_kl,
        };
        Ok((stats, grads))
    };
    Ok(run()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use skillmimic_nn::normalizer::RunningMeanStd;

    /// A 1-input, 1-action policy whose actor is the identity map (μ = s) and whose critic
    /// outputs 2·s: losses can be computed by hand.
    fn tiny_policy() -> Policy {
        Policy {
            family: &crate::policies::gaussian_mlp::GaussianMlp,
            space: skillmimic_env::ActionSpace::Box { dim: 1 },
            actor: crate::actor::ActorNet::from(Mlp::from_parts(
                vec![1, 1],
                vec![vec![1.0]],
                vec![vec![0.0]],
            )),
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
        let cfg = PpoConfig {
            critic_coef: 5.0,
            bounds_coef: 10.0,
            bound: 1.0,
            clip: 0.2,
            ..Default::default()
        };
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
