//! One PPO optimisation step on a minibatch: normaliser update, loss and gradients (canonical
//! candle loss or its fast specialisation), optional gradient clipping, Adam.

use super::batch::{LossStats, Minibatch, RawMinibatch};
use super::loss::loss_and_grads;
use crate::config::PpoConfig;
use crate::error::LearnError;
use crate::policy::Policy;

/// Buffers reused by [`update_minibatch`] across minibatches and iterations.
#[derive(Default)]
pub struct UpdateBuffers {
    pub obs_n: Vec<f32>,
    pub fast: super::fast::UpdateWorkspace,
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
) -> Result<LossStats, LearnError> {
    if policy.normalize_input {
        policy.obs_norm.update(mb.obs);
    }
    buf.obs_n.resize(mb.obs.len(), 0.0);
    policy.normalize_obs_into(mb.obs, &mut buf.obs_n);
    let batch = Minibatch { n: mb.n, obs_n: &buf.obs_n, actions: mb.actions, old_neglogp: mb.old_neglogp, advantages: mb.advantages, returns_n: mb.returns_n };
    let (l, mut owned);
    // the fast path is the Gaussian-MLP specialisation of the canonical loss
    let fast = cfg.backend == crate::config::Backend::Fast && super::fast::applies_to(policy);
    let grads: &mut Vec<Vec<f32>> = if fast {
        l = super::fast::loss_and_grads_fast(policy, &batch, cfg, &mut buf.fast, threads);
        &mut buf.fast.grads
    } else {
        (l, owned) = loss_and_grads(policy, &batch, cfg)?;
        &mut owned
    };
    if cfg.truncate_grads {
        crate::adam::clip_global_norm(grads, cfg.grad_norm);
    }
    let mut params: Vec<&mut Vec<f32>> = policy.actor.params_mut();
    params.extend(policy.critic.params_mut());
    adam.update(&mut params, grads);
    Ok(l)
}

