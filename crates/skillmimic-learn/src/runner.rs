//! The training runner: owns the loop around [`Trainer`] — JSONL and TensorBoard logs, periodic
//! checkpoints (atomic, with the effective config next to them), then the end-of-run work: the
//! task's evaluation, the caller's hooks (learning-curve plot, video, …) and `summary.json`.
//! The command line only parses arguments and calls [`Runner::run`].
//!
//! In a data-parallel run every rank trains; only rank 0 writes (logs, checkpoints, evaluation,
//! hooks, summary), and its logged statistics are those of all ranks (see
//! [`crate::trainer::IterationStats`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use skillmimic_core::tensorfile::write_bytes_atomic;

use crate::episode_eval::{EpisodeReport, evaluate_episodes};
use crate::error::{LearnError, io};
use crate::eval::{EvalReport, evaluate};
use crate::tblog::EventWriter;
use crate::trainer::{IterationHook, IterationStats, Trainer};

/// Train for the configured iterations, writing logs and checkpoints into `run.out_dir`;
/// `on_iteration` sees every iteration's statistics (progress bars). Returns the path of the
/// last checkpoint.
pub fn train_loop(
    t: &mut Trainer,
    mut on_iteration: impl FnMut(&IterationStats),
) -> Result<PathBuf, LearnError> {
    train_loop_until(t, |s| {
        on_iteration(s);
        true
    })
    .map(|(p, _)| p)
}

/// [`train_loop`] that stops early when `on_iteration` returns false (an interrupt seen by the
/// caller), after saving a checkpoint of the last finished iteration. Returns the last checkpoint
/// and whether it stopped early.
///
/// Before the first iteration rank 0 prepares the run folder ([`crate::run_dir::prepare`]: stale
/// temporary files removed, `log.jsonl` and the TensorBoard events cut to the starting
/// iteration). A resumed run that already reached `run.iterations` is a [`LearnError::Config`]
/// saying so, unless [`Trainer::finish_if_complete`] is set and the run stands exactly at
/// `run.iterations`: then nothing is trained or written and the latest checkpoint is returned.
/// A divergence ([`crate::divergence`]) is a [`LearnError::Diverged`] naming the
/// iteration and the last good checkpoint; nothing of the diverged state is saved.
pub fn train_loop_until(
    t: &mut Trainer,
    mut on_iteration: impl FnMut(&IterationStats) -> bool,
) -> Result<(PathBuf, bool), LearnError> {
    let out = t.cfg.run.out_dir.clone();
    let target = t.cfg.run.iterations as u64;
    let start = t.progress.iteration;
    if t.is_complete() {
        if t.shard.rank == 0 {
            tracing::info!(
                "the run in {} is already complete at iteration {start} (--resume latest): \
                    evaluating and writing the summary only",
                out.display()
            );
        }
        return Ok((out.join("latest.safetensors"), false));
    }
    if start > 0 && start >= target {
        let from = t.resumed_from.as_ref().map_or(String::new(), |p| format!(" {}", p.display()));
        return Err(LearnError::Config(format!(
            "config field 'run.iterations': the run is already complete: the checkpoint{from} is \
                at iteration {start} and run.iterations is {target}; raise run.iterations \
                (--iterations) to train further"
        )));
    }
    let save_every = t.cfg.run.save_every as u64;
    // the regular checkpoint iterations, where every rank hands in its resume state
    let keep_state = t.cfg.run.save_run_state;
    let regular = |it: u64| keep_state && (it.is_multiple_of(save_every) || it == target);
    if t.shard.rank != 0 {
        while t.progress.iteration < target {
            let s = t.iteration()?;
            if regular(t.progress.iteration) {
                t.resume_state()?;
            }
            if !on_iteration(&s) {
                return Ok((out.join("latest.safetensors"), true));
            }
        }
        return Ok((out.join("latest.safetensors"), false));
    }
    let ckpt_dir = out.join("checkpoints");
    std::fs::create_dir_all(&ckpt_dir).map_err(io(&ckpt_dir))?;
    crate::run_dir::prepare(&out, &t.progress)?;
    let mut hooks = iteration_hooks(&t.cfg);
    if start > 0 {
        for h in hooks.iter_mut() {
            h.on_resume(t)?;
        }
    }
    let cfg_path = out.join("config.toml");
    write_bytes_atomic(&cfg_path, t.config_toml().as_bytes()).map_err(io(&cfg_path))?;
    let log_path = out.join("log.jsonl");
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(io(&log_path))?;
    let mut tb = EventWriter::create(&out.join("tb")).map_err(io(&out.join("tb")))?;
    let mut last = out.join("latest.safetensors");
    let mut last_good = t.resumed_from.clone();
    while t.progress.iteration < target {
        let s = t
            .iteration()
            .map_err(|e| crate::divergence::with_last_good(e, last_good.as_deref()))?;
        use std::io::Write;
        writeln!(log, "{}", serde_json::to_string(&s).expect("serialisable stats"))
            .map_err(io(&log_path))?;
        let scalars = s.scalars();
        let refs: Vec<(&str, f32)> = scalars.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        tb.scalars(s.samples as i64, &refs).map_err(io(tb.path()))?;
        let go_on = on_iteration(&s);
        let it = t.progress.iteration;
        if it < target && go_on {
            for h in hooks.iter_mut() {
                h.after_iteration(t)
                    .map_err(|e| crate::divergence::with_last_good(e, last_good.as_deref()))?;
            }
        }
        if it.is_multiple_of(save_every) || it == target || !go_on {
            // one process: always; data-parallel: at the regular iterations only, where every
            // rank takes part (an interrupt's checkpoint then resumes with fresh episodes)
            let state = if regular(it) || (keep_state && t.shard.world == 1) {
                t.resume_state()?
            } else {
                None
            };
            let p = ckpt_dir.join(format!("iter_{it:06}.safetensors"));
            t.save_with_state(&p, state.clone())?;
            t.save_with_state(&out.join("latest.safetensors"), state)?;
            last_good = Some(p.clone());
            last = p;
        }
        if !go_on {
            return Ok((last, true));
        }
    }
    Ok((last, false))
}

/// The iteration hooks the configuration asks for (one line each): active skill learning
/// (`run.active`).
fn iteration_hooks(cfg: &crate::config::TrainConfig) -> Vec<Box<dyn IterationHook>> {
    let mut hooks: Vec<Box<dyn IterationHook>> = Vec::new();
    hooks.extend(
        crate::active::Rounds::for_config(cfg).map(|h| Box::new(h) as Box<dyn IterationHook>),
    );
    hooks
}

/// What an end-of-run hook produced: a file, or why it could not.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HookOutput {
    pub path: Option<PathBuf>,
    pub error: Option<String>,
}

/// Work done once training has finished (after the evaluation), e.g. a plot or a video.
pub trait RunHook: Send {
    /// Key of the output in `summary.json`.
    fn name(&self) -> &'static str;
    /// Produce the output into `out_dir`. An `Err` stops the run; failures that should not
    /// (a missing video encoder) are reported in [`HookOutput::error`] instead.
    fn run(&mut self, trainer: &Trainer, out_dir: &Path) -> anyhow::Result<HookOutput>;
}

/// `summary.json` of a run.
#[derive(Serialize)]
pub struct Summary {
    pub task: String,
    pub iterations: u64,
    pub samples: u64,
    /// `samples` in simulation steps (× the task's `steps_per_action`; the high-level tasks'
    /// papers count these).
    pub low_level_samples: u64,
    pub wall_s: f64,
    pub samples_per_s: f64,
    /// Ranks that trained (1: one process).
    pub world_size: usize,
    /// Mean seconds per iteration that rank 0 spent in collective operations.
    pub mean_allreduce_s: f64,
    /// Precision the update's backward products ran in: `"bf16"` only where `ppo.precision`
    /// asked for it, the fast backend computed the loss and the CPU has AVX512-BF16.
    pub update_precision: &'static str,
    /// Mean reward per step of the first iteration of this run (biased: every episode is fresh).
    pub first_mean_reward: f64,
    pub last_mean_reward: f64,
    pub best_mean_reward: f64,
    /// Iterations averaged in `early_mean_reward` / `late_mean_reward`: a tenth of the run,
    /// at least 1 and at most 25.
    pub reward_window: usize,
    /// Mean of the per-iteration mean reward over the first `reward_window` iterations.
    pub early_mean_reward: f64,
    /// Mean of the per-iteration mean reward over the last `reward_window` iterations.
    pub late_mean_reward: f64,
    pub checkpoint: PathBuf,
    /// The evaluation report file (`metrics.json`: the imitation report or the episode report).
    pub metrics: PathBuf,
    /// Outputs of the hooks by name (`curve`, `video`, …).
    pub outputs: std::collections::BTreeMap<String, HookOutput>,
    /// The imitation task's SkillMimic evaluation.
    pub eval: Option<EvalReport>,
    /// Every other task's episode evaluation (returns, lengths, terms, metrics).
    pub task_eval: Option<EpisodeReport>,
}

/// The training runner.
pub struct Runner {
    pub trainer: Trainer,
    hooks: Vec<Box<dyn RunHook>>,
}

impl Runner {
    pub fn new(trainer: Trainer) -> Self {
        Self { trainer, hooks: Vec::new() }
    }

    /// Add an end-of-run hook (run in the order added).
    pub fn hook(mut self, h: Box<dyn RunHook>) -> Self {
        self.hooks.push(h);
        self
    }

    /// Train to `run.iterations`, evaluate, run the hooks and write `summary.json` (returned).
    /// `on_iteration` sees every iteration's statistics (progress display). Ranks other than 0 of
    /// a data-parallel run only train and return `None`.
    pub fn run(
        &mut self,
        mut on_iteration: impl FnMut(&IterationStats),
    ) -> Result<Option<Summary>, anyhow::Error> {
        self.run_until(|s| {
            on_iteration(s);
            true
        })
    }

    /// [`Runner::run`] that stops when `on_iteration` returns false: the last finished iteration
    /// is saved and an error saying so is returned (no evaluation, no summary).
    pub fn run_until(
        &mut self,
        mut on_iteration: impl FnMut(&IterationStats) -> bool,
    ) -> Result<Option<Summary>, anyhow::Error> {
        let start = Instant::now();
        let mut rewards = Vec::new();
        let mut allreduce = 0.0;
        let (last, stopped) = train_loop_until(&mut self.trainer, |s| {
            rewards.push(s.mean_reward);
            allreduce += s.allreduce_s;
            on_iteration(s)
        })?;
        if stopped {
            anyhow::bail!(
                "training stopped at iteration {}; checkpoint {} (continue with --resume)",
                self.trainer.progress.iteration,
                last.display()
            );
        }
        let wall = start.elapsed().as_secs_f64();
        let t = &self.trainer;
        if t.shard.rank != 0 {
            return Ok(None);
        }
        let out = t.cfg.run.out_dir.clone();
        let trained = rewards.len();
        if trained == 0 {
            // a finished run re-entered (`--resume latest`): the reward statistics are the run's,
            // from its log
            rewards = logged_rewards(&out.join("log.jsonl"))?;
        }
        let report = evaluate_task(t)?;
        let path = out.join("metrics.json");
        write_bytes_atomic(&path, serde_json::to_string_pretty(&report)?.as_bytes())
            .map_err(io(&path))?;
        let (eval, task_eval) = match report {
            TaskEval::Imitation(r) => (Some(r), None),
            TaskEval::Episodes(r) => (None, Some(r)),
        };
        let mut outputs = std::collections::BTreeMap::new();
        for h in &mut self.hooks {
            outputs.insert(h.name().to_string(), h.run(t, &out)?);
        }
        let window = (rewards.len() / 10).clamp(1, 25);
        let mean_of = |xs: &[f64]| {
            if xs.is_empty() { f64::NAN } else { xs.iter().sum::<f64>() / xs.len() as f64 }
        };
        let summary = Summary {
            task: t.cfg.env.task.clone(),
            iterations: t.progress.iteration,
            samples: t.progress.samples,
            low_level_samples: t.progress.samples * t.env.spec().steps_per_action as u64,
            wall_s: wall,
            samples_per_s: if trained == 0 {
                0.0
            } else {
                (trained * t.cfg.batch_size()) as f64 / wall
            },
            world_size: t.shard.world,
            mean_allreduce_s: allreduce / trained.max(1) as f64,
            update_precision: t.update_precision(),
            first_mean_reward: rewards.first().copied().unwrap_or(f64::NAN),
            last_mean_reward: rewards.last().copied().unwrap_or(f64::NAN),
            best_mean_reward: rewards.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            reward_window: window,
            early_mean_reward: mean_of(&rewards[..window.min(rewards.len())]),
            late_mean_reward: mean_of(&rewards[rewards.len().saturating_sub(window)..]),
            checkpoint: last,
            metrics: path,
            outputs,
            eval,
            task_eval,
        };
        let path = out.join("summary.json");
        write_bytes_atomic(&path, serde_json::to_string_pretty(&summary)?.as_bytes())
            .map_err(io(&path))?;
        Ok(Some(summary))
    }
}

/// The per-iteration mean rewards of a run's `log.jsonl` (its `mean_reward` column, in order).
fn logged_rewards(path: &Path) -> Result<Vec<f64>, LearnError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| {
            serde_json::from_str::<serde_json::Value>(l)
                .ok()
                .and_then(|v| v.get("mean_reward").and_then(serde_json::Value::as_f64))
                .ok_or_else(|| {
                    LearnError::Config(format!(
                        "{}: line {}: expected a JSON object with a numeric 'mean_reward'",
                        path.display(),
                        i + 1
                    ))
                })
        })
        .collect()
}

/// A task's end-of-run evaluation (serialised as the report itself into `metrics.json`).
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum TaskEval {
    /// SkillMimic metrics of the imitation task.
    Imitation(EvalReport),
    /// The task-independent episode report of every other task.
    Episodes(EpisodeReport),
}

/// The task's end-of-run evaluation with the deterministic policy, `run.eval_episodes` episodes
/// on at most 16 environments, seed `run.seed`.
pub fn evaluate_task(t: &Trainer) -> Result<TaskEval, LearnError> {
    use skillmimic_env::registry::{self, Evaluation};
    let mut c = t.cfg.env.clone();
    c.num_envs = c.num_envs.min(16);
    let mut env = registry::make_sharing(&c, t.env.as_ref())?;
    let (episodes, seed) = (t.cfg.run.eval_episodes, t.cfg.run.seed);
    Ok(match registry::entry(&c.task).map(|e| e.evaluation) {
        Some(Evaluation::SkillMimic) => {
            TaskEval::Imitation(evaluate(&t.policy, env.as_mut(), episodes, seed, false, 0))
        }
        _ => TaskEval::Episodes(evaluate_episodes(
            &t.policy,
            env.as_mut(),
            episodes,
            seed,
            false,
            0,
        )?),
    })
}
