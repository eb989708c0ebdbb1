//! Active skill learning with generative adaptive sampling (ModSkill §3.4;
//! modskill-tokenhsi-facts §1.6) for the `tracking` task: evaluate every clip, hand the failed
//! ones to a generator (`skillmimic_motion::generate`), keep the generated clips that pass the
//! validity filter (written to `<run.out_dir>/generated/`), and raise the sampling weight of the
//! failed clips; [`apply`] then rebuilds the trainer's environment over the grown library.
//!
//! * Evaluation of a clip: one episode from its frame 0 with the policy's deterministic actions,
//!   terminated beyond `env.tracking.success_distance` (0.5 m); success = the clip's end reached.
//!   Clips of the built-in demo (no file) are skipped.
//! * Weights (`env.tracking.clip_weights`): a failed clip's multiplier is multiplied by
//!   `failure_weight` each round it fails; generated clips start at 1.
//! * Rejected clips are logged with the filter's reason and listed in the report.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};


use rand::RngCore;
use skillmimic_motion::Clip;
use skillmimic_motion::library::find_clip_files;
use rand::SeedableRng;
use skillmimic_motion::generate::{ExternalCommand, Generator, ModelFree, check_validity};

use crate::config::TrainConfig;
pub use crate::config_active::ActiveConfig;
use crate::error::{LearnError, io};
use crate::policy::{InferenceBuffers, Policy};
use crate::trainer::Trainer;

/// What a round did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RoundReport {
    pub evaluated: usize,
    pub failed: Vec<String>,
    /// Generated clips that joined (name, file).
    pub accepted: Vec<(String, PathBuf)>,
    /// Generated clips refused (name, reason).
    pub rejected: Vec<(String, String)>,
    /// The new `env.tracking.clip_weights`.
    pub clip_weights: BTreeMap<String, f64>,
}

/// Whether `policy` tracks the clip file `path` to its end (see the module doc).
pub fn evaluate_clip(policy: &Policy, cfg: &TrainConfig, path: &Path) -> Result<bool, LearnError> {
    let mut e = cfg.env.clone();
    e.task = "tracking".into();
    e.motion = vec![path.to_path_buf()];
    e.num_envs = 1;
    e.threads = 1;
    e.tracking.random_start = false;
    e.tracking.termination_distance = e.tracking.success_distance;
    e.tracking.clip_weights.clear();
    let mut env = skillmimic_env::registry::make(&e)?;
    env.reset_all(Some(0));
    let (mut buf, mut mu, mut v, mut a) = (InferenceBuffers::default(), vec![0.0; policy.actor_outputs()], vec![0.0], vec![0.0; env.act_dim()]);
    for _ in 0..=env.spec().max_episode_steps {
        policy.infer(&env.buffers().obs, 1, &mut buf, &mut mu, &mut v, 1);
        policy.mode(&mu, 1, &mut a);
        env.step(&a)?;
        let b = env.buffers();
        if b.terminated[0] != 0 || b.truncated[0] != 0 {
            let success = b.metrics[4] == 1.0;
            return Ok(success);
        }
    }
    Ok(false)
}

/// One round over the clips of `cfg.env.motion` (see the module doc).
pub fn round(policy: &Policy, cfg: &TrainConfig, generator: &mut dyn Generator, a: &ActiveConfig, rng: &mut dyn RngCore) -> Result<RoundReport, LearnError> {
    let mut files = Vec::new();
    for p in cfg.env.motion.iter().filter(|p| p.as_os_str() != skillmimic_env::BUILTIN_DEMO) {
        files.extend(find_clip_files(p).map_err(|e| LearnError::Config(e.to_string()))?);
    }
    let clips: Vec<Clip> = files.iter().map(|f| Clip::load_any(f)).collect::<Result<_, _>>().map_err(|e| LearnError::Config(e.to_string()))?;
    let dir = cfg.run.out_dir.join("generated");
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let mut r = RoundReport { clip_weights: cfg.env.tracking.clip_weights.clone(), ..Default::default() };
    for (c, path) in clips.iter().zip(&files) {
        r.evaluated += 1;
        if evaluate_clip(policy, cfg, path)? {
            continue;
        }
        r.failed.push(c.name.clone());
        *r.clip_weights.entry(c.name.clone()).or_insert(1.0) *= a.failure_weight;
        let made = generator.generate(c, &clips, rng).map_err(|e| LearnError::Config(e.to_string()))?;
        tracing::info!("active learning: '{}' failed; {} made {} clip(s)", c.name, generator.name(), made.len());
        for g in made {
            match check_validity(&g, a.floor_tol, a.max_joint_speed) {
                Err(why) => {
                    tracing::info!("active learning: rejected {why}");
                    r.rejected.push((g.name.clone(), why.to_string()));
                }
                Ok(()) => {
                    let file = dir.join(format!("{}.safetensors", g.name));
                    g.save(&file).map_err(io(&file))?;
                    r.accepted.push((g.name.clone(), file));
                }
            }
        }
    }
    Ok(r)
}

/// The generator named by `run.active` (`work_dir`: the external command's scratch folder).
pub fn generator(a: &ActiveConfig, work_dir: &Path) -> Box<dyn Generator> {
    match a.generator.as_str() {
        "command" => Box::new(ExternalCommand::new(PathBuf::from(&a.command[0]), a.command[1..].to_vec(), work_dir.to_path_buf())),
        _ => Box::new(ModelFree::default()),
    }
}

/// A round inside training (rank 0 of one process): evaluate, generate, re-weight, rebuild the
/// environment; the report is appended to `<run.out_dir>/active.jsonl`.
pub fn train_round(t: &mut Trainer) -> Result<RoundReport, LearnError> {
    let a = t.cfg.run.active.clone();
    let out = t.cfg.run.out_dir.clone();
    let mut g = generator(&a, &out.join("generator_work"));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(t.cfg.run.seed ^ t.progress.iteration.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let report = round(&t.policy, &t.cfg, g.as_mut(), &a, &mut rng)?;
    apply(t, &report)?;
    let path = out.join("active.jsonl");
    let line = serde_json::json!({"iteration": t.progress.iteration, "report": &report});
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new().create(true).append(true).open(&path).map_err(io(&path))?;
    writeln!(f, "{line}").map_err(io(&path))?;
    tracing::info!("active learning at iteration {}: {} clips evaluated, {} failed, {} generated clips joined, {} rejected", t.progress.iteration, report.evaluated, report.failed.len(), report.accepted.len(), report.rejected.len());
    Ok(report)
}

/// Grow the run's library with the round's clips and weights, rebuild the environment (fresh
/// episodes) and refresh the effective configuration saved with the checkpoints.
pub fn apply(t: &mut Trainer, report: &RoundReport) -> Result<(), LearnError> {
    if t.shard.world > 1 {
        return Err(LearnError::Config("active skill learning runs in one process for now".into()));
    }
    let dir = t.cfg.run.out_dir.join("generated");
    if !report.accepted.is_empty() && !t.cfg.env.motion.contains(&dir) {
        t.cfg.env.motion.push(dir);
    }
    t.cfg.env.tracking.clip_weights = report.clip_weights.clone();
    t.rebuild_env()
}
