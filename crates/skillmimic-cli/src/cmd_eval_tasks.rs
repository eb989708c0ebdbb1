//! `skillmimic eval` for tasks other than imitation: the task-independent episode report of the
//! policy and, with `--baselines`, of a uniformly random choice and of every fixed choice on the
//! same episode starts (the high-level tasks: success rates by the paper's rule and by the
//! released code's latch, in the report's `final_metrics`).

use std::collections::BTreeMap;

use anyhow::{Context, bail};
use skillmimic_env::ActionSpace;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::episode_eval::{Actor, EpisodeReport, evaluate_actor};
use skillmimic_learn::policy::Policy;

/// What `skillmimic eval` asks of a task-independent evaluation.
pub struct Options {
    pub episodes: usize,
    pub seed: u64,
    pub stochastic: bool,
    pub baselines: bool,
    pub out: std::path::PathBuf,
}

/// Evaluate, print one line per actor, write the JSON (`{actor: report}`, or the policy's report
/// alone without baselines).
pub fn run(a: &Options, policy: Option<&Policy>, cfg: &TrainConfig) -> anyhow::Result<()> {
    let mut env = skillmimic_env::registry::make(&cfg.env)?;
    let mut actors = Vec::new();
    if let Some(p) = policy {
        actors.push(Actor::Policy { policy: p, stochastic: a.stochastic });
    }
    if a.baselines {
        let n = match env.spec().action_space {
            ActionSpace::Discrete { n } => n,
            ActionSpace::Box { .. } => bail!(
                "--baselines needs a task with discrete choices (a high-level task over a skill \
                    policy); '{}' has continuous actions here",
                cfg.env.task
            ),
        };
        actors.push(Actor::Random);
        actors.extend((0..n).map(Actor::Fixed));
    }
    let mut reports: BTreeMap<String, EpisodeReport> = BTreeMap::new();
    for actor in actors {
        let r = evaluate_actor(actor, env.as_mut(), a.episodes, a.seed, 0)
            .with_context(|| format!("evaluating {}", actor.label()))?;
        // a multi-task environment names its metrics `<task>/success`: one entry per task
        let fin = |k: &str| {
            let hits: Vec<String> = r
                .final_metrics
                .iter()
                .filter_map(|(name, v)| match name.strip_suffix(k) {
                    Some("") => Some(format!("{:.1} %", 100.0 * v)),
                    Some(prefix) => {
                        prefix.strip_suffix('/').map(|task| format!("{task} {:.1} %", 100.0 * v))
                    }
                    _ => None,
                })
                .collect();
            if hits.is_empty() { "-".to_string() } else { hits.join(", ") }
        };
        let normalised =
            r.normalised_return.map_or(String::new(), |v| format!(" (normalised return {v:.3})"));
        println!(
            "{:<9} {} episodes: return {:.3}{normalised}, reward/step {:.4}, length {:.1} ({:.0} \
                sim steps), early end {:.1} %, success {} (code latch {})",
            actor.label(),
            r.episodes,
            r.mean_return,
            r.mean_reward_per_step,
            r.mean_episode_length,
            r.mean_episode_low_level_steps,
            100.0 * r.early_termination_rate,
            fin("success"),
            fin("success_code")
        );
        reports.insert(actor.label(), r);
    }
    let text = if a.baselines {
        serde_json::to_string_pretty(&reports)?
    } else {
        serde_json::to_string_pretty(reports.values().next().expect("one report"))?
    };
    skillmimic_core::tensorfile::write_bytes_atomic(&a.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    println!("wrote {}", a.out.display());
    Ok(())
}

/// `skillmimic eval --each-motion`: [`skillmimic_learn::tracking_eval`], one line per motion and
/// the totals, the JSON report in `out`.
pub fn each_motion(
    policy: &Policy,
    cfg: &TrainConfig,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    let r = skillmimic_learn::tracking_eval::evaluate_each_motion(policy, cfg)?;
    let line = |m: &BTreeMap<String, f64>| {
        let g = |k: &str| m.get(k).copied().unwrap_or(f64::NAN);
        format!(
            "E_g-mpjpe {:.1} mm, E_mpjpe {:.1} mm, E_vel {:.1} mm/frame, E_acc {:.1} mm/frame²",
            g("g_mpjpe_mm"),
            g("mpjpe_mm"),
            g("vel_err_mm"),
            g("acc_err_mm")
        )
    };
    for m in &r.per_motion {
        let verdict = if m.success { "tracked" } else { "failed" };
        println!("  {} ({} steps, {verdict}): {}", m.file.display(), m.steps, line(&m.metrics));
    }
    println!(
        "{} motions, success {:.1} % ({} of {}, {} m); all: {}",
        r.motions,
        100.0 * r.success_rate,
        r.successes,
        r.motions,
        r.success_distance,
        line(&r.metrics_all)
    );
    if r.successes > 0 {
        println!("successful motions: {}", line(&r.metrics_successful));
    }
    let text = serde_json::to_string_pretty(&r)?;
    skillmimic_core::tensorfile::write_bytes_atomic(out, text.as_bytes())
        .with_context(|| format!("cannot write {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}
