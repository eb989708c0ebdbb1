//! Task-independent evaluation: run a policy on any registered task and report episode returns,
//! lengths, early terminations and the per-step means of the task's reward terms and metrics
//! (names from its `TaskSpec`). The imitation task adds the SkillMimic metrics of [`crate::eval`].

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use skillmimic_env::Env;

use crate::error::LearnError;
use crate::policy::{InferenceBuffers, Policy};

/// Results of [`evaluate_episodes`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct EpisodeReport {
    pub task: String,
    /// Who acted: `policy`, `random` or `fixed:<k>` (see [`Actor`]).
    pub actor: String,
    pub episodes: usize,
    pub seed: u64,
    pub deterministic: bool,
    /// Mean undiscounted episode return.
    pub mean_return: f64,
    /// ModSkill's normalised return (Tab. 4): the mean return over the largest return an
    /// episode can earn (`TaskSpec::max_step_reward` × `max_episode_steps`), in [0, 1]; falls
    /// count as the reward they did not earn. Null for tasks without a bounded reward.
    pub normalised_return: Option<f64>,
    /// Mean reward per step over the counted episodes.
    pub mean_reward_per_step: f64,
    /// Mean episode length (policy steps).
    pub mean_episode_length: f64,
    /// Fraction of episodes that ended early (terminated rather than truncated).
    pub early_termination_rate: f64,
    /// Per-step means of the reward terms over the counted episodes.
    pub reward_terms: BTreeMap<String, f64>,
    /// Per-step means of the task's metrics over the counted episodes.
    pub metrics: BTreeMap<String, f64>,
    /// Means over the counted episodes of each metric's value at the episode's last step (the
    /// success latches of the high-level tasks: their success rates).
    pub final_metrics: BTreeMap<String, f64>,
    /// Mean episode length in simulation steps (× the task's `steps_per_action`).
    pub mean_episode_low_level_steps: f64,
}

/// Who acts in an evaluation.
#[derive(Clone, Copy, Debug)]
pub enum Actor<'a> {
    /// The policy's mode (deterministic) or samples (`stochastic`).
    Policy { policy: &'a Policy, stochastic: bool },
    /// Uniformly random choices of a discrete task (baseline).
    Random,
    /// Always the same choice of a discrete task (baseline: one fixed skill).
    Fixed(usize),
}

impl Actor<'_> {
    /// Name in reports: `policy`, `random`, `fixed:<k>`.
    pub fn label(&self) -> String {
        match self {
            Actor::Policy { .. } => "policy".into(),
            Actor::Random => "random".into(),
            Actor::Fixed(k) => format!("fixed:{k}"),
        }
    }
}

/// Evaluate `policy` on `env` for `episodes` episodes: every environment contributes a fixed
/// quota of its first episodes (counting the first to finish would favour short ones); actions
/// are the family's mode, or samples when `stochastic`; starts seeded with `seed`.
pub fn evaluate_episodes(
    policy: &Policy,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    stochastic: bool,
    threads: usize,
) -> Result<EpisodeReport, LearnError> {
    evaluate_actor(Actor::Policy { policy, stochastic }, env, episodes, seed, threads)
}

/// [`evaluate_episodes`] for any [`Actor`]: the baselines see the same episode starts (seed) as
/// the policy. Random choices come from their own stream seeded with `seed`.
pub fn evaluate_actor(
    actor: Actor<'_>,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    threads: usize,
) -> Result<EpisodeReport, LearnError> {
    let spec = env.spec().clone();
    let choices = match spec.action_space {
        skillmimic_env::ActionSpace::Discrete { n } => n,
        skillmimic_env::ActionSpace::Box { .. } => 0,
    };
    let labelled = |mut r: EpisodeReport| {
        r.actor = actor.label();
        r.deterministic = !matches!(actor, Actor::Random | Actor::Policy { stochastic: true, .. });
        r
    };
    match actor {
        Actor::Policy { policy, stochastic } => {
            return evaluate_policy(policy, stochastic, env, episodes, seed, threads).map(labelled);
        }
        Actor::Fixed(k) if k >= choices => {
            return Err(LearnError::Config(format!(
                "baseline fixed:{k}: task '{}' has {choices} discrete choices",
                spec.name
            )));
        }
        _ if choices == 0 => {
            return Err(LearnError::Config(format!(
                "baselines need a task with discrete choices; '{}' has continuous actions",
                spec.name
            )));
        }
        _ => {}
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xba5e);
    run_episodes(env, episodes, seed, |_obs, actions| {
        for a in actions.iter_mut() {
            *a = match actor {
                Actor::Fixed(k) => k as f32,
                _ => rand::Rng::random_range(&mut rng, 0..choices) as f32,
            };
        }
    })
    .map(labelled)
}

fn evaluate_policy(
    policy: &Policy,
    stochastic: bool,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    threads: usize,
) -> Result<EpisodeReport, LearnError> {
    let spec = env.spec().clone();
    if (policy.obs_dim(), policy.act_dim()) != (spec.obs_dim, spec.act_dim()) {
        return Err(LearnError::Config(format!(
            "the policy takes observations of {} and gives actions of {}; task '{}' has {} and {}",
            policy.obs_dim(),
            policy.act_dim(),
            spec.name,
            spec.obs_dim,
            spec.act_dim()
        )));
    }
    let (n, o) = (env.num_envs(), policy.actor_outputs());
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let mut buf = InferenceBuffers::default();
    let (mut out, mut values, mut neglogp) = (vec![0.0; n * o], vec![0.0; n], vec![0.0; n]);
    run_episodes(env, episodes, seed, |obs, actions| {
        policy.infer(obs, n, &mut buf, &mut out, &mut values, threads);
        if stochastic {
            policy.sample(&out, n, &mut rng, actions, &mut neglogp);
        } else {
            policy.mode(&out, n, actions);
        }
    })
}

/// The episode loop shared by every actor: `act(obs, actions)` fills the actions of a step.
fn run_episodes(
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
    mut act: impl FnMut(&[f32], &mut [f32]),
) -> Result<EpisodeReport, LearnError> {
    let spec = env.spec().clone();
    let (n, a) = (env.num_envs(), spec.act_dim());
    let (nt, nm) = (spec.term_names.len(), spec.metric_names.len());
    env.set_autoreset(false);
    env.reset_all(Some(seed));
    let mut actions = vec![0.0; n * a];
    let quota: Vec<usize> = (0..n).map(|i| episodes / n + usize::from(i < episodes % n)).collect();
    let (mut finished, mut ret, mut len) = (vec![0usize; n], vec![0.0f64; n], vec![0usize; n]);
    let (mut terms, mut metrics, mut finals) =
        (vec![0.0f64; nt], vec![0.0f64; nm], vec![0.0f64; nm]);
    let mut rep = EpisodeReport {
        task: spec.name.to_string(),
        seed,
        deterministic: true,
        ..Default::default()
    };
    let (mut steps, mut reward, mut early) = (0.0f64, 0.0f64, 0usize);
    while rep.episodes < episodes {
        env.reset_done();
        act(&env.buffers().obs, &mut actions);
        env.step(&actions)?;
        let b = env.buffers();
        for i in 0..n {
            if finished[i] >= quota[i] {
                continue;
            }
            ret[i] += b.reward[i] as f64;
            len[i] += 1;
            for (s, &v) in terms.iter_mut().zip(&b.terms[i * nt..(i + 1) * nt]) {
                *s += v as f64;
            }
            for (s, &v) in metrics.iter_mut().zip(&b.metrics[i * nm..(i + 1) * nm]) {
                *s += v as f64;
            }
            if b.terminated[i] != 0 || b.truncated[i] != 0 {
                finished[i] += 1;
                rep.episodes += 1;
                steps += len[i] as f64;
                reward += ret[i];
                early += usize::from(b.terminated[i] != 0);
                for (s, &v) in finals.iter_mut().zip(&b.metrics[i * nm..(i + 1) * nm]) {
                    *s += v as f64;
                }
                rep.mean_return += ret[i];
                (ret[i], len[i]) = (0.0, 0);
            }
        }
    }
    let (e, s) = (rep.episodes.max(1) as f64, steps.max(1.0));
    rep.mean_return /= e;
    rep.normalised_return =
        spec.max_step_reward.map(|m| rep.mean_return / (m * spec.max_episode_steps.max(1) as f64));
    rep.mean_reward_per_step = reward / s;
    rep.mean_episode_length = steps / e;
    rep.early_termination_rate = early as f64 / e;
    // the sums include the steps of counted episodes only
    rep.reward_terms =
        spec.term_names.iter().zip(&terms).map(|(k, v)| (k.to_string(), v / s)).collect();
    rep.metrics =
        spec.metric_names.iter().zip(&metrics).map(|(k, v)| (k.to_string(), v / s)).collect();
    rep.final_metrics =
        spec.metric_names.iter().zip(&finals).map(|(k, v)| (k.to_string(), v / e)).collect();
    rep.mean_episode_low_level_steps = rep.mean_episode_length * spec.steps_per_action as f64;
    Ok(rep)
}
