//! The update part of an iteration: advantages (GAE), value normalisation, then `mini_epochs`
//! passes of PPO minibatch updates over the global batch; this rank gathers the members of each
//! global minibatch it holds and the gradients are reduced over the ranks.

use crate::adam::Adam;
use crate::collective::{self, Collective};
use crate::config::TrainConfig;
use crate::error::LearnError;
use crate::iteration_stats::IterationStats;
use crate::policy::Policy;
use crate::ppo::gae::gae;
use crate::ppo::{LossStats, RawMinibatch, update_minibatch};
use crate::shard::{Shard, epoch_order};
use crate::storage::{MinibatchBuffers, Rollout};
use crate::trainer::Extension;

/// Reusable buffers of the update.
#[derive(Default)]
pub struct Updater {
    mb: MinibatchBuffers,
    /// The global sample order of an epoch, and this rank's members of one minibatch.
    order: Vec<usize>,
    members: Vec<usize>,
    /// Scratch of the normaliser reductions.
    sums: Vec<f64>,
    threads: usize,
}

/// What the update works on.
pub struct UpdateInput<'a> {
    pub cfg: &'a TrainConfig,
    /// Completed iterations before this one (the minibatch order's seed).
    pub iteration: u64,
    pub shard: Shard,
    /// Environments of this rank, observation and action widths.
    pub dims: (usize, usize, usize),
}

impl Updater {
    pub fn new(threads: usize) -> Self {
        Self { threads, ..Self::default() }
    }

    /// Advantages, value normalisation and the minibatch updates (each followed by every
    /// extension's [`Extension::minibatch`] hook); the mean losses go into `stats`.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        input: &UpdateInput<'_>,
        r: &mut Rollout,
        policy: &mut Policy,
        adam: &mut Adam,
        comm: &mut dyn Collective,
        stats: &mut IterationStats,
        extensions: &mut [Box<dyn Extension>],
    ) -> Result<(), LearnError> {
        let cfg = &input.cfg.ppo;
        let (n, d, a) = input.dims;
        gae(
            &r.rewards,
            &r.values,
            &r.next_values,
            &r.dones,
            n,
            cfg.gamma as f32,
            cfg.lam as f32,
            &mut r.advantages,
            &mut r.returns,
        );
        if policy.normalize_value {
            // rl_games order: update with the values, then with the returns; the critic learns
            // the returns normalised with the final statistics
            collective::update_normalizer(&mut policy.value_norm, &r.values, comm, &mut self.sums)?;
            collective::update_normalizer(
                &mut policy.value_norm,
                &r.returns,
                comm,
                &mut self.sums,
            )?;
            for x in r.returns.iter_mut() {
                *x = policy.value_norm.normalize_scalar(*x as f64) as f32;
            }
        }
        if cfg.normalize_advantage {
            collective::normalize_advantages(&mut r.advantages, comm)?;
        }
        // the global batch and minibatch; this rank gathers the members it holds
        let batch = input.cfg.batch_size();
        let mbs = cfg.minibatch;
        let mb = &mut self.mb;
        mb.obs.resize(mbs * d, 0.0);
        mb.actions.resize(mbs * a, 0.0);
        mb.neglogp.resize(mbs, 0.0);
        mb.adv.resize(mbs, 0.0);
        mb.ret.resize(mbs, 0.0);
        let mut acc = LossStats::default();
        let mut count = 0.0;
        for epoch in 0..cfg.mini_epochs {
            epoch_order(input.cfg.run.seed, input.iteration, epoch, batch, &mut self.order);
            for global in self.order.chunks_exact(mbs) {
                self.members.clear();
                self.members.extend(global.iter().filter_map(|&g| input.shard.local_index(g)));
                let m = self.members.len();
                for (k, &s) in self.members.iter().enumerate() {
                    mb.obs[k * d..(k + 1) * d].copy_from_slice(&r.obs[s * d..(s + 1) * d]);
                    mb.actions[k * a..(k + 1) * a].copy_from_slice(&r.actions[s * a..(s + 1) * a]);
                    mb.neglogp[k] = r.neglogp[s];
                    mb.adv[k] = r.advantages[s];
                    mb.ret[k] = r.returns[s];
                }
                let raw = RawMinibatch {
                    n: m,
                    obs: &mb.obs[..m * d],
                    actions: &mb.actions[..m * a],
                    old_neglogp: &mb.neglogp[..m],
                    advantages: &mb.adv[..m],
                    returns_n: &mb.ret[..m],
                };
                let l = update_minibatch(
                    policy,
                    adam,
                    &raw,
                    mbs,
                    &mut mb.update,
                    cfg,
                    self.threads,
                    comm,
                )?;
                for e in extensions.iter_mut() {
                    e.minibatch(&self.members, comm)?;
                }
                acc.actor += l.actor;
                acc.critic += l.critic;
                acc.bounds += l.bounds;
                acc.clip_frac += l.clip_frac;
                acc.approx_kl += l.approx_kl;
                count += 1.0;
            }
        }
        stats.actor_loss = acc.actor / count;
        stats.critic_loss = acc.critic / count;
        stats.bounds_loss = acc.bounds / count;
        stats.clip_frac = acc.clip_frac / count;
        stats.approx_kl = acc.approx_kl / count;
        Ok(())
    }
}
