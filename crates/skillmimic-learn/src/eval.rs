//! Policy evaluation on the environment: imitation metrics (Acc, E_b-mpjpe, E_o-mpjpe, E_cg),
//! the normalised reward NR (mean per-step reward of finished episodes), and per-skill success
//! of SkillMimic (V1 scores) and SkillMimic-V2 (success rate), over a fixed number of seeded
//! episodes with the deterministic policy (action = μ) unless `stochastic` is set. Each
//! environment contributes its first ⌈episodes / N⌉ or ⌊episodes / N⌋ episodes, so the sample is
//! not biased towards episodes that end early.

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use skillmimic_env::metrics::{FrameState, ImitationMetrics, skill_kind};
use skillmimic_env::{Env, EnvConfig, EnvError, SkillEnv, StateInit};
use skillmimic_motion::MotionLibrary;
use std::sync::Arc;

pub use crate::eval_report::{
    EpisodeTally, EpisodeTracker, EvalReport, FrameQuartiles, SkillReport,
};
use crate::policy::{InferenceBuffers, Policy};

/// The SkillMimic-V2 success rate of `skill` in `r` (0 when the report has no episode of it or
/// the skill has no rule): SR, TSR and εNSR of [`evaluate_v2`].
pub fn v2_rate(r: &EvalReport, skill: u32) -> f64 {
    r.per_skill.get(&format!("{skill:03}")).and_then(|k| k.v2_success_rate).unwrap_or(0.0)
}

/// Highest ball height of a clip (the shot/layup target height).
fn max_ball_height(clip: &skillmimic_motion::Clip) -> f64 {
    clip.ball_pos.chunks_exact(3).map(|p| p[2] as f64).fold(f64::NEG_INFINITY, f64::max)
}

/// Target height per skill: the highest ball position of the skill's first clip ("clip 0" of the
/// reference metric).
pub fn target_heights(lib: &MotionLibrary) -> BTreeMap<u32, f64> {
    let mut m = BTreeMap::new();
    for c in 0..lib.len() {
        let clip = &lib.get(c).clip;
        m.entry(clip.skill).or_insert_with(|| max_ball_height(clip));
    }
    m
}

/// The imitation episode fields the evaluation reads ([`Env::episode_info`]: `clip`, `skill`,
/// `ref_frame`).
struct Fields {
    at: [Option<usize>; 3],
}

impl Fields {
    fn of(env: &dyn Env) -> Self {
        let names = &env.spec().episode_names;
        let at = ["clip", "skill", "ref_frame"].map(|k| names.iter().position(|n| *n == k));
        Self { at }
    }
    /// (clip, skill, clip frame) of environment `i`'s episode: clip and skill 0 and the frame
    /// `None` where the task does not report one.
    fn get(&self, env: &dyn Env, i: usize) -> (usize, u32, Option<usize>) {
        // evaluation only: one small vector per episode start and end
        let v = env.episode_info(i);
        let f = |k: Option<usize>| k.and_then(|k| v.get(k)).map(|&x| x.max(0) as usize);
        (f(self.at[0]).unwrap_or(0), f(self.at[1]).unwrap_or(0) as u32, f(self.at[2]))
    }
}

fn tracker(
    env: &dyn Env,
    fields: &Fields,
    i: usize,
    heights: &BTreeMap<u32, f64>,
) -> EpisodeTracker {
    let (clip, skill, _) = fields.get(env, i);
    let target = heights.get(&skill).copied().unwrap_or_else(|| {
        env.library().filter(|l| clip < l.len()).map_or(0.0, |l| max_ball_height(&l.get(clip).clip))
    });
    EpisodeTracker::new(skill, target)
}

/// Evaluate `policy` on `env` for `episodes` finished episodes.
pub fn evaluate(
    policy: &Policy,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    stochastic: bool,
    threads: usize,
) -> EvalReport {
    let heights = env.library().map(|l| target_heights(l)).unwrap_or_default();
    evaluate_with(policy, env, episodes, seed, stochastic, threads, &heights)
}

/// [`evaluate`] with the success-rule target heights given per skill (transition runs, whose
/// library holds only the source skill's clips).
pub fn evaluate_with(
    policy: &Policy,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    stochastic: bool,
    threads: usize,
    heights: &BTreeMap<u32, f64>,
) -> EvalReport {
    let (n, a) = (env.num_envs(), env.act_dim());
    env.set_autoreset(false);
    env.reset_all(Some(seed));
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let mut buf = InferenceBuffers::default();
    let (mut mu, mut values, mut actions, mut neglogp) =
        (vec![0.0; n * a], vec![0.0; n], vec![0.0; n * a], vec![0.0; n]);
    let fields = Fields::of(env);
    let mut trackers: Vec<EpisodeTracker> =
        (0..n).map(|i| tracker(env, &fields, i, heights)).collect();
    let mut restart = vec![false; n];
    let mut imitation = ImitationMetrics::default();
    let mut rep = EvalReport { seed, deterministic: !stochastic, ..Default::default() };
    let mut tally = EpisodeTally::default();
    // every environment contributes a fixed number of episodes (its first ones): counting the
    // first `episodes` to finish would favour short episodes (late start frames, early falls)
    let quota: Vec<usize> = (0..n).map(|i| episodes / n + usize::from(i < episodes % n)).collect();
    let mut finished = vec![0usize; n];
    while tally.episodes() < episodes {
        env.reset_done();
        for i in 0..n {
            // a finished episode was reset by `reset_done`: a new tracker for the new episode
            if restart[i] {
                trackers[i] = tracker(env, &fields, i, heights);
                restart[i] = false;
            }
        }
        policy.infer(&env.buffers().obs, n, &mut buf, &mut mu, &mut values, threads);
        if stochastic {
            policy.sample(&mu, n, &mut rng, &mut actions, &mut neglogp);
        } else {
            actions.copy_from_slice(&mu);
        }
        env.step(&actions).expect("policy actions are finite");
        let b = env.buffers();
        for i in 0..n {
            let fs = FrameState::of(&env.mujoco().env_state(i));
            let tr = &mut trackers[i];
            tr.step(&fs, b.reward[i]);
            let counted = finished[i] < quota[i];
            if counted {
                imitation.add(&b.metrics[i * 4..(i + 1) * 4]);
            }
            let done = b.terminated[i] != 0 || b.truncated[i] != 0;
            if done {
                finished[i] += 1;
                restart[i] = true;
            }
            if done && counted {
                let (_, skill, frame) = fields.get(env, i);
                tally.finish_at(skill, tr, b.terminated[i] != 0, frame);
            }
        }
    }
    rep.acc_percent = imitation.acc_percent();
    rep.e_b_mpjpe_mm = imitation.body_mpjpe_mm();
    rep.e_o_mpjpe_mm = imitation.ball_mpjpe_mm();
    rep.e_cg = imitation.cg_error();
    tally.write_into(&mut rep);
    rep
}

/// Settings of the SkillMimic-V2 evaluation.
#[derive(Clone, Debug, Serialize)]
pub struct V2EvalConfig {
    /// Episodes per skill (SR, εNSR, NR) and per skill pair (TSR).
    pub episodes: usize,
    /// Episode length of the success runs (600 = 10 s).
    pub horizon: usize,
    /// Reference frame every episode starts from.
    pub start_frame: usize,
    pub seed: u64,
    /// Environments run in parallel per case.
    pub num_envs: usize,
    /// SR and TSR episodes sample their actions (each its own noise), so that the episodes from
    /// the one start frame are distinct trials (SkillMimic-V2 averages over random trials); with
    /// the mean action they would be copies of one trajectory. εNSR's episodes differ by their
    /// perturbed starts and use the mean action.
    pub sampled_actions: bool,
}

impl Default for V2EvalConfig {
    fn default() -> Self {
        Self {
            episodes: 16,
            horizon: 600,
            start_frame: 2,
            seed: 0,
            num_envs: 16,
            sampled_actions: true,
        }
    }
}

/// SkillMimic-V2 evaluation results (success rates are fractions in [0, 1]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct V2Report {
    pub config: Option<V2EvalConfig>,
    /// SR per skill: start at the skill's own reference state, hold the skill for the horizon.
    pub sr: BTreeMap<String, f64>,
    /// TSR per "source->target": start from the source skill's reference state while the
    /// condition asks for the target skill; scored with the target skill's rule.
    pub tsr: BTreeMap<String, f64>,
    /// εNSR per skill: SR with every start perturbed in the training ε-neighbourhood (and
    /// connected to the clip, as in training).
    pub eps_nsr: BTreeMap<String, f64>,
    /// NR per skill: mean per-step imitation reward, episodes ending with the clip.
    pub nr: BTreeMap<String, f64>,
    pub sr_mean: f64,
    pub tsr_mean: f64,
    pub eps_nsr_mean: f64,
    pub nr_mean: f64,
    /// Skills without a success rule (only NR is reported for them).
    pub skills_without_rule: Vec<u32>,
    /// Distinct trajectories among each case's episodes (`sr/<skill>`, `tsr/<source>-><target>`,
    /// `eps_nsr/<skill>`): equal to `episodes` when every trial is distinct.
    pub distinct: BTreeMap<String, usize>,
}

fn mean_of(m: &BTreeMap<String, f64>) -> f64 {
    if m.is_empty() { f64::NAN } else { m.values().sum::<f64>() / m.len() as f64 }
}

/// Run the V2 metrics for every skill of `lib` with a success rule (reference-facts §9.8):
/// SR, TSR (every other skill of the library as source), εNSR and NR over `cfg.episodes` trials
/// per case, fixed seeds; SR and TSR sample their actions unless `cfg.sampled_actions` is off
/// (see there), εNSR and NR use the mean action. `distinct` reports how many of each case's
/// episodes are distinct trajectories. `base` supplies the environment settings of training (scene, reward, history
/// encoder, ε of the State Transition Field); STG and ATS are off during evaluation.
pub fn evaluate_v2(
    policy: &Policy,
    base: &EnvConfig,
    lib: &Arc<MotionLibrary>,
    cfg: &V2EvalConfig,
    threads: usize,
) -> Result<V2Report, EnvError> {
    let heights = target_heights(lib);
    let mut skills: Vec<u32> = (0..lib.len()).map(|c| lib.get(c).clip.skill).collect();
    skills.sort_unstable();
    skills.dedup();
    let subset = |s: u32| -> Result<Arc<MotionLibrary>, EnvError> {
        let clips = (0..lib.len())
            .filter(|&c| lib.get(c).clip.skill == s)
            .map(|c| lib.get(c).clip.clone())
            .collect();
        Ok(Arc::new(MotionLibrary::from_clips(clips)?))
    };
    let env_cfg = |horizon: usize, noise: bool| {
        let mut c = base.clone();
        c.num_envs = cfg.num_envs.min(cfg.episodes).max(1);
        c.state_init = StateInit::Frame(cfg.start_frame);
        c.fixed_horizon = horizon;
        if horizon == 0 {
            c.episode_length = usize::MAX / 4; // the clip end decides
        }
        c.v2.stg.enabled = false;
        c.v2.ats.enabled = false;
        // the STF stays on (with p_n = 0 for noise-free starts) so that every case is a
        // SkillMimic-V2 run: get-up episodes are then exempt from early termination, as in
        // training (`tasks::imitation`), whichever V2 parts the policy was trained with
        c.v2.stf.enabled = true;
        c.v2.stf.prob = if noise { 1.0 } else { 0.0 };
        c
    };
    let run = |c: EnvConfig,
               l: Arc<MotionLibrary>,
               over: Option<u32>,
               sampled: bool|
     -> Result<EvalReport, EnvError> {
        let mut env = SkillEnv::new(c, l)?;
        env.set_skill_override(over);
        Ok(evaluate_with(policy, &mut env, cfg.episodes, cfg.seed, sampled, threads, &heights))
    };
    let distinct = |r: &EvalReport, s: u32| {
        r.per_skill.get(&format!("{s:03}")).map_or(0, |k| k.distinct_episodes)
    };
    let sampled = cfg.sampled_actions;
    let mut rep = V2Report { config: Some(cfg.clone()), ..Default::default() };
    for &s in &skills {
        let own = subset(s)?;
        rep.nr.insert(format!("{s:03}"), run(env_cfg(0, false), own.clone(), None, false)?.nr);
        if skill_kind(s).is_none() {
            rep.skills_without_rule.push(s);
            continue;
        }
        let r = run(env_cfg(cfg.horizon, false), own.clone(), None, sampled)?;
        rep.sr.insert(format!("{s:03}"), v2_rate(&r, s));
        rep.distinct.insert(format!("sr/{s:03}"), distinct(&r, s));
        let r = run(env_cfg(cfg.horizon, true), own, None, false)?;
        rep.eps_nsr.insert(format!("{s:03}"), v2_rate(&r, s));
        rep.distinct.insert(format!("eps_nsr/{s:03}"), distinct(&r, s));
        for &src in skills.iter().filter(|&&x| x != s) {
            let r = run(env_cfg(cfg.horizon, false), subset(src)?, Some(s), sampled)?;
            rep.tsr.insert(format!("{src:03}->{s:03}"), v2_rate(&r, s));
            rep.distinct.insert(format!("tsr/{src:03}->{s:03}"), distinct(&r, s));
        }
    }
    rep.sr_mean = mean_of(&rep.sr);
    rep.tsr_mean = mean_of(&rep.tsr);
    rep.eps_nsr_mean = mean_of(&rep.eps_nsr);
    rep.nr_mean = mean_of(&rep.nr);
    Ok(rep)
}
