//! `skillmimic train`: parse the arguments, then hand the run to `skillmimic_learn::runner` with
//! two end-of-run hooks of the CLI (learning-curve PNG, short video).

use std::io::IsTerminal;
use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use skillmimic_learn::runner::{HookOutput, RunHook, Runner};
use skillmimic_learn::trainer::{IterationStats, Trainer};

use crate::common::init_learner_threads;

pub use skillmimic_learn::args::TrainArgs as Args;

/// End-of-run hook: the learning-curve PNG.
struct CurveHook;

impl RunHook for CurveHook {
    fn name(&self) -> &'static str {
        "curve"
    }
    fn run(&mut self, _t: &Trainer, out: &Path) -> anyhow::Result<HookOutput> {
        let curve = out.join("curve.png");
        crate::plot::plot_log(&out.join("log.jsonl"), &curve)?;
        Ok(HookOutput { path: Some(curve), error: None })
    }
}

/// End-of-run hook: a short video of the deterministic policy (rendering failures are
/// reported, not fatal).
struct VideoHook;

impl RunHook for VideoHook {
    fn name(&self) -> &'static str {
        "video"
    }
    fn run(&mut self, t: &Trainer, out: &Path) -> anyhow::Result<HookOutput> {
        let mut c = t.cfg.env.clone();
        c.num_envs = 1;
        c.threads = 1;
        // the imitation task reuses the trainer's motion library (`build_sharing`)
        let env = skillmimic_env::registry::make_sharing(&c, t.env.as_ref())?;
        let path = out.join("video.gif");
        Ok(
            match crate::cmd_play::render_policy_video(
                &t.policy,
                (env, &c),
                t.cfg.run.seed,
                180,
                &path,
                (320, 240),
            ) {
                Ok(()) => HookOutput { path: Some(path), error: None },
                Err(e) => {
                    tracing::warn!("no video: {e:#}");
                    HookOutput { path: None, error: Some(format!("{e:#}")) }
                }
            },
        )
    }
}

/// The end-of-run artefacts of `skillmimic train` besides the runner's own (checkpoint, log,
/// metrics, summary): `curve.png` and, unless `run.final_video` is off, `video.gif`. The Python
/// trainer (`skillmimic_rs.train`, `python -m skillmimic_rs.train`) adds the same hooks.
pub fn with_artefact_hooks(runner: Runner) -> Runner {
    let video = runner.trainer.cfg.run.final_video;
    let runner = runner.hook(Box::new(CurveHook));
    if video { runner.hook(Box::new(VideoHook)) } else { runner }
}

fn progress_bar(total: u64, done: u64) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::new(total);
    pb.set_position(done);
    pb.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} it  {msg}",
        )
        .expect("valid template"),
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
    let cfg = a.config()?;
    init_learner_threads(cfg.run.learner_threads);
    let out = cfg.run.out_dir.clone();
    let resume = a.resume_path(&cfg.run.out_dir);
    if a.resume.is_some() && resume.is_none() {
        tracing::info!(
            "--resume latest: no checkpoint in {} yet, starting fresh",
            cfg.run.out_dir.display()
        );
    }
    let mut trainer = Trainer::new(cfg.clone(), resume.as_deref())?;
    trainer.finish_if_complete = a.resume_is_latest();
    let complete = trainer.is_complete();
    tracing::info!(
        "training task '{}': {} envs x horizon {} = {} samples/iteration, network {:?}, {} \
            iterations -> {}",
        cfg.env.task,
        cfg.env.num_envs,
        cfg.ppo.horizon,
        cfg.batch_size(),
        cfg.ppo.hidden,
        cfg.run.iterations,
        out.display()
    );
    let pb = progress_bar(cfg.run.iterations as u64, trainer.progress.iteration);
    let every = (cfg.run.iterations / 20).max(1) as u64;
    let mut runner = with_artefact_hooks(Runner::new(trainer));
    // Ctrl-C / SIGTERM (crate::stop): a checkpoint of the finished iteration, then an error naming it
    let training = crate::stop::training();
    let summary = runner
        .run_until(|s| {
            match &pb {
                Some(pb) => {
                    pb.set_position(s.iteration);
                    pb.set_message(describe(s));
                }
                None if s.iteration % every == 0 || s.iteration == 1 => {
                    tracing::info!("iteration {}: {}", s.iteration, describe(s))
                }
                None => {}
            }
            !crate::stop::stop_requested()
        })?
        .expect("a single-process run is rank 0");
    drop(training);
    if let Some(pb) = pb {
        pb.finish();
    }
    let eval = match (&summary.eval, &summary.task_eval) {
        (Some(e), _) => format!("; eval NR {:.4}, Acc {:.1} %", e.nr, e.acc_percent),
        (None, Some(e)) => {
            let success = e
                .final_metrics
                .get("success")
                .map_or(String::new(), |s| format!(", success {:.1} %", 100.0 * s));
            format!(
                "; eval return {:.3}, reward/step {:.4}, length {:.1}{success}",
                e.mean_return, e.mean_reward_per_step, e.mean_episode_length
            )
        }
        (None, None) => String::new(),
    };
    let what = if complete {
        format!(
            "already complete at {} iterations ({} samples): evaluated in {:.1} s",
            summary.iterations, summary.samples, summary.wall_s
        )
    } else {
        format!(
            "trained {} iterations ({} samples) in {:.1} s",
            summary.iterations, summary.samples, summary.wall_s
        )
    };
    println!(
        "{what}; mean reward/step over the first {w} iterations {:.4} -> last {w} {:.4}{eval}",
        summary.early_mean_reward,
        summary.late_mean_reward,
        w = summary.reward_window
    );
    println!("checkpoint {}", summary.checkpoint.display());
    println!("metrics    {}", summary.metrics.display());
    for (name, o) in &summary.outputs {
        if let Some(p) = &o.path {
            println!("{name:<10} {}", p.display());
        }
    }
    println!("summary    {}", out.join("summary.json").display());
    Ok(())
}
