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
//! checkpoint's policy, normalisers and Adam state and, where the checkpoint holds it, the saved
//! state of the environments, streams and extensions, so that it goes on exactly as the run
//! would have ([`resume`]; otherwise with freshly reset environments).
//!
//! The parts: `setup` builds a trainer (seeds, environment, fresh or resumed policy, the
//! data-parallel agreement, extensions); `rollout` collects an iteration's samples;
//! `update` runs PPO on them; `extension` is the hook interface of the parts that ride
//! along (`ppo.amp.enabled`: the motion prior's style reward and discriminator,
//! [`crate::amp_reward`]).
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

mod extension;
mod hooks;
pub mod resume;
mod rollout;
mod setup;
mod state;
mod update;

use std::path::Path;
use std::time::Instant;

use skillmimic_env::registry;

use crate::checkpoint::{self};
use crate::collective::{Collective, Single};
use crate::config::TrainConfig;
use crate::error::{LearnError, io};
use crate::policy::Policy;
use crate::storage::Rollout;
use skillmimic_core::tensorfile::OwnedTensor;

pub use crate::iteration_stats::IterationStats;
pub use extension::{Extension, StepView};
pub use hooks::IterationHook;
pub use state::Trainer;
use update::UpdateInput;

impl Trainer {
    /// A new trainer (fresh policy), or one resumed from `resume` (a training checkpoint).
    pub fn new(cfg: TrainConfig, resume: Option<&Path>) -> Result<Self, LearnError> {
        Self::with_collective(cfg, resume, Box::new(Single))
    }

    /// One rank of a data-parallel run over `comm` (see the module documentation); with
    /// [`Single`] the same as [`Trainer::new`]. Only rank 0 reads `resume`; the other ranks take
    /// the state from rank 0.
    pub fn with_collective(
        cfg: TrainConfig,
        resume: Option<&Path>,
        comm: Box<dyn Collective>,
    ) -> Result<Self, LearnError> {
        setup::build(cfg, resume, comm)
    }

    /// Whether this run only has its end-of-run work left: [`Trainer::finish_if_complete`] is set
    /// and the run already stands at `run.iterations` (the runner then trains nothing).
    pub fn is_complete(&self) -> bool {
        let done = self.progress.iteration;
        self.finish_if_complete && done > 0 && done == self.cfg.run.iterations as u64
    }

    /// Precision of the update's backward products in this run (`"bf16"` or `"f32"`, see
    /// [`crate::config::Precision`]).
    pub fn update_precision(&self) -> &'static str {
        let bf16 = self.cfg.ppo.backend == crate::config::Backend::Fast
            && crate::ppo::fast::applies_to(&self.policy)
            && crate::ppo::mlp_grad::Mm::new(1, self.cfg.ppo.precision).bf16;
        if bf16 { "bf16" } else { "f32" }
    }

    /// The extension of type `E`, when the run has one (e.g. the motion prior,
    /// [`crate::amp_reward::AmpReward`]).
    pub fn extension<E: Extension>(&self) -> Option<&E> {
        self.extensions.iter().find_map(|e| e.as_any().downcast_ref::<E>())
    }

    /// The policy and configuration, with the extension of type `E` mutably (active learning
    /// scores generated clips with the motion prior's discriminator while reading the policy).
    pub fn policy_and_extension_mut<E: Extension>(
        &mut self,
    ) -> (&Policy, &TrainConfig, Option<&mut E>) {
        let ext = self.extensions.iter_mut().find_map(|e| e.as_any_mut().downcast_mut::<E>());
        (&self.policy, &self.cfg, ext)
    }

    /// Rebuild the environment from `cfg.env` after it changed (one process; fresh episodes),
    /// re-derive the effective configuration saved with checkpoints and restart the per-episode
    /// bookkeeping.
    pub fn rebuild_env(&mut self) -> Result<(), LearnError> {
        let mut e = self.cfg.env.clone();
        e.num_envs = self.shard.local;
        self.env = registry::make(&e)?;
        self.config_toml = self.cfg.to_toml();
        self.rollouts.episodes.clear();
        for x in self.extensions.iter_mut() {
            x.restart();
        }
        Ok(())
    }

    /// The effective configuration as TOML.
    pub fn config_toml(&self) -> &str {
        &self.config_toml
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
        self.rollouts.collect(
            self.cfg.ppo.horizon,
            self.env.as_mut(),
            &self.policy,
            &mut self.extensions,
            &mut self.comm,
            &mut stats,
        )?;
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
        let input = UpdateInput {
            cfg: &self.cfg,
            iteration: self.progress.iteration,
            shard: self.shard,
            dims: (self.env.num_envs(), self.env.obs_dim(), self.env.act_dim()),
        };
        let roll = &mut self.rollouts.storage;
        self.updater
            .run(
                &input,
                roll,
                &mut self.policy,
                &mut self.adam,
                &mut self.comm,
                &mut stats,
                &mut self.extensions,
            )
            .map_err(at)?;
        crate::divergence::check_state(&self.policy, &self.adam).map_err(at)?;
        for e in self.extensions.iter_mut() {
            e.update(&mut self.comm, &mut stats).map_err(at)?;
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
        &self.rollouts.storage
    }

    /// Replace the rollout storage by this rank's environments of `full`, a rollout of all
    /// `env.num_envs` environments (equivalence tests: every rank updates on its part of one
    /// rollout).
    pub fn load_rollout_part(&mut self, full: &Rollout) {
        let h = self.cfg.ppo.horizon;
        self.rollouts.alloc(h, self.env.as_ref());
        let (d, a) = (self.env.obs_dim(), self.env.act_dim());
        let s = self.shard;
        self.rollouts.storage.copy_envs_from(full, h, s.total_envs, s.offset, s.local, d, a);
    }

    /// Simulation-only throughput probe for `skillmimic bench train`: step the same environments
    /// for one horizon with the actions of the last rollout (resets included, no inference, no
    /// update) and return the wall-clock seconds. It advances the environments, so a benchmark
    /// run's later training differs from an unprobed run's.
    pub fn sim_only_horizon(&mut self) -> Result<f64, LearnError> {
        let h = self.cfg.ppo.horizon;
        self.rollouts.alloc(h, self.env.as_ref());
        let (n, a) = (self.env.num_envs(), self.env.act_dim());
        let t0 = Instant::now();
        for t in 0..h {
            self.env.reset_done();
            self.env.step(&self.rollouts.storage.actions[t * n * a..(t + 1) * n * a])?;
        }
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Write a training checkpoint (atomic; with every extension's tensors) and the effective
    /// config next to it.
    ///
    /// In one process the checkpoint holds the run's state for an exact resume ([`resume`]); a
    /// data-parallel run's ranks gather theirs together ([`Trainer::resume_state`]) and rank 0
    /// writes it with [`Trainer::save_with_state`].
    pub fn save(&self, path: &Path) -> Result<(), LearnError> {
        let state = match self.shard.world {
            1 if self.cfg.run.save_run_state => resume::single(self)?,
            _ => None,
        };
        self.save_with_state(path, state)
    }

    /// The run's state for an exact resume ([`resume`]): on rank 0 the checkpoint tensor, `None`
    /// on the others. Collective in a data-parallel run (every rank calls it at the same
    /// iterations).
    pub fn resume_state(&mut self) -> Result<Option<OwnedTensor>, LearnError> {
        resume::collect(self)
    }

    /// [`Trainer::save`] with the given resume state (`None`: a checkpoint whose resume starts
    /// fresh episodes).
    pub fn save_with_state(
        &self,
        path: &Path,
        state: Option<OwnedTensor>,
    ) -> Result<(), LearnError> {
        let mut extra: Vec<_> = self.extensions.iter().flat_map(|e| e.tensors()).collect();
        extra.extend(state);
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
