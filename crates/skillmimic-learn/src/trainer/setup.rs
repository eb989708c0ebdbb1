//! Building a trainer: configuration checks, the seeds of the run (episode starts, action
//! noise, resumed streams), the history encoder kept with the run, the environment of this
//! rank, a fresh policy (adapted from a trained one for TokenHSI's policy adaptation) or the
//! resumed state, the data-parallel agreement and broadcast, and the extensions.

use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skillmimic_env::registry;

use super::extension::Extension;
use super::rollout::Rollouts;
use super::state::Trainer;
use super::update::Updater;
use crate::adam::Adam;
use crate::checkpoint::{self, Progress};
use crate::collective::{Collective, Timed, mix_seed};
use crate::config::TrainConfig;
use crate::error::{LearnError, bad_checkpoint, io};
use crate::policy::Policy;
use crate::shard::Shard;

/// Build one rank's trainer (see [`Trainer::with_collective`]).
pub fn build(
    mut cfg: TrainConfig,
    resume: Option<&Path>,
    comm: Box<dyn Collective>,
) -> Result<Trainer, LearnError> {
    let mut comm = Timed::new(comm);
    cfg.validate()?;
    let shard = Shard::new(cfg.env.num_envs, comm.rank(), comm.world_size())?;
    let rank = shard.rank;
    check(&cfg)?;
    // derived value, made explicit in the effective config: episode starts follow the run seed
    // unless `env.seed` is set
    let start_seed = cfg.env.start_seed(cfg.run.seed);
    cfg.env.seed = Some(start_seed);
    if let Some(path) = resume.filter(|_| cfg.run.active.enabled && rank == 0) {
        // the library and weights of active learning's rounds as they were at the checkpoint
        crate::active_resume::prepare(&mut cfg, path)?;
    }
    let mut ecfg = cfg.env.clone();
    keep_history_encoder(&mut cfg, rank, resume)?;
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
    let (mut policy, mut adam, mut progress) = match resume.filter(|_| rank == 0) {
        None => {
            // the task's character (its default when env.character is empty)
            let character = registry::character(&ecfg)?;
            let obs = crate::policies::ObsInfo::of_env(env.as_ref(), character);
            fresh_state(&cfg, &ppo, &obs, env.spec().action_space, &mut rng)?
        }
        Some(path) => resumed_state(&cfg, path, (obs_dim, act_dim))?,
    };
    if comm.world_size() > 1 {
        crate::sync::check_agreement(&cfg, &policy, &adam, &mut comm)?;
        crate::sync::broadcast_state(&mut policy, &mut adam, &mut progress, &mut comm)?;
        adam.lr = cfg.ppo.lr;
    }
    if progress.iteration > 0 {
        // resumed: continue with streams of random numbers that differ from the first run's
        // (replaced by the saved ones when the checkpoint holds the run's state, `resume`)
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
    // a multi-task environment: one conditional discriminator or one per task (env.hsi)
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
    let rollouts = Rollouts::new(env.num_envs(), obs_dim, policy.actor_outputs(), rng, threads);
    let extensions: Vec<Box<dyn Extension>> =
        amp.into_iter().map(|a| Box::new(a) as Box<dyn Extension>).collect();
    let config_toml = cfg.to_toml();
    let mut t = Trainer {
        cfg,
        env,
        policy,
        adam,
        progress,
        shard,
        resumed_from: resume.filter(|_| rank == 0).map(Path::to_path_buf),
        finish_if_complete: false,
        rollouts,
        updater: Updater::new(threads),
        extensions,
        comm,
        config_toml,
    };
    if t.progress.iteration > 0 {
        // resumed: the saved environments, streams and extension states, where the checkpoint
        // has them (every rank takes part; rank 0 reads the file)
        super::resume::apply(&mut t, resume)?;
    }
    Ok(t)
}

/// The checks that need more than one key (the single keys' ranges are `cfg.validate`'s), and
/// the warnings of a precision the machine or backend cannot honour.
fn check(cfg: &TrainConfig) -> Result<(), LearnError> {
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
                "ppo.precision = \"bf16\" applies to the fast backend only; the candle backend \
                    runs in float32"
            );
        }
    }
    Ok(())
}

/// The frozen SkillMimic-V2 history encoder defines part of the policy's input: a fresh run keeps
/// a copy in `run.out_dir` (written by rank 0; the others read the original) and its saved
/// configuration points there, so the run's checkpoints stay usable when the original moves. A
/// resumed run whose folder holds that copy reads it too (its effective configuration is then
/// the saved one, and an exact resume writes the same checkpoints).
fn keep_history_encoder(
    cfg: &mut TrainConfig,
    rank: usize,
    resume: Option<&Path>,
) -> Result<(), LearnError> {
    let kept = cfg.run.out_dir.join("history_encoder.safetensors");
    if cfg.env.v2.history.enabled && resume.is_some() && kept.is_file() {
        // a resumed run reads the copy its checkpoints were trained with, and its effective
        // configuration stays the one it saved
        cfg.env.v2.history.encoder = kept;
        return Ok(());
    }
    if cfg.env.v2.history.enabled && resume.is_none() {
        // the frozen encoder defines part of the policy's input: keep a copy with the run
        // (written by rank 0; the others read the original)
        let src = cfg.env.v2.history.encoder.clone();
        let dst = cfg.run.out_dir.join("history_encoder.safetensors");
        if src != dst {
            if rank == 0 {
                std::fs::create_dir_all(&cfg.run.out_dir).map_err(io(&cfg.run.out_dir))?;
                let bytes = std::fs::read(&src).map_err(io(&src))?;
                skillmimic_core::tensorfile::write_bytes_atomic(&dst, &bytes).map_err(io(&dst))?;
            }
            cfg.env.v2.history.encoder = dst;
        }
    }
    Ok(())
}

/// A fresh policy (adapted from a trained one when `ppo.token.adapt_from` is set: TokenHSI's
/// policy adaptation) and its optimiser; `rng` is the run's initialisation stream.
fn fresh_state(
    cfg: &TrainConfig,
    ppo: &crate::config::PpoConfig,
    obs: &crate::policies::ObsInfo,
    space: skillmimic_env::ActionSpace,
    rng: &mut ChaCha8Rng,
) -> Result<(Policy, Adam, Progress), LearnError> {
    let mut policy = Policy::build_for(obs, space, ppo, rng)?;
    if !ppo.token.adapt_from.as_os_str().is_empty() {
        crate::adapt::adapt(&mut policy, &ppo.token.adapt_from, ppo.token.gate_adapters, rng)?;
    }
    let adam = Adam::new(&crate::ppo::update::param_sizes(&policy), cfg.ppo.lr, cfg.ppo.adam_eps);
    Ok((policy, adam, Progress::default()))
}

/// The state of the training checkpoint `path` (a policy-only checkpoint, other hidden sizes or
/// another family are errors naming the file); the learning rate is the config's.
fn resumed_state(
    cfg: &TrainConfig,
    path: &Path,
    dims: (usize, usize),
) -> Result<(Policy, Adam, Progress), LearnError> {
    let c = checkpoint::load(path, Some(dims))?;
    let mut adam = c.adam.ok_or_else(|| {
        bad_checkpoint(path)(format!(
            "{}: a policy-only (exported) checkpoint cannot resume \
            training; use a training checkpoint",
            path.display()
        ))
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
    Ok((c.policy, adam, c.progress))
}
