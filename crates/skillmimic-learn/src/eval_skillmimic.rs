//! SkillMimic's success rates as the paper measures them (seed 000 §6.2.4, the protocol of its
//! Tab. 3): per skill with a rule, a number of distinct test trials, each started from a
//! reference state of one of the skill's clips (reference state initialisation) and run for
//! 10 s with the skill's condition, then scored with [`V1Success::trial`].
//!
//! * Trials: the start states (clip c, frame f ∈ 2 … T_c − 2, the training range) of all the
//!   skill's clips, drawn without replacement with `seed`. Distinct starts make distinct
//!   trajectories, so no trial is a copy of another; a skill with fewer start states than asked
//!   uses them all and reports the smaller count.
//! * A trial runs [`TRIAL_FRAMES`] policy steps (10 s at 60 Hz; reference frames past the clip's
//!   end hold its last frame, `env.fixed_horizon`) with the policy's deterministic action unless
//!   `stochastic` (then each trial has its own stream of action noise). A fall (early
//!   termination) ends the trial: the rest of the 10 s counts as invalid dribble frames and fails
//!   the other rules. SkillMimic-V2's start generation (STG) and adaptive sampling (ATS) are off;
//!   a run with the State Transition Field keeps it on with noise probability 0, so that V2's
//!   get-up exemption from the fall rule applies as in training.
//! * 95 % interval of the mean over trials: Wilson's score interval for the 0/1 rules (pickup,
//!   layup, shot); mean ± 1.96 · s / √n, clamped to [0, 1], for the dribble fraction.
//! * Target height of layups and shots: the highest ball position of the skill's first clip
//!   ([`target_heights`]).

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use skillmimic_env::metrics::{FrameState, SkillKind, TRIAL_FRAMES, V1Success, skill_kind};
use skillmimic_env::{Env, EnvConfig, EnvError, SkillEnv, StateInit};
use skillmimic_motion::MotionLibrary;

use crate::eval::target_heights;
use crate::policy::{InferenceBuffers, Policy};

/// Settings of the evaluation.
#[derive(Clone, Debug, Serialize)]
pub struct SkillMimicEvalConfig {
    /// Trials per skill (fewer when the skill has fewer start states).
    pub trials: usize,
    /// Seed of the start draw (and of the action noise when `stochastic`).
    pub seed: u64,
    /// Sample actions instead of the deterministic action.
    pub stochastic: bool,
}

impl Default for SkillMimicEvalConfig {
    fn default() -> Self {
        Self { trials: 64, seed: 0, stochastic: false }
    }
}

/// One trial: its start and score.
#[derive(Clone, Debug, Serialize)]
pub struct Trial {
    pub clip: String,
    pub start_frame: usize,
    /// Score in [0, 1] (the dribble fraction, or 0/1).
    pub score: f64,
    /// Policy steps played (600 unless it fell).
    pub steps: usize,
}

/// One skill's success rate.
#[derive(Clone, Debug, Serialize)]
pub struct SkillSuccess {
    /// The paper's rule that scored it.
    pub rule: &'static str,
    pub trials: usize,
    /// Start states the skill's clips offer (the upper bound on distinct trials).
    pub start_states: usize,
    /// Mean score over the trials (the success rate).
    pub success_rate: f64,
    /// 95 % interval of the success rate.
    pub ci95: [f64; 2],
    /// Fraction of trials that ended by a fall before the 10 s.
    pub fall_rate: f64,
    pub per_trial: Vec<Trial>,
}

/// The evaluation's results, per skill label (`"013"`, …).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SkillMimicReport {
    pub config: Option<SkillMimicEvalConfig>,
    /// Policy steps per trial (600 = 10 s).
    pub trial_steps: usize,
    pub per_skill: BTreeMap<String, SkillSuccess>,
    /// Mean of the skills' success rates.
    pub mean: f64,
    /// Skills of the library without a rule in the paper.
    pub skills_without_rule: Vec<u32>,
}

/// The paper's wording of the rule of `kind`.
fn rule(kind: SkillKind) -> &'static str {
    match kind {
        SkillKind::Run => {
            "dribble: valid frames (root z > 0.5 m, ball-root distance < 1.5 m) / frames of 10 s"
        }
        SkillKind::Pickup => "pickup: ball above 1 m after 10 s",
        SkillKind::Layup | SkillKind::Shot => {
            "layup & shot: |max ball height - target height| < 0.1 m and root above 0.5 m"
        }
    }
}

/// Wilson's 95 % score interval of `k` successes in `n` trials.
pub fn wilson95(k: f64, n: f64) -> [f64; 2] {
    if n <= 0.0 {
        return [0.0, 1.0];
    }
    let (z, p) = (1.96_f64, k / n);
    let denom = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denom;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / denom;
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// Mean ± 1.96 · s / √n of `x` (sample standard deviation), clamped to [0, 1].
pub fn normal95(x: &[f64]) -> [f64; 2] {
    let n = x.len() as f64;
    if n < 2.0 {
        return [0.0, 1.0];
    }
    let m = x.iter().sum::<f64>() / n;
    let s = (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt();
    let half = 1.96 * s / n.sqrt();
    [(m - half).max(0.0), (m + half).min(1.0)]
}

/// Run the evaluation of `policy` on every skill of `lib` (see the module documentation);
/// `base` supplies the training environment's settings (scene, reward, history encoder).
pub fn evaluate_skillmimic(
    policy: &Policy,
    base: &EnvConfig,
    lib: &Arc<MotionLibrary>,
    cfg: &SkillMimicEvalConfig,
) -> Result<SkillMimicReport, EnvError> {
    let heights = target_heights(lib);
    let mut skills: Vec<u32> = lib.clips().iter().map(|m| m.clip.skill).collect();
    skills.sort_unstable();
    skills.dedup();
    let mut rep = SkillMimicReport {
        config: Some(cfg.clone()),
        trial_steps: TRIAL_FRAMES,
        ..Default::default()
    };
    for s in skills {
        let Some(kind) = skill_kind(s) else {
            rep.skills_without_rule.push(s);
            continue;
        };
        let mut starts: Vec<(usize, usize)> = (0..lib.len())
            .filter(|&c| lib.get(c).clip.skill == s)
            .flat_map(|c| (2..=lib.get(c).clip.num_frames - 2).map(move |f| (c, f)))
            .collect();
        let start_states = starts.len();
        starts.shuffle(&mut ChaCha8Rng::seed_from_u64(cfg.seed ^ u64::from(s)));
        starts.truncate(cfg.trials);
        let target = heights[&s];
        let per_trial: Vec<Trial> = starts
            .par_iter()
            .enumerate()
            .map(|(k, &(c, f))| trial(policy, base, lib, (c, f), kind, target, cfg, k as u64))
            .collect::<Result<_, _>>()?;
        let scores: Vec<f64> = per_trial.iter().map(|t| t.score).collect();
        let n = scores.len() as f64;
        let mean = scores.iter().sum::<f64>() / n.max(1.0);
        let ci95 = match kind {
            SkillKind::Run => normal95(&scores),
            _ => wilson95(scores.iter().sum(), n),
        };
        let falls = per_trial.iter().filter(|t| t.steps < TRIAL_FRAMES).count();
        rep.per_skill.insert(
            format!("{s:03}"),
            SkillSuccess {
                rule: rule(kind),
                trials: per_trial.len(),
                start_states,
                success_rate: mean,
                ci95,
                fall_rate: falls as f64 / n.max(1.0),
                per_trial,
            },
        );
    }
    let rates: Vec<f64> = rep.per_skill.values().map(|k| k.success_rate).collect();
    rep.mean =
        if rates.is_empty() { f64::NAN } else { rates.iter().sum::<f64>() / rates.len() as f64 };
    Ok(rep)
}

/// One trial from frame `f` of clip `c`; `k` = the trial's index (its action-noise stream).
#[allow(clippy::too_many_arguments)]
fn trial(
    policy: &Policy,
    base: &EnvConfig,
    lib: &MotionLibrary,
    (c, f): (usize, usize),
    kind: SkillKind,
    target: f64,
    cfg: &SkillMimicEvalConfig,
    k: u64,
) -> Result<Trial, EnvError> {
    let mut e = base.clone();
    e.num_envs = 1;
    e.threads = 1;
    e.state_init = StateInit::Frame(f);
    e.fixed_horizon = TRIAL_FRAMES;
    e.v2.stg.enabled = false;
    e.v2.ats.enabled = false;
    e.v2.stf.prob = 0.0;
    let clip = lib.get(c).clip.clone();
    let name = clip.name.clone();
    let mut env = SkillEnv::new(e, Arc::new(MotionLibrary::from_clips(vec![clip])?))?;
    env.set_autoreset(false);
    env.reset_all(Some(cfg.seed));
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed.wrapping_add(k).wrapping_mul(0x9e37_79b9));
    let (na, nout) = (env.act_dim(), policy.actor_outputs());
    let (mut buf, mut out, mut v, mut a, mut nlp) =
        (InferenceBuffers::default(), vec![0.0; nout], vec![0.0], vec![0.0; na], vec![0.0]);
    let mut tracker = V1Success::trial(kind, target, TRIAL_FRAMES);
    let mut steps = 0;
    while steps < TRIAL_FRAMES {
        policy.infer(&env.buffers().obs, 1, &mut buf, &mut out, &mut v, 1);
        if cfg.stochastic {
            policy.sample(&out, 1, &mut rng, &mut a, &mut nlp);
        } else {
            policy.mode(&out, 1, &mut a);
        }
        env.step(&a)?;
        steps += 1;
        tracker.update(&FrameState::of(&env.mujoco().env_state(0)));
        let b = env.buffers();
        if b.terminated[0] != 0 || b.truncated[0] != 0 {
            break;
        }
    }
    Ok(Trial { clip: name, start_frame: f, score: tracker.score(), steps })
}
