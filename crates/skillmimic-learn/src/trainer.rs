//! The PPO learner on any registered task (`env.task`, built through `skillmimic_env::registry`)
//! with any compatible policy family (`ppo.policy`): rollouts into [`crate::storage`] and the PPO
//! update. The loop around it (logs, checkpoints, end-of-run work) is [`crate::runner`].
//!
//! One iteration = a rollout of `horizon` steps in all environments + `mini_epochs` passes of
//! minibatch updates. The rollout follows the original learner's loop: finished environments are
//! reset at the top of the next step, so the observation returned with `done` is the true terminal
//! observation and the critic bootstraps on it (times 1 − terminated; time-outs bootstrap).
//! Inference writes into preallocated buffers; the value of a step's next observation is reused
//! as the value of the following step whenever the environment was not reset in between.
//!
//! With the SkillMimic-V2 history encoder on, a fresh run copies the encoder file into
//! `run.out_dir/history_encoder.safetensors` and its saved configuration points there, so the
//! run's checkpoints stay usable when the original file moves.
//!
//! Everything is seeded from `run.seed` (network initialisation, action noise, minibatch
//! shuffling) and `env.seed` (episode starts; when unset it is derived as `run.seed` and written
//! into the effective config saved with the run), so two runs with the same seed and
//! thread counts produce the same checkpoints bit for bit. A resumed run continues from the
//! checkpoint's policy, normalisers and Adam state with freshly reset environments.
//!
//! `ppo.amp.enabled` adds the motion prior's style reward and discriminator
//! ([`crate::amp_reward`]).
//!
//! Data-parallel ([`Trainer::with_collective`], [`crate::collective`]): `env.num_envs` is the total
//! over all ranks; each rank steps its share ([`crate::shard`]): global environment g draws its
//! episode starts from the stream `env.seed + g`, as in one process
//! (`skillmimic_env::vec_env::env_streams`), so the ranks together plan exactly the episodes of a
//! single process; the action noise has a stream per rank (rank 0's is a single process's, rank r >
//! 0 mixes r into the seed); every rank computes the same minibatch order from `run.seed` and the
//! iteration, and gradients and normaliser statistics are reduced so every rank takes the update
//! one process would take on the same rollout. Only rank 0 reads a checkpoint to resume from; the
//! state reaches the others by broadcast, so the world size may differ from the saving run's.

use std::path::Path;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skillmimic_env::{Env, registry};

use crate::adam::Adam;
use crate::checkpoint::{self, Progress};
use crate::collective::{self, Collective, Single, Timed, mix_seed};
use crate::config::TrainConfig;
use crate::error::{LearnError, bad_checkpoint, io};
use crate::policy::{InferenceBuffers, Policy};
use crate::ppo::gae::gae;
use crate::ppo::{LossStats, RawMinibatch, update_minibatch};
use crate::shard::{Shard, epoch_order};
use crate::storage::{MinibatchBuffers, Rollout};

pub use crate::iteration_stats::IterationStats;

/// PPO trainer.
pub struct Trainer {
    pub cfg: TrainConfig,
    pub env: Box<dyn Env>,
    pub policy: Policy,
    pub adam: Adam,
    pub progress: Progress,
    rng: ChaCha8Rng,
    roll: Rollout,
    mb: MinibatchBuffers,
    infer: InferenceBuffers,
    mu: Vec<f32>,
    step_values: Vec<f32>,
    done_rows: Vec<usize>,
    gather: Vec<f32>,
    gather_values: Vec<f32>,
    ep_return: Vec<f64>,
    ep_len: Vec<u64>,
    term_sums: Vec<f64>,
    threads: usize,
    config_toml: String,
    comm: Timed,
    /// This rank's environments and samples.
    pub shard: Shard,
    order: Vec<usize>,
    members: Vec<usize>,
    sums: Vec<f64>,
    /// The motion prior (`ppo.amp.enabled`).
    pub amp: Option<crate::amp_reward::AmpReward>,
    /// The checkpoint this run resumed from (rank 0; the last good checkpoint until it saves one).
    pub resumed_from: Option<std::path::PathBuf>,
    step_rewards: Vec<f32>,
    step_done: Vec<u8>,
}

impl Trainer {
    /// A new trainer (fresh policy), or one resumed from `resume` (a training checkpoint).
    /// Precision of the update's backward products in this run (`"bf16"` or `"f32"`, see
    /// [`crate::config::Precision`]).
    pub fn update_precision(&self) -> &'static str {
        let bf16 = self.cfg.ppo.backend == crate::config::Backend::Fast
            && crate::ppo::fast::applies_to(&self.policy)
            && crate::ppo::mlp_grad::Mm::new(1, self.cfg.ppo.precision).bf16;
        if bf16 { "bf16" } else { "f32" }
    }

    pub fn new(cfg: TrainConfig, resume: Option<&Path>) -> Result<Self, LearnError> {
        Self::with_collective(cfg, resume, Box::new(Single))
    }

    /// One rank of a data-parallel run over `comm` (see the module documentation); with
    /// [`Single`] the same as [`Trainer::new`]. Only rank 0 reads `resume`; the other ranks take
    /// the state from rank 0.
    pub fn with_collective(
        mut cfg: TrainConfig,
        resume: Option<&Path>,
        comm: Box<dyn Collective>,
    ) -> Result<Self, LearnError> {
        let mut comm = Timed::new(comm);
        cfg.validate()?;
        let shard = Shard::new(cfg.env.num_envs, comm.rank(), comm.world_size())?;
        let rank = shard.rank;
        let batch = cfg.batch_size();
        if !batch.is_multiple_of(cfg.ppo.minibatch) {
            return Err(LearnError::Config(format!(
                "config field 'ppo.minibatch': {} must divide the samples per iteration ({batch})",
                cfg.ppo.minibatch
            )));
        }
        if cfg.ppo.precision == crate::config::Precision::Bf16 {
            if !skillmimic_nn::bf16::available() {
                tracing::warn!(
                    "ppo.precision = \"bf16\": this CPU has no AVX512-BF16; the update runs in float32"
                );
            } else if cfg.ppo.backend != crate::config::Backend::Fast {
                tracing::warn!(
                    "ppo.precision = \"bf16\" applies to the fast backend only; the candle backend runs in float32"
                );
            }
        }
        // derived value, made explicit in the effective config: episode starts follow the run seed
        // unless `env.seed` is set
        let start_seed = cfg.env.start_seed(cfg.run.seed);
        cfg.env.seed = Some(start_seed);
        let mut ecfg = cfg.env.clone();
        if cfg.env.v2.history.enabled && resume.is_none() {
            // the frozen encoder defines part of the policy's input: keep a copy with the run
            // (written by rank 0; the others read the original)
            let src = cfg.env.v2.history.encoder.clone();
            let dst = cfg.run.out_dir.join("history_encoder.safetensors");
            if src != dst {
                if rank == 0 {
                    std::fs::create_dir_all(&cfg.run.out_dir).map_err(io(&cfg.run.out_dir))?;
                    let bytes = std::fs::read(&src).map_err(io(&src))?;
                    skillmimic_core::tensorfile::write_bytes_atomic(&dst, &bytes)
                        .map_err(io(&dst))?;
                }
                cfg.env.v2.history.encoder = dst;
            }
        }
        if rank == 0 {
            ecfg.v2.history.encoder = cfg.env.v2.history.encoder.clone();
        }
        ecfg.num_envs = shard.local;
        // global environment g (= shard.offset + local index) uses the episode stream seed + g
        ecfg.seed = Some(start_seed.wrapping_add(shard.offset as u64));
        let mut env = registry::make(&ecfg)?;
        let (obs_dim, act_dim) = (env.obs_dim(), env.act_dim());
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.run.seed);
        // a token policy's observation groups come from the task unless configured
        let ppo = crate::policies::token_transformer::with_task_groups(&cfg.ppo, env.spec());
        let fresh = |rng: &mut ChaCha8Rng| -> Result<(Policy, Adam), LearnError> {
            let mut policy = Policy::build(obs_dim, env.spec().action_space, &ppo, rng)?;
            if !ppo.token.adapt_from.as_os_str().is_empty() {
                crate::adapt::adapt(
                    &mut policy,
                    &ppo.token.adapt_from,
                    ppo.token.gate_adapters,
                    rng,
                )?;
            }
            let adam =
                Adam::new(&crate::ppo::update::param_sizes(&policy), cfg.ppo.lr, cfg.ppo.adam_eps);
            Ok((policy, adam))
        };
        let (mut policy, mut adam, mut progress) = match resume.filter(|_| rank == 0) {
            None => {
                let (p, a) = fresh(&mut rng)?;
                (p, a, Progress::default())
            }
            Some(path) => {
                let c = checkpoint::load(path, Some((obs_dim, act_dim)))?;
                let mut adam = c.adam.ok_or_else(|| {
                    bad_checkpoint(path)(format!("{}: a policy-only (exported) checkpoint cannot resume training; use a training checkpoint", path.display()))
                })?;
                let hidden = &c.policy.critic.dims[1..c.policy.critic.dims.len() - 1];
                if hidden != cfg.ppo.hidden.as_slice() {
                    return Err(bad_checkpoint(path)(format!(
                        "{}: network hidden sizes {hidden:?} differ from the config's ppo.hidden {:?}",
                        path.display(),
                        cfg.ppo.hidden
                    )));
                }
                if c.policy.family.name() != cfg.ppo.policy {
                    return Err(bad_checkpoint(path)(format!(
                        "{}: policy family '{}' differs from the config's ppo.policy '{}'",
                        path.display(),
                        c.policy.family.name(),
                        cfg.ppo.policy
                    )));
                }
                adam.lr = cfg.ppo.lr;
                (c.policy, adam, c.progress)
            }
        };
        if comm.world_size() > 1 {
            crate::sync::check_agreement(&cfg, &policy, &adam, &mut comm)?;
            crate::sync::broadcast_state(&mut policy, &mut adam, &mut progress, &mut comm)?;
            adam.lr = cfg.ppo.lr;
        }
        if progress.iteration > 0 {
            // resumed: continue with streams of random numbers that differ from the first run's
            let it = progress.iteration;
            let mut noise = cfg.run.seed ^ it.wrapping_mul(0x9e37_79b9_7f4a_7c15);
            let starts = cfg
                .run
                .seed
                .wrapping_add(it)
                .wrapping_mul(0x9e37_79b9)
                .wrapping_add(shard.offset as u64);
            if rank > 0 {
                noise = mix_seed(noise, rank as u64);
            }
            rng = ChaCha8Rng::seed_from_u64(noise);
            env.reset_all(Some(starts));
        } else if rank > 0 {
            rng = ChaCha8Rng::seed_from_u64(mix_seed(cfg.run.seed, rank as u64));
        }
        comm.take_seconds();
        // one discriminator per task of a multi-task environment
        let amp = crate::amp_reward::AmpReward::for_run(
            &cfg,
            obs_dim,
            env.num_envs(),
            &env.task_rows(),
            &mut comm,
            resume,
        )?;
        let threads = if cfg.run.learner_threads == 0 {
            rayon::current_num_threads()
        } else {
            cfg.run.learner_threads
        };
        let n = env.num_envs();
        let outputs = policy.actor_outputs();
        let config_toml = cfg.to_toml();
        let term_sums = vec![0.0; env.spec().term_names.len()];
        Ok(Self {
            cfg,
            env,
            term_sums,
            policy,
            adam,
            progress,
            rng,
            roll: Rollout::default(),
            mb: MinibatchBuffers::default(),
            infer: InferenceBuffers::default(),
            mu: vec![0.0; n * outputs],
            step_values: vec![0.0; n],
            done_rows: Vec::with_capacity(n),
            gather: vec![0.0; n * obs_dim],
            gather_values: vec![0.0; n],
            ep_return: vec![0.0; n],
            ep_len: vec![0; n],
            threads,
            config_toml,
            comm,
            shard,
            order: Vec::new(),
            members: Vec::new(),
            sums: Vec::new(),
            amp,
            resumed_from: resume.filter(|_| rank == 0).map(Path::to_path_buf),
            step_rewards: vec![0.0; n],
            step_done: vec![0; n],
        })
    }

    /// Rebuild the environment from `cfg.env` after it changed (one process; fresh episodes),
    /// re-derive the effective configuration saved with checkpoints and restart the per-episode
    /// bookkeeping.
    pub fn rebuild_env(&mut self) -> Result<(), LearnError> {
        let mut e = self.cfg.env.clone();
        e.num_envs = self.shard.local;
        self.env = registry::make(&e)?;
        self.config_toml = self.cfg.to_toml();
        self.ep_return.fill(0.0);
        self.ep_len.fill(0);
        if let Some(a) = &mut self.amp {
            a.restart();
        }
        Ok(())
    }

    /// The effective configuration as TOML.
    pub fn config_toml(&self) -> &str {
        &self.config_toml
    }

    fn alloc_rollout(&mut self) {
        let (h, n, d, a) =
            (self.cfg.ppo.horizon, self.env.num_envs(), self.env.obs_dim(), self.env.act_dim());
        self.roll.ensure(h, n, d, a);
    }

    /// Collect one rollout; returns rollout statistics.
    fn rollout(&mut self, stats: &mut IterationStats) -> Result<(), LearnError> {
        self.alloc_rollout();
        let (h, n, d, a) =
            (self.cfg.ppo.horizon, self.env.num_envs(), self.env.obs_dim(), self.env.act_dim());
        let nt = self.term_sums.len();
        self.term_sums.fill(0.0);
        let (mut ep_count, mut ep_len_sum, mut ep_ret_sum, mut early, mut unstable) =
            (0usize, 0u64, 0.0f64, 0usize, 0usize);
        let mut pending = false; // next_values[t-1] still to fill from values[t]
        let mut amp_sums = [0.0f64; 2];
        let mut env_time = std::time::Duration::ZERO;
        for t in 0..h {
            let te = Instant::now();
            self.env.reset_done();
            env_time += te.elapsed();
            let rows = t * n..(t + 1) * n;
            self.roll.obs[t * n * d..(t + 1) * n * d].copy_from_slice(&self.env.buffers().obs);
            let obs = &self.roll.obs[t * n * d..(t + 1) * n * d];
            if let Some(amp) = &mut self.amp {
                amp.begin_step(obs, d);
            }
            self.policy.infer(
                obs,
                n,
                &mut self.infer,
                &mut self.mu,
                &mut self.step_values,
                self.threads,
            );
            self.roll.values[rows.clone()].copy_from_slice(&self.step_values);
            if pending {
                // environments not reset since the last step: their next value is this value
                let prev = (t - 1) * n;
                for i in 0..n {
                    if self.roll.dones[prev + i] == 0 {
                        self.roll.next_values[prev + i] = self.step_values[i];
                    }
                }
            }
            self.policy.sample(
                &self.mu,
                n,
                &mut self.rng,
                &mut self.roll.actions[t * n * a..(t + 1) * n * a],
                &mut self.roll.neglogp[rows.clone()],
            );
            let te = Instant::now();
            self.env.step(&self.roll.actions[t * n * a..(t + 1) * n * a])?;
            env_time += te.elapsed();
            let b = self.env.buffers();
            self.step_rewards.copy_from_slice(&b.reward);
            if let Some(amp) = &mut self.amp {
                for (o, (&te, &tr)) in
                    self.step_done.iter_mut().zip(b.terminated.iter().zip(&b.truncated))
                {
                    *o = u8::from(te != 0 || tr != 0);
                }
                let (st, ss) = amp.after_step(&b.obs, d, &self.step_done, &mut self.step_rewards);
                amp_sums[0] += st;
                amp_sums[1] += ss;
            }
            self.done_rows.clear();
            for i in 0..n {
                let r = self.step_rewards[i];
                self.roll.rewards[t * n + i] = r;
                let done = b.terminated[i] != 0 || b.truncated[i] != 0;
                self.roll.dones[t * n + i] = u8::from(done);
                self.ep_return[i] += r as f64;
                self.ep_len[i] += 1;
                unstable += usize::from(b.unstable[i] != 0);
                for (s, &v) in self.term_sums.iter_mut().zip(&b.terms[i * nt..(i + 1) * nt]) {
                    *s += v as f64;
                }
                if done || t + 1 == h {
                    self.done_rows.push(i);
                }
                if done {
                    ep_count += 1;
                    ep_len_sum += self.ep_len[i];
                    ep_ret_sum += self.ep_return[i];
                    early += usize::from(b.terminated[i] != 0);
                    self.ep_return[i] = 0.0;
                    self.ep_len[i] = 0;
                }
            }
            // values of the observations after the step for finished environments (terminal
            // observations) and, at the last step, for everyone
            let m = self.done_rows.len();
            for (k, &i) in self.done_rows.iter().enumerate() {
                self.gather[k * d..(k + 1) * d].copy_from_slice(&b.obs[i * d..(i + 1) * d]);
            }
            if m > 0 {
                self.policy.infer_values(
                    &self.gather[..m * d],
                    m,
                    &mut self.infer,
                    &mut self.gather_values,
                    self.threads,
                );
            }
            for (k, &i) in self.done_rows.iter().enumerate() {
                let keep = if b.terminated[i] != 0 { 0.0 } else { 1.0 };
                self.roll.next_values[t * n + i] = keep * self.gather_values[k];
            }
            pending = t + 1 < h;
        }
        stats.env_s = env_time.as_secs_f64();
        // sums over all ranks' environments: [steps, rewards, values, episodes, lengths,
        // returns, early endings, unstable steps, reward terms…]
        let mut s = vec![
            (h * n) as f64,
            self.roll.rewards.iter().map(|&r| r as f64).sum::<f64>(),
            self.roll.values.iter().map(|&v| v as f64).sum::<f64>(),
            ep_count as f64,
            ep_len_sum as f64,
            ep_ret_sum,
            early as f64,
            unstable as f64,
        ];
        s.extend_from_slice(&self.term_sums);
        s.extend_from_slice(&amp_sums);
        self.comm.all_reduce_f64(&mut s)?;
        let steps = s[0];
        stats.mean_reward = s[1] / steps;
        stats.reward_terms = self
            .env
            .spec()
            .term_names
            .iter()
            .zip(&s[8..])
            .map(|(nm, v)| (nm.to_string(), v / steps))
            .collect();
        if self.amp.is_some() {
            // the task reward before mixing and the style reward (the mixed one is `mean_reward`)
            let at = s.len() - 2;
            stats.reward_terms.extend([
                ("task".to_string(), s[at] / steps),
                ("style".to_string(), s[at + 1] / steps),
            ]);
        }
        stats.episodes = s[3] as usize;
        stats.unstable_steps = s[7] as u64;
        if s[3] > 0.0 {
            stats.episode_length = s[4] / s[3];
            stats.episode_return = s[5] / s[3];
            stats.early_terminations = s[6] / s[3];
        }
        stats.value_mean = s[2] / steps;
        Ok(())
    }

    /// Advantages, value normalisation and the minibatch updates.
    fn update(&mut self, stats: &mut IterationStats) -> Result<(), LearnError> {
        let cfg = &self.cfg.ppo;
        let (n, d, a) = (self.env.num_envs(), self.env.obs_dim(), self.env.act_dim());
        let comm: &mut dyn Collective = &mut self.comm;
        let r = &mut self.roll;
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
        if self.policy.normalize_value {
            // rl_games order: update with the values, then with the returns; the critic learns
            // the returns normalised with the final statistics
            collective::update_normalizer(
                &mut self.policy.value_norm,
                &r.values,
                comm,
                &mut self.sums,
            )?;
            collective::update_normalizer(
                &mut self.policy.value_norm,
                &r.returns,
                comm,
                &mut self.sums,
            )?;
            for x in r.returns.iter_mut() {
                *x = self.policy.value_norm.normalize_scalar(*x as f64) as f32;
            }
        }
        if cfg.normalize_advantage {
            collective::normalize_advantages(&mut r.advantages, comm)?;
        }
        // the global batch and minibatch; this rank gathers the members it holds
        let batch = self.cfg.batch_size();
        let mbs = cfg.minibatch;
        let mb = &mut self.mb;
        mb.obs.resize(mbs * d, 0.0);
        mb.actions.resize(mbs * a, 0.0);
        mb.neglogp.resize(mbs, 0.0);
        mb.adv.resize(mbs, 0.0);
        mb.ret.resize(mbs, 0.0);
        let mut acc = LossStats::default();
        let mut count = 0.0;
        let shard = self.shard;
        for epoch in 0..cfg.mini_epochs {
            epoch_order(self.cfg.run.seed, self.progress.iteration, epoch, batch, &mut self.order);
            for global in self.order.chunks_exact(mbs) {
                self.members.clear();
                self.members.extend(global.iter().filter_map(|&g| shard.local_index(g)));
                let chunk = &self.members;
                let m = chunk.len();
                for (k, &s) in chunk.iter().enumerate() {
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
                    &mut self.policy,
                    &mut self.adam,
                    &raw,
                    mbs,
                    &mut mb.update,
                    cfg,
                    self.threads,
                    comm,
                )?;
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

    /// Run one iteration (rollout + update).
    pub fn iteration(&mut self) -> Result<IterationStats, LearnError> {
        let stats = self.collect_rollout()?;
        self.update_from_rollout(stats)
    }

    /// The rollout half of an iteration: fill the rollout storage (statistics reduced over the
    /// ranks, `rollout_s` set).
    pub fn collect_rollout(&mut self) -> Result<IterationStats, LearnError> {
        let mut stats = IterationStats::default();
        let t0 = Instant::now();
        self.rollout(&mut stats)?;
        stats.rollout_s = t0.elapsed().as_secs_f64();
        stats.inference_s = (stats.rollout_s - stats.env_s).max(0.0);
        Ok(stats)
    }

    /// The update half of an iteration on the rollout storage, then count the iteration. A
    /// divergence ([`crate::divergence`]) is an error naming the iteration; the trainer's state
    /// is then unusable (not to be saved).
    pub fn update_from_rollout(
        &mut self,
        mut stats: IterationStats,
    ) -> Result<IterationStats, LearnError> {
        let t1 = Instant::now();
        let it = self.progress.iteration + 1;
        let at = move |e| crate::divergence::in_iteration(e, it);
        self.update(&mut stats).map_err(at)?;
        crate::divergence::check_state(&self.policy, &self.adam).map_err(at)?;
        if let Some(amp) = &mut self.amp {
            let l = amp.update(&mut self.comm)?;
            if !l.total.is_finite() {
                return Err(at(LearnError::Diverged(format!(
                    "the discriminator loss is {}",
                    l.total
                ))));
            }
            (stats.disc_loss, stats.disc_ref, stats.disc_sim) = (l.total, l.mean_ref, l.mean_sim);
        }
        stats.update_s = t1.elapsed().as_secs_f64();
        self.progress.iteration += 1;
        self.progress.samples += self.cfg.batch_size() as u64;
        stats.iteration = self.progress.iteration;
        stats.samples = self.progress.samples;
        stats.low_level_samples = self.progress.samples * self.env.spec().steps_per_action as u64;
        stats.samples_per_s = self.cfg.batch_size() as f64 / (stats.rollout_s + stats.update_s);
        stats.world_size = self.shard.world;
        stats.allreduce_s = self.comm.take_seconds();
        Ok(stats)
    }

    /// The rollout storage (time-major over this rank's environments).
    pub fn rollout_storage(&self) -> &Rollout {
        &self.roll
    }

    /// Replace the rollout storage by this rank's environments of `full`, a rollout of all
    /// `env.num_envs` environments (equivalence tests: every rank updates on its part of one
    /// rollout).
    pub fn load_rollout_part(&mut self, full: &Rollout) {
        self.alloc_rollout();
        let (h, d, a) = (self.cfg.ppo.horizon, self.env.obs_dim(), self.env.act_dim());
        self.roll.copy_envs_from(
            full,
            h,
            self.shard.total_envs,
            self.shard.offset,
            self.shard.local,
            d,
            a,
        );
    }

    /// Simulation-only throughput probe for `skillmimic bench train`: step the same environments
    /// for one horizon with the actions of the last rollout (resets included, no inference, no
    /// update) and return the wall-clock seconds. It advances the environments, so a benchmark
    /// run's later training differs from an unprobed run's.
    pub fn sim_only_horizon(&mut self) -> Result<f64, LearnError> {
        self.alloc_rollout();
        let (h, n, a) = (self.cfg.ppo.horizon, self.env.num_envs(), self.env.act_dim());
        let t0 = Instant::now();
        for t in 0..h {
            self.env.reset_done();
            self.env.step(&self.roll.actions[t * n * a..(t + 1) * n * a])?;
        }
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Write a training checkpoint (atomic) and the effective config next to it.
    pub fn save(&self, path: &Path) -> Result<(), LearnError> {
        let extra = self.amp.as_ref().map(|a| a.tensors()).unwrap_or_default();
        checkpoint::save_with(
            path,
            &self.policy,
            Some(&self.adam),
            &self.progress,
            &self.config_toml,
            extra,
        )
        .map_err(io(path))?;
        let toml_path = path.with_extension("toml");
        skillmimic_core::tensorfile::write_bytes_atomic(&toml_path, self.config_toml.as_bytes())
            .map_err(io(&toml_path))
    }
}
