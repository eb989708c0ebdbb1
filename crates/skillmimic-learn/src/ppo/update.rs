//! One PPO optimisation step on a minibatch: normaliser update, loss and gradients (canonical
//! candle loss or its fast specialisation), the data-parallel gradient reduction, optional
//! gradient clipping, Adam.

use super::batch::{LossStats, Minibatch, RawMinibatch};
use super::loss::loss_and_grads;
use crate::collective::{self, Collective};
use crate::config::PpoConfig;
use crate::error::LearnError;
use crate::policy::Policy;

/// Buffers reused by [`update_minibatch`] across minibatches and iterations.
#[derive(Default)]
pub struct UpdateBuffers {
    pub obs_n: Vec<f32>,
    pub fast: super::fast::UpdateWorkspace,
    /// Data-parallel runs: normaliser sums, the flattened gradients + loss statistics, the
    /// reduced gradients, zero gradients for a rank that holds no sample of a minibatch.
    sums: Vec<f64>,
    flat: Vec<f32>,
    reduced: Vec<Vec<f32>>,
    zero: Vec<Vec<f32>>,
}

/// Loss statistics carried through the gradient all-reduce (weighted like the gradients).
const STATS: usize = 7;

fn stats_to(l: &LossStats, w: f64) -> [f32; STATS] {
    [l.actor, l.critic, l.bounds, l.entropy, l.total, l.clip_frac, l.approx_kl]
        .map(|x| (x * w) as f32)
}

fn stats_from(s: &[f32]) -> LossStats {
    let s: Vec<f64> = s.iter().map(|&x| x as f64).collect();
    LossStats {
        actor: s[0],
        critic: s[1],
        bounds: s[2],
        entropy: s[3],
        total: s[4],
        clip_frac: s[5],
        approx_kl: s[6],
    }
}

/// One optimisation step on a minibatch, as rl_games does it: update the observation normaliser
/// with the batch, normalise with the updated statistics, compute the losses and gradients
/// (`cfg.backend`), clip them if configured, and take an Adam step. Non-finite loss terms or
/// gradients stop before the step with [`LearnError::Diverged`] ([`crate::divergence`]).
///
/// Data-parallel: `mb` holds this rank's members of a minibatch of `global_n` samples (one
/// process: `mb.n == global_n`). The normaliser statistics are merged over all ranks, each
/// rank's mean-loss gradient is weighted by `mb.n / global_n` and the weighted gradients (and
/// loss statistics) are summed over the ranks before clipping, so every rank takes the step one
/// process would take on the whole minibatch. A rank may hold no member (`mb.n == 0`).
#[allow(clippy::too_many_arguments)]
pub fn update_minibatch(
    policy: &mut Policy,
    adam: &mut crate::adam::Adam,
    mb: &RawMinibatch<'_>,
    global_n: usize,
    buf: &mut UpdateBuffers,
    cfg: &PpoConfig,
    threads: usize,
    comm: &mut dyn Collective,
) -> Result<LossStats, LearnError> {
    if policy.normalize_input {
        // adaptation: the frozen tokenizers' inputs keep the statistics they were trained with
        let frozen: Vec<(usize, f64, f64)> = policy
            .actor
            .frozen_obs_columns()
            .iter()
            .map(|&c| (c, policy.obs_norm.mean[c], policy.obs_norm.var[c]))
            .collect();
        collective::update_normalizer(&mut policy.obs_norm, mb.obs, comm, &mut buf.sums)?;
        for (c, m, v) in frozen {
            policy.obs_norm.mean[c] = m;
            policy.obs_norm.var[c] = v;
        }
    }
    buf.obs_n.resize(mb.obs.len(), 0.0);
    policy.normalize_obs_into(mb.obs, &mut buf.obs_n);
    let batch = Minibatch {
        n: mb.n,
        obs_n: &buf.obs_n,
        actions: mb.actions,
        old_neglogp: mb.old_neglogp,
        advantages: mb.advantages,
        returns_n: mb.returns_n,
    };
    let mut l = LossStats::default();
    let mut owned: Vec<Vec<f32>>;
    // the fast path is the Gaussian-MLP specialisation of the canonical loss
    let fast = cfg.backend == crate::config::Backend::Fast && super::fast::applies_to(policy);
    let mut grads: &mut Vec<Vec<f32>> = if mb.n == 0 {
        if buf.zero.is_empty() {
            buf.zero = param_sizes(policy).iter().map(|&k| vec![0.0; k]).collect();
        }
        &mut buf.zero
    } else if fast {
        l = super::fast::loss_and_grads_fast(policy, &batch, cfg, &mut buf.fast, threads);
        &mut buf.fast.grads
    } else {
        (l, owned) = loss_and_grads(policy, &batch, cfg)?;
        &mut owned
    };
    if comm.world_size() > 1 {
        let w = mb.n as f64 / global_n as f64;
        let wf = w as f32;
        buf.flat.clear();
        for g in grads.iter() {
            buf.flat.extend(g.iter().map(|&x| x * wf));
        }
        buf.flat.extend_from_slice(&stats_to(&l, w));
        comm.all_reduce_f32(&mut buf.flat)?;
        if buf.reduced.len() != grads.len() {
            buf.reduced = grads.iter().map(|g| vec![0.0; g.len()]).collect();
        }
        let mut at = 0;
        for r in buf.reduced.iter_mut() {
            let k = r.len();
            r.copy_from_slice(&buf.flat[at..at + k]);
            at += k;
        }
        l = stats_from(&buf.flat[at..at + STATS]);
        grads = &mut buf.reduced;
    }
    // the norm before clipping: a non-finite one means the run diverged (crate::divergence)
    let norm = if cfg.truncate_grads {
        crate::adam::clip_global_norm(grads, cfg.grad_norm)
    } else {
        crate::adam::global_norm(grads)
    };
    crate::divergence::check_minibatch(&l, norm)?;
    let mut params: Vec<&mut Vec<f32>> = policy.actor.params_mut();
    params.extend(policy.critic.params_mut());
    adam.update(&mut params, grads);
    Ok(l)
}

/// Lengths of the trained parameter tensors in optimiser order (actor, then critic).
pub fn param_sizes(policy: &Policy) -> Vec<usize> {
    policy.actor.params().iter().chain(policy.critic.params().iter()).map(|p| p.len()).collect()
}
