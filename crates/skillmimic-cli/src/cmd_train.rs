//! `skillmimic train`: PPO training with logs (JSONL + TensorBoard), checkpoints, and at the end
//! an evaluation (metrics JSON), a learning-curve PNG, a short video and a summary JSON.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use skillmimic_learn::eval::{EvalReport, evaluate};
use skillmimic_learn::trainer::{IterationStats, Trainer};

use crate::common::{PresetArgs, init_learner_threads};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub base: PresetArgs,
    /// Training iterations (`run.iterations`).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Seed of everything (`run.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder (`run.out_dir`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Learner threads (`run.learner_threads`, 0 = all cores).
    #[arg(long)]
    pub learner_threads: Option<usize>,
    /// Continue from a training checkpoint (optimizer and normaliser state included).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Skip the end-of-training video.
    #[arg(long)]
    pub no_video: bool,
}

#[derive(Serialize)]
struct Summary {
    iterations: u64,
    samples: u64,
    wall_s: f64,
    samples_per_s: f64,
    /// Mean reward per step of the first iteration of this run (biased: every episode is fresh).
    first_mean_reward: f64,
    last_mean_reward: f64,
    best_mean_reward: f64,
    /// Iterations averaged in `early_mean_reward` / `late_mean_reward`: a tenth of the run,
    /// at least 1 and at most 25.
    reward_window: usize,
    /// Mean of the per-iteration mean reward over the first `reward_window` iterations.
    early_mean_reward: f64,
    /// Mean of the per-iteration mean reward over the last `reward_window` iterations.
    late_mean_reward: f64,
    checkpoint: PathBuf,
    metrics: PathBuf,
    curve: PathBuf,
    video: Option<PathBuf>,
    video_error: Option<String>,
    eval: EvalReport,
}

fn progress_bar(total: u64, done: u64) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::new(total);
    pb.set_position(done);
    pb.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} it  {msg}").expect("valid template"),
    );
    Some(pb)
}

fn describe(s: &IterationStats) -> String {
    format!(
        "{:.0} samples/s  reward/step {:.4}  ep.len {:.1}  ep.return {:.2}  falls {:.0}%",
        s.samples_per_s,
        s.mean_reward,
        s.episode_length,
        s.episode_return,
        100.0 * s.early_terminations
    )
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut cfg = a.base.assemble()?;
    if let Some(v) = a.iterations {
        cfg.run.iterations = v;
    }
    if let Some(v) = a.seed {
        cfg.run.seed = v;
    }
    if let Some(v) = &a.out {
        cfg.run.out_dir = v.clone();
    }
    if let Some(v) = a.learner_threads {
        cfg.run.learner_threads = v;
    }
    if a.no_video {
        cfg.run.final_video = false;
    }
    init_learner_threads(cfg.run.learner_threads);
    let out = cfg.run.out_dir.clone();
    let mut trainer = Trainer::new(cfg.clone(), a.resume.as_deref())?;
    tracing::info!(
        "training: {} envs x horizon {} = {} samples/iteration, network {:?}, {} iterations -> {}",
        cfg.env.num_envs,
        cfg.ppo.horizon,
        cfg.batch_size(),
        cfg.ppo.hidden,
        cfg.run.iterations,
        out.display()
    );
    let start = Instant::now();
    let pb = progress_bar(cfg.run.iterations as u64, trainer.progress.iteration);
    let mut history: Vec<IterationStats> = Vec::new();
    let every = (cfg.run.iterations / 20).max(1) as u64;
    let last = trainer.train(|s| {
        match &pb {
            Some(pb) => {
                pb.set_position(s.iteration);
                pb.set_message(describe(s));
            }
            None if s.iteration % every == 0 || s.iteration == 1 => tracing::info!("iteration {}: {}", s.iteration, describe(s)),
            None => {}
        }
        history.push(s.clone());
    })?;
    if let Some(pb) = pb {
        pb.finish();
    }
    let wall = start.elapsed().as_secs_f64();

    // end of training: evaluation, curve, video
    let eval_cfg = {
        let mut c = cfg.env.clone();
        c.num_envs = c.num_envs.min(16);
        c
    };
    let mut env = skillmimic_env::SkillEnv::new(eval_cfg, trainer.env.library().clone())?;
    let report = evaluate(&trainer.policy, &mut env, cfg.run.eval_episodes, cfg.run.seed, false, 0);
    let metrics = out.join("metrics.json");
    skillmimic_core::tensorfile::write_bytes_atomic(&metrics, serde_json::to_string_pretty(&report)?.as_bytes())
        .with_context(|| format!("cannot write {}", metrics.display()))?;
    let curve = out.join("curve.png");
    crate::plot::plot_log(&out.join("log.jsonl"), &curve)?;
    let (mut video, mut video_error) = (None, None);
    if cfg.run.final_video {
        let path = out.join("video.gif");
        match crate::cmd_play::render_policy_video(&trainer.policy, &cfg, trainer.env.library().clone(), 180, &path, 320, 240) {
            Ok(()) => video = Some(path),
            Err(e) => {
                tracing::warn!("no video: {e:#}");
                video_error = Some(format!("{e:#}"));
            }
        }
    }
    let rewards: Vec<f64> = history.iter().map(|s| s.mean_reward).collect();
    let window = (rewards.len() / 10).clamp(1, 25);
    let mean_of = |xs: &[f64]| if xs.is_empty() { f64::NAN } else { xs.iter().sum::<f64>() / xs.len() as f64 };
    let summary = Summary {
        iterations: trainer.progress.iteration,
        samples: trainer.progress.samples,
        wall_s: wall,
        samples_per_s: (history.len() * cfg.batch_size()) as f64 / wall,
        first_mean_reward: rewards.first().copied().unwrap_or(f64::NAN),
        last_mean_reward: rewards.last().copied().unwrap_or(f64::NAN),
        best_mean_reward: rewards.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        reward_window: window,
        early_mean_reward: mean_of(&rewards[..window.min(rewards.len())]),
        late_mean_reward: mean_of(&rewards[rewards.len().saturating_sub(window)..]),
        checkpoint: last.clone(),
        metrics: metrics.clone(),
        curve: curve.clone(),
        video: video.clone(),
        video_error,
        eval: report,
    };
    let summary_path = out.join("summary.json");
    skillmimic_core::tensorfile::write_bytes_atomic(&summary_path, serde_json::to_string_pretty(&summary)?.as_bytes())
        .with_context(|| format!("cannot write {}", summary_path.display()))?;
    println!(
        "trained {} iterations ({} samples) in {:.1} s; mean reward/step over the first {w} iterations {:.4} -> last {w} {:.4}; eval NR {:.4}, Acc {:.1} %",
        summary.iterations,
        summary.samples,
        wall,
        summary.early_mean_reward,
        summary.late_mean_reward,
        summary.eval.nr,
        summary.eval.acc_percent,
        w = summary.reward_window
    );
    println!("checkpoint {}\nmetrics    {}\ncurve      {}", last.display(), metrics.display(), curve.display());
    if let Some(v) = &video {
        println!("video      {}", v.display());
    }
    println!("summary    {}", summary_path.display());
    Ok(())
}
