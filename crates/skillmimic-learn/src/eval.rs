//! Policy evaluation on the environment: imitation metrics (Acc, E_b-mpjpe, E_o-mpjpe, E_cg),
//! the normalised reward NR (mean per-step reward of finished episodes), and per-skill success
//! of SkillMimic (V1 scores) and SkillMimic-V2 (success rate), over a fixed number of seeded
//! episodes with the deterministic policy (action = μ) unless `stochastic` is set.

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use skillmimic_env::metrics::{FrameState, ImitationMetrics, V1Success, V2Success, skill_kind};
use skillmimic_env::SkillEnv;
use skillmimic_sim::BALL;

use crate::policy::{InferenceBuffers, Policy};

/// Per-skill results.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SkillReport {
    pub episodes: usize,
    /// Mean episode length (steps).
    pub mean_length: f64,
    /// Mean per-step reward of the skill's episodes.
    pub nr: f64,
    /// Fraction of episodes that ended early (fall).
    pub fall_rate: f64,
    /// SkillMimic success score (dribble fraction or 0/1), mean over episodes; null if the skill
    /// has no rule.
    pub v1_score: Option<f64>,
    /// SkillMimic-V2 success rate; null if the skill has no rule.
    pub v2_success_rate: Option<f64>,
}

/// Evaluation results (the `eval` command's JSON).
#[derive(Clone, Debug, Default, Serialize)]
pub struct EvalReport {
    pub episodes: usize,
    pub seed: u64,
    pub deterministic: bool,
    /// Acc in percent (ball error < 0.2 m ∧ body error < 0.1 m ∧ contact graph correct).
    pub acc_percent: f64,
    pub e_b_mpjpe_mm: f64,
    pub e_o_mpjpe_mm: f64,
    pub e_cg: f64,
    /// Mean per-step reward over finished episodes.
    pub nr: f64,
    pub mean_episode_length: f64,
    pub fall_rate: f64,
    pub per_skill: BTreeMap<String, SkillReport>,
}

struct Tracker {
    v1: Option<V1Success>,
    v2: Option<V2Success>,
    steps: usize,
    reward: f64,
}

fn tracker(env: &SkillEnv, i: usize) -> Tracker {
    let ep = env.episode(i);
    let clip = &env.library().get(ep.clip).clip;
    let target = clip.ball_pos.chunks_exact(3).map(|p| p[2] as f64).fold(f64::NEG_INFINITY, f64::max);
    let kind = skill_kind(ep.skill);
    Tracker { v1: kind.map(|k| V1Success::new(k, target)), v2: kind.map(|k| V2Success::new(k, target)), steps: 0, reward: 0.0 }
}

/// Evaluate `policy` on `env` for `episodes` finished episodes.
pub fn evaluate(policy: &Policy, env: &mut SkillEnv, episodes: usize, seed: u64, stochastic: bool, threads: usize) -> EvalReport {
    let (n, a) = (env.num_envs(), env.act_dim());
    env.set_autoreset(false);
    env.reset_all(Some(seed));
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let mut buf = InferenceBuffers::default();
    let (mut mu, mut values, mut actions, mut neglogp) = (vec![0.0; n * a], vec![0.0; n], vec![0.0; n * a], vec![0.0; n]);
    let mut trackers: Vec<Tracker> = (0..n).map(|i| tracker(env, i)).collect();
    let mut imitation = ImitationMetrics::default();
    let mut rep = EvalReport { seed, deterministic: !stochastic, ..Default::default() };
    struct Acc {
        episodes: usize,
        len: f64,
        reward: f64,
        steps: f64,
        falls: usize,
        v1: Vec<f64>,
        v2: Vec<f64>,
    }
    let mut per: BTreeMap<u32, Acc> = BTreeMap::new();
    let (mut total_reward, mut total_steps, mut total_len, mut falls) = (0.0, 0.0, 0.0, 0usize);
    while rep.episodes < episodes {
        env.reset_done();
        for i in 0..n {
            if env.episode(i).progress == 0 && trackers[i].steps > 0 {
                trackers[i] = tracker(env, i);
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
            let st = env.sim().state().env(i);
            let fs = FrameState { root_pos: st.pos(0), ball_pos: st.pos(BALL), ball_vel: st.linvel(BALL) };
            let tr = &mut trackers[i];
            let t = tr.steps;
            if let Some(v) = tr.v1.as_mut() {
                v.update(&fs);
            }
            if let Some(v) = tr.v2.as_mut() {
                v.update(t, &fs);
            }
            tr.steps += 1;
            tr.reward += b.reward[i] as f64;
            imitation.add(&b.metrics[i * 4..(i + 1) * 4]);
            let done = b.terminated[i] != 0 || b.truncated[i] != 0;
            if done && rep.episodes < episodes {
                rep.episodes += 1;
                let skill = env.episode(i).skill;
                let e = per.entry(skill).or_insert(Acc { episodes: 0, len: 0.0, reward: 0.0, steps: 0.0, falls: 0, v1: vec![], v2: vec![] });
                e.episodes += 1;
                e.len += tr.steps as f64;
                e.reward += tr.reward;
                e.steps += tr.steps as f64;
                e.falls += usize::from(b.terminated[i] != 0);
                if let Some(v) = &tr.v1 {
                    e.v1.push(v.score());
                }
                if let Some(v) = &tr.v2 {
                    e.v2.push(f64::from(u8::from(v.success())));
                }
                total_reward += tr.reward;
                total_steps += tr.steps as f64;
                total_len += tr.steps as f64;
                falls += usize::from(b.terminated[i] != 0);
            }
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    rep.acc_percent = imitation.acc_percent();
    rep.e_b_mpjpe_mm = imitation.body_mpjpe_mm();
    rep.e_o_mpjpe_mm = imitation.ball_mpjpe_mm();
    rep.e_cg = imitation.cg_error();
    rep.nr = total_reward / total_steps.max(1.0);
    rep.mean_episode_length = total_len / rep.episodes.max(1) as f64;
    rep.fall_rate = falls as f64 / rep.episodes.max(1) as f64;
    for (skill, e) in per {
        rep.per_skill.insert(
            format!("{skill:03}"),
            SkillReport {
                episodes: e.episodes,
                mean_length: e.len / e.episodes as f64,
                nr: e.reward / e.steps.max(1.0),
                fall_rate: e.falls as f64 / e.episodes as f64,
                v1_score: mean(&e.v1),
                v2_success_rate: mean(&e.v2),
            },
        );
    }
    rep
}
