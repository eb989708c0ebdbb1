//! Active skill learning with generative adaptive sampling (ModSkill §3.4;
//! modskill-tokenhsi-facts §1.6) for the `tracking` task: evaluate every clip, hand the failed
//! ones to a generator (`skillmimic_motion::generate`), keep the generated clips that pass the
//! validity filter (written to `<run.out_dir>/generated/`), and raise the sampling weight of the
//! failed clips; [`apply`] then rebuilds the trainer's environment over the grown library.
//!
//! * Evaluation of a clip: one episode from its frame 0 with the policy's deterministic actions,
//!   terminated beyond `env.tracking.success_distance` (0.5 m); success = the clip's end reached.
//!   Clips of the built-in demo (no file) are skipped.
//! * Weights (`env.tracking.clip_weights`): in the generative mode (the default) a failed clip's
//!   multiplier is multiplied by `failure_weight` each round it fails (1 by default: the released
//!   generative mode leaves the weights alone); generated clips start at 1. The released `hard`
//!   and `soft` modes generate nothing and set the weights from the failures
//!   ([`released_weights`]).
//! * Rejected clips are logged with the filter's reason and listed in the report.
//! * Optional motion-prior filter (`disc_score_min` > 0, the released code's rule): the generated
//!   clip is posed in the scene, its AMP features (`skillmimic_env::amp`) cut into every full
//!   window (`ppo.amp.window` frames; a shorter clip gives one padded window), and the clip is
//!   kept when the mean of sigmoid(D(window)) reaches the bound ([`disc_score`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rand::{RngCore, SeedableRng};
use skillmimic_env::amp::{FEATURE_DIM, clip_features, window};
use skillmimic_motion::generate::{ExternalCommand, Generator, ModelFree, check_validity};
use skillmimic_motion::library::find_clip_files;
use skillmimic_motion::{Clip, MotionLibrary};
use skillmimic_sim::Scene;

use crate::amp::Discriminator;

use crate::config::TrainConfig;
pub use crate::config_active::{ActiveConfig, ActiveMode};
use crate::error::{LearnError, io};
use crate::policy::Policy;
use crate::trainer::Trainer;
use skillmimic_env::tasks::tracking::config::TrackingConfig;

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

/// Whether `policy` tracks the clip file `path` to its end (see the module doc; the
/// per-motion evaluation of [`crate::tracking_eval`]).
pub fn evaluate_clip(policy: &Policy, cfg: &TrainConfig, path: &Path) -> Result<bool, LearnError> {
    // the run's task: one that declares active learning (checked by `ActiveConfig::validate`)
    Ok(crate::tracking_eval::evaluate_motion(policy, cfg, path)?.success)
}

/// The motion prior's score of a clip: mean of sigmoid(D) over its windows (module doc).
pub fn disc_score(
    disc: &mut Discriminator,
    clip: &Clip,
    cfg: &TrainConfig,
) -> Result<f64, LearnError> {
    let cfg_err = |e: String| LearnError::Config(format!("scoring clip '{}': {e}", clip.name));
    let lib = MotionLibrary::from_clips(vec![clip.clone()]).map_err(|e| cfg_err(e.to_string()))?;
    let scene = Arc::new(
        Scene::new(
            skillmimic_env::registry::scene_options(&cfg.env)
                .map_err(|e| cfg_err(e.to_string()))?,
        )
        .map_err(|e| cfg_err(e.to_string()))?,
    );
    let feats = clip_features(scene, &lib).map_err(|e| cfg_err(e.to_string()))?.remove(0);
    let (k, t) = (cfg.ppo.amp.window, clip.num_frames);
    let ends: Vec<usize> = if t >= k { (k - 1..t).collect() } else { vec![t - 1] };
    let mut x = vec![0.0f32; ends.len() * k * FEATURE_DIM];
    for (row, &end) in x.chunks_exact_mut(k * FEATURE_DIM).zip(&ends) {
        window(&feats, end, k, row);
    }
    let logits = disc.logits(&x, ends.len());
    Ok(logits.iter().map(|&l| 1.0 / (1.0 + (-(l as f64)).exp())).sum::<f64>() / ends.len() as f64)
}

/// One round over the clips of `cfg.env.motion` (see the module doc); `disc` = the run's motion
/// prior (needed when `a.disc_score_min` > 0).
pub fn round(
    policy: &Policy,
    cfg: &TrainConfig,
    generator: &mut dyn Generator,
    a: &ActiveConfig,
    mut disc: Option<&mut Discriminator>,
    rng: &mut dyn RngCore,
) -> Result<RoundReport, LearnError> {
    if a.disc_score_min > 0.0 && disc.is_none() {
        return Err(LearnError::Config(
            "config field 'run.active.disc_score_min': the \
            discriminator filter needs the motion prior (--set ppo.amp.enabled=true)"
                .into(),
        ));
    }
    let mut files = Vec::new();
    for p in cfg.env.motion.iter().filter(|p| p.as_os_str() != skillmimic_env::BUILTIN_DEMO) {
        files.extend(find_clip_files(p).map_err(|e| LearnError::Config(e.to_string()))?);
    }
    let clips: Vec<Clip> = files
        .iter()
        .map(|f| Clip::load_any(f))
        .collect::<Result<_, _>>()
        .map_err(|e| LearnError::Config(e.to_string()))?;
    let dir = cfg.run.out_dir.join("generated");
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let mut r = RoundReport {
        clip_weights: cfg.env.table::<TrackingConfig>().clip_weights.clone(),
        ..Default::default()
    };
    for (c, path) in clips.iter().zip(&files) {
        r.evaluated += 1;
        if evaluate_clip(policy, cfg, path)? {
            continue;
        }
        r.failed.push(c.name.clone());
        if a.mode != ActiveMode::Generative {
            continue;
        }
        *r.clip_weights.entry(c.name.clone()).or_insert(1.0) *= a.failure_weight;
        let made =
            generator.generate(c, &clips, rng).map_err(|e| LearnError::Config(e.to_string()))?;
        tracing::info!(
            "active learning: '{}' failed; {} made {} clip(s)",
            c.name,
            generator.name(),
            made.len()
        );
        for g in made {
            let mut verdict =
                check_validity(&g, a.floor_tol, a.max_joint_speed).map_err(|why| why.to_string());
            if let (Ok(()), Some(d)) = (&verdict, disc.as_deref_mut())
                && a.disc_score_min > 0.0
            {
                let score = disc_score(d, &g, cfg)?;
                if score < a.disc_score_min {
                    verdict = Err(format!(
                        "clip '{}': motion-prior score {score:.3} is below \
                            run.active.disc_score_min = {}",
                        g.name, a.disc_score_min
                    ));
                }
            }
            match verdict {
                Err(why) => {
                    tracing::info!("active learning: rejected {why}");
                    r.rejected.push((g.name.clone(), why));
                }
                Ok(()) => {
                    let file = dir.join(format!("{}.safetensors", g.name));
                    g.save(&file).map_err(io(&file))?;
                    r.accepted.push((g.name.clone(), file));
                }
            }
        }
    }
    if a.mode != ActiveMode::Generative {
        let log = cfg.run.out_dir.join("active.jsonl");
        let earlier = crate::active_resume::failure_counts(&log)?;
        let names: Vec<String> = clips.iter().map(|c| c.name.clone()).collect();
        r.clip_weights = released_weights(a.mode, &names, &r.failed, &earlier);
    }
    Ok(r)
}

/// The sampling weights after a round of the released `hard` or `soft` mode (see
/// [`ActiveConfig::mode`]): `names` the evaluated clips, `failed` this round's failed ones,
/// `earlier` the failures of each clip in the earlier rounds. No failure: every clip 1 (an empty
/// map).
pub fn released_weights(
    mode: ActiveMode,
    names: &[String],
    failed: &[String],
    earlier: &BTreeMap<String, usize>,
) -> BTreeMap<String, f64> {
    if failed.is_empty() {
        return BTreeMap::new();
    }
    let now = |n: &String| usize::from(failed.contains(n));
    names
        .iter()
        .map(|n| {
            let w = match mode {
                ActiveMode::Hard => now(n),
                _ => earlier.get(n).copied().unwrap_or(0) + now(n),
            };
            (n.clone(), w as f64)
        })
        .collect()
}

/// The generator named by `run.active` (`work_dir`: the external command's scratch folder).
pub fn generator(a: &ActiveConfig, work_dir: &Path) -> Box<dyn Generator> {
    match a.generator.as_str() {
        "command" => Box::new(ExternalCommand::new(
            PathBuf::from(&a.command[0]),
            a.command[1..].to_vec(),
            work_dir.to_path_buf(),
        )),
        name => match skillmimic_motion::generate::registered(name) {
            Some(factory) => factory(work_dir),
            None => Box::new(ModelFree::default()),
        },
    }
}

/// Active learning rounds every `run.active.every` iterations of a training run (the runner's
/// iteration hook).
pub struct Rounds {
    every: u64,
}

impl Rounds {
    /// The hook, when `run.active.enabled`.
    pub fn for_config(cfg: &crate::config::TrainConfig) -> Option<Self> {
        cfg.run.active.enabled.then_some(Self { every: cfg.run.active.every as u64 })
    }
}

impl crate::trainer::IterationHook for Rounds {
    fn after_iteration(&mut self, t: &mut Trainer) -> Result<(), LearnError> {
        if t.progress.iteration.is_multiple_of(self.every) {
            train_round(t)?;
        }
        Ok(())
    }

    /// The round of the checkpoint's iteration when it is due and `active.jsonl` does not hold
    /// it (the checkpoint was written without the hooks: an interrupt, or the end of a shorter
    /// run), so that the resumed run does what the uninterrupted one did.
    fn on_resume(&mut self, t: &mut Trainer) -> Result<(), LearnError> {
        let it = t.progress.iteration;
        let log = t.cfg.run.out_dir.join("active.jsonl");
        if it > 0 && it.is_multiple_of(self.every) && !crate::active_resume::round_logged(&log, it)?
        {
            train_round(t)?;
        }
        Ok(())
    }
}

/// A round inside training (rank 0 of one process): evaluate, generate, re-weight, rebuild the
/// environment; the report is appended to `<run.out_dir>/active.jsonl`.
pub fn train_round(t: &mut Trainer) -> Result<RoundReport, LearnError> {
    let a = t.cfg.run.active.clone();
    let out = t.cfg.run.out_dir.clone();
    let mut g = generator(&a, &out.join("generator_work"));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
        t.cfg.run.seed ^ t.progress.iteration.wrapping_mul(0x9e37_79b9_7f4a_7c15),
    );
    let (policy, cfg, amp) = t.policy_and_extension_mut::<crate::amp_reward::AmpReward>();
    let report = round(policy, cfg, g.as_mut(), &a, amp.map(|x| x.disc_mut()), &mut rng)?;
    apply(t, &report)?;
    let path = out.join("active.jsonl");
    let line = serde_json::json!({"iteration": t.progress.iteration, "report": &report});
    use std::io::Write;
    let mut f =
        std::fs::OpenOptions::new().create(true).append(true).open(&path).map_err(io(&path))?;
    writeln!(f, "{line}").map_err(io(&path))?;
    tracing::info!(
        "active learning at iteration {}: {} clips evaluated, {} failed, {} generated clips \
            joined, {} rejected",
        t.progress.iteration,
        report.evaluated,
        report.failed.len(),
        report.accepted.len(),
        report.rejected.len()
    );
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
    t.cfg.env.table_mut::<TrackingConfig>().clip_weights = report.clip_weights.clone();
    t.rebuild_env()
}
