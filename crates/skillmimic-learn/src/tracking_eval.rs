//! The tracking evaluation of PHC and ModSkill (`skillmimic eval --each-motion`): every motion of
//! the evaluated set played **once**, from its frame 0 to its end, with the policy's
//! deterministic actions; a motion succeeds when the mean distance of the judged bodies never
//! exceeds `env.tracking.success_distance` (0.5 m). Reported as the released player prints it:
//!
//! * `success_rate`: successful motions / motions (each motion counts once, whatever its
//!   length; repeated identical rollouts of a deterministic policy are never counted twice);
//! * `metrics_all`: the per-step metrics (E_g-mpjpe, E_mpjpe in mm, velocity error in mm/frame,
//!   acceleration error in mm/frame²) averaged over every evaluated step of every motion, the
//!   pooling of the released `compute_metrics_lite` means, with its bookkeeping: the positions
//!   after steps 1 … N of a motion give N position errors, N − 1 velocity errors (from step 2 on)
//!   and N − 2 acceleration errors (from step 3 on), none against the reset state;
//! * `metrics_successful`: the same over the successful motions only (the released "Succ" line);
//! * `motions`: one row per motion (file, steps, success, its own means).
//!
//! Difference from the released player, by choice: a failed motion ends at its failure (the
//! released one keeps stepping it to the motion's end and pools those frames into "All").

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;
use skillmimic_env::tasks::tracking::config::TrackingConfig;
use skillmimic_env::tasks::tracking::formulas::METRICS;
use skillmimic_env::tasks::tracking::motion::MOTION_EXTENSIONS;
use skillmimic_motion::library::find_files;

use crate::config::TrainConfig;
use crate::error::LearnError;
use crate::policy::{InferenceBuffers, Policy};

/// One motion's result.
#[derive(Clone, Debug, Serialize)]
pub struct MotionResult {
    pub file: PathBuf,
    /// Policy steps played (the motion's frames − 1 when it succeeded).
    pub steps: usize,
    pub success: bool,
    /// The means of the task's error metrics over this motion's values (mm, mm/frame, mm/frame²;
    /// the success flag is `success`).
    pub metrics: BTreeMap<String, f64>,
    /// How many values each mean is over (velocity: steps − 1, acceleration: steps − 2).
    pub values: BTreeMap<String, usize>,
}

/// The first step whose value of a metric counts (the released bookkeeping, module doc).
fn first_counted(metric: &str) -> usize {
    match metric {
        m if m == METRICS[2] => 2, // velocity error
        m if m == METRICS[3] => 3, // acceleration error
        _ => 1,
    }
}

/// Results of [`evaluate_each_motion`] (see the module doc).
#[derive(Clone, Debug, Serialize)]
pub struct TrackingReport {
    /// "phc": every motion once, frame 0, deterministic actions.
    pub protocol: &'static str,
    /// Motions evaluated.
    pub motions: usize,
    pub successes: usize,
    pub success_rate: f64,
    /// The success threshold (m) the episodes were terminated and judged at.
    pub success_distance: f64,
    /// Per-step metric means over every step of every motion.
    pub metrics_all: BTreeMap<String, f64>,
    /// Per-step metric means over the steps of the successful motions (empty without one).
    pub metrics_successful: BTreeMap<String, f64>,
    pub per_motion: Vec<MotionResult>,
}

/// The motion files of `cfg.env.motion` (clip files and AMASS `.npz`), in path order.
pub fn motion_files(cfg: &TrainConfig) -> Result<Vec<PathBuf>, LearnError> {
    let mut files = Vec::new();
    for p in &cfg.env.motion {
        if p.as_os_str() == skillmimic_env::BUILTIN_DEMO {
            return Err(LearnError::Config(format!(
                "config field 'env.motion': the per-motion evaluation needs motion files; '{}' \
                 has none (give --motion FILE or DIR)",
                p.display()
            )));
        }
        files.extend(
            find_files(p, &MOTION_EXTENSIONS).map_err(|e| LearnError::Config(e.to_string()))?,
        );
    }
    if files.is_empty() {
        return Err(LearnError::Config(format!(
            "config field 'env.motion': no motion files under {:?}",
            cfg.env.motion
        )));
    }
    Ok(files)
}

/// The run's environment configuration reduced to one environment playing `file` once from
/// frame 0, terminated beyond the success distance (shared with active skill learning).
pub fn one_motion_config(cfg: &TrainConfig, file: &Path) -> skillmimic_env::EnvConfig {
    let mut e = cfg.env.clone();
    e.motion = vec![file.to_path_buf()];
    e.num_envs = 1;
    e.threads = 1;
    let t = e.table_mut::<TrackingConfig>();
    t.random_start = false;
    t.termination_distance = t.success_distance;
    t.clip_weights.clear();
    e
}

/// Play `file` once with `policy`'s deterministic actions (see the module doc).
pub fn evaluate_motion(
    policy: &Policy,
    cfg: &TrainConfig,
    file: &Path,
) -> Result<MotionResult, LearnError> {
    let mut env = skillmimic_env::registry::make(&one_motion_config(cfg, file))?;
    let spec = env.spec().clone();
    if (policy.obs_dim(), policy.act_dim()) != (spec.obs_dim, spec.act_dim()) {
        return Err(LearnError::Config(format!(
            "the policy takes observations of {} and gives actions of {}; the tracking task on \
             '{}' has {} and {}",
            policy.obs_dim(),
            policy.act_dim(),
            file.display(),
            spec.obs_dim,
            spec.act_dim()
        )));
    }
    env.set_autoreset(false);
    env.reset_all(Some(0));
    let (mut buf, mut out, mut v) =
        (InferenceBuffers::default(), vec![0.0; policy.actor_outputs()], vec![0.0]);
    let mut actions = vec![0.0; spec.act_dim()];
    let names = &spec.metric_names;
    let (mut sums, mut values) = (vec![0.0f64; names.len()], vec![0usize; names.len()]);
    let (mut steps, mut success) = (0, false);
    while steps <= spec.max_episode_steps {
        policy.infer(&env.buffers().obs, 1, &mut buf, &mut out, &mut v, 1);
        policy.mode(&out, 1, &mut actions);
        env.step(&actions)?;
        steps += 1;
        let b = env.buffers();
        for (k, _) in names.iter().enumerate().filter(|(_, n)| steps >= first_counted(n)) {
            sums[k] += b.metrics[k] as f64;
            values[k] += 1;
        }
        if b.terminated[0] != 0 || b.truncated[0] != 0 {
            success =
                names.iter().position(|n| n == METRICS[4]).is_some_and(|k| b.metrics[k] == 1.0);
            break;
        }
    }
    let errors = || names.iter().enumerate().filter(|(_, n)| *n != METRICS[4]);
    Ok(MotionResult {
        file: file.to_path_buf(),
        steps,
        success,
        metrics: errors().map(|(k, n)| (n.clone(), sums[k] / values[k].max(1) as f64)).collect(),
        values: errors().map(|(k, n)| (n.clone(), values[k])).collect(),
    })
}

/// The means of the metrics of `rows` over all their values (each row's mean weighted by its
/// count of values: the released pooling over every frame of every motion).
fn pooled<'a>(rows: impl Iterator<Item = &'a MotionResult>) -> BTreeMap<String, f64> {
    let mut sums: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for r in rows {
        for (k, v) in &r.metrics {
            let n = r.values.get(k).copied().unwrap_or(0);
            let s = sums.entry(k.clone()).or_default();
            *s = (s.0 + v * n as f64, s.1 + n);
        }
    }
    sums.into_iter().map(|(k, (s, n))| (k, s / n.max(1) as f64)).collect()
}

/// Every motion of `cfg.env.motion` once (module doc); motions run in parallel on the current
/// rayon pool, one environment each.
pub fn evaluate_each_motion(
    policy: &Policy,
    cfg: &TrainConfig,
) -> Result<TrackingReport, LearnError> {
    let entry = skillmimic_env::registry::entry(&cfg.env.task);
    if entry.map(|e| e.evaluation) != Some(skillmimic_env::registry::Evaluation::Tracking) {
        return Err(LearnError::Config(format!(
            "the per-motion evaluation is for motion tracking tasks; this run's task is '{}'",
            cfg.env.task
        )));
    }
    let files = motion_files(cfg)?;
    let per_motion: Vec<MotionResult> =
        files.par_iter().map(|f| evaluate_motion(policy, cfg, f)).collect::<Result<_, _>>()?;
    let successes = per_motion.iter().filter(|r| r.success).count();
    Ok(TrackingReport {
        protocol: "phc",
        motions: per_motion.len(),
        successes,
        success_rate: successes as f64 / per_motion.len() as f64,
        success_distance: cfg.env.table::<TrackingConfig>().success_distance,
        metrics_all: pooled(per_motion.iter()),
        metrics_successful: pooled(per_motion.iter().filter(|r| r.success)),
        per_motion,
    })
}
