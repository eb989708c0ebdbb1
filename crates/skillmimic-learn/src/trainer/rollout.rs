//! The rollout part of an iteration: `horizon` steps of every environment of this rank into the
//! rollout storage, with the per-episode bookkeeping and the iteration's rollout statistics
//! (reduced over the ranks). See the module doc of [`super`] for the loop's conventions.

use std::time::{Duration, Instant};

use rand_chacha::ChaCha8Rng;
use skillmimic_env::Env;

use super::extension::{Extension, StepView};
use crate::collective::Collective;
use crate::error::LearnError;
use crate::iteration_stats::IterationStats;
use crate::policy::{InferenceBuffers, Policy};
use crate::storage::Rollout;

/// Running returns and lengths of the current episodes, per environment.
#[derive(Default)]
pub struct EpisodeTally {
    pub(super) ret: Vec<f64>,
    pub(super) len: Vec<u64>,
}

impl EpisodeTally {
    fn new(n: usize) -> Self {
        Self { ret: vec![0.0; n], len: vec![0; n] }
    }
    /// Forget the current episodes (rebuilt environments).
    pub fn clear(&mut self) {
        self.ret.fill(0.0);
        self.len.fill(0);
    }
}

/// Bootstrap values of the observations after a step, for the environments that need one.
#[derive(Default)]
struct Bootstrap {
    rows: Vec<usize>,
    obs: Vec<f32>,
    values: Vec<f32>,
}

/// Buffers and random stream of the rollout (reused every iteration).
pub struct Rollouts {
    pub storage: Rollout,
    /// The action-noise stream.
    pub rng: ChaCha8Rng,
    pub episodes: EpisodeTally,
    infer: InferenceBuffers,
    /// Actor outputs and values of the current step.
    mu: Vec<f32>,
    values: Vec<f32>,
    boot: Bootstrap,
    /// Rewards of the current step (after the extensions) and its episode ends.
    rewards: Vec<f32>,
    done: Vec<u8>,
    /// The environments' style features (`n × style_dim`) for the extensions.
    style: Vec<f32>,
    threads: usize,
}

impl Rollouts {
    /// Buffers for `n` environments of observation width `d`, `outputs` actor outputs.
    pub fn new(n: usize, d: usize, outputs: usize, rng: ChaCha8Rng, threads: usize) -> Self {
        Self {
            storage: Rollout::default(),
            rng,
            episodes: EpisodeTally::new(n),
            infer: InferenceBuffers::default(),
            mu: vec![0.0; n * outputs],
            values: vec![0.0; n],
            boot: Bootstrap {
                rows: Vec::with_capacity(n),
                obs: vec![0.0; n * d],
                values: vec![0.0; n],
            },
            rewards: vec![0.0; n],
            done: vec![0; n],
            style: Vec::new(),
            threads,
        }
    }

    /// Size the storage for `h` steps of `env`.
    pub fn alloc(&mut self, h: usize, env: &dyn Env) {
        self.storage.ensure(h, env.num_envs(), env.obs_dim(), env.act_dim());
    }

    /// Collect `h` steps into the storage; fill the rollout statistics of `stats` (reduced over
    /// `comm`'s ranks; `env_s` measured here).
    pub fn collect(
        &mut self,
        h: usize,
        env: &mut dyn Env,
        policy: &Policy,
        extensions: &mut [Box<dyn Extension>],
        comm: &mut dyn Collective,
        stats: &mut IterationStats,
    ) -> Result<(), LearnError> {
        self.alloc(h, env);
        let (n, d, a) = (env.num_envs(), env.obs_dim(), env.act_dim());
        let nt = env.spec().term_names.len();
        let mut term_sums = vec![0.0f64; nt];
        let ext_terms: usize = extensions.iter().map(|e| e.step_terms().len()).sum();
        let mut ext_sums = vec![0.0f64; ext_terms];
        let (mut ep_count, mut ep_len_sum, mut ep_ret_sum, mut early, mut unstable) =
            (0usize, 0u64, 0.0f64, 0usize, 0usize);
        let mut pending = false; // next_values[t-1] still to fill from values[t]
        let mut env_time = Duration::ZERO;
        let roll = &mut self.storage;
        for t in 0..h {
            let te = Instant::now();
            env.reset_done();
            env_time += te.elapsed();
            let rows = t * n..(t + 1) * n;
            roll.obs[t * n * d..(t + 1) * n * d].copy_from_slice(&env.buffers().obs);
            let obs = &roll.obs[t * n * d..(t + 1) * n * d];
            let k = if extensions.is_empty() { 0 } else { env.style_dim() };
            self.style.resize(n * k, 0.0);
            if k > 0 {
                env.style_features(&mut self.style);
            }
            let view = StepView {
                t,
                obs,
                obs_dim: d,
                done: &[],
                style: &self.style,
                style_dim: k,
                tasks: env.row_tasks(),
            };
            for e in extensions.iter_mut() {
                e.begin_step(&view);
            }
            policy.infer(obs, n, &mut self.infer, &mut self.mu, &mut self.values, self.threads);
            roll.values[rows.clone()].copy_from_slice(&self.values);
            if pending {
                // environments not reset since the last step: their next value is this value
                let prev = (t - 1) * n;
                for i in 0..n {
                    if roll.dones[prev + i] == 0 {
                        roll.next_values[prev + i] = self.values[i];
                    }
                }
            }
            policy.sample(
                &self.mu,
                n,
                &mut self.rng,
                &mut roll.actions[t * n * a..(t + 1) * n * a],
                &mut roll.neglogp[rows.clone()],
            );
            let te = Instant::now();
            env.step(&roll.actions[t * n * a..(t + 1) * n * a])?;
            env_time += te.elapsed();
            let b = env.buffers();
            self.rewards.copy_from_slice(&b.reward);
            if !extensions.is_empty() {
                for (o, (&te, &tr)) in
                    self.done.iter_mut().zip(b.terminated.iter().zip(&b.truncated))
                {
                    *o = u8::from(te != 0 || tr != 0);
                }
                if k > 0 {
                    env.style_features(&mut self.style);
                }
                let b = env.buffers();
                let view = StepView {
                    t,
                    obs: &b.obs,
                    obs_dim: d,
                    done: &self.done,
                    style: &self.style,
                    style_dim: k,
                    tasks: env.row_tasks(),
                };
                let mut at = 0;
                for e in extensions.iter_mut() {
                    let k = e.step_terms().len();
                    e.after_step(&view, &mut self.rewards, &mut ext_sums[at..at + k]);
                    at += k;
                }
            }
            self.boot.rows.clear();
            let ep = &mut self.episodes;
            for i in 0..n {
                let r = self.rewards[i];
                roll.rewards[t * n + i] = r;
                let done = b.terminated[i] != 0 || b.truncated[i] != 0;
                roll.dones[t * n + i] = u8::from(done);
                ep.ret[i] += r as f64;
                ep.len[i] += 1;
                unstable += usize::from(b.unstable[i] != 0);
                for (s, &v) in term_sums.iter_mut().zip(&b.terms[i * nt..(i + 1) * nt]) {
                    *s += v as f64;
                }
                if done || t + 1 == h {
                    self.boot.rows.push(i);
                }
                if done {
                    ep_count += 1;
                    ep_len_sum += ep.len[i];
                    ep_ret_sum += ep.ret[i];
                    early += usize::from(b.terminated[i] != 0);
                    ep.ret[i] = 0.0;
                    ep.len[i] = 0;
                }
            }
            // values of the observations after the step for finished environments (terminal
            // observations) and, at the last step, for everyone
            let boot = &mut self.boot;
            let m = boot.rows.len();
            for (k, &i) in boot.rows.iter().enumerate() {
                boot.obs[k * d..(k + 1) * d].copy_from_slice(&b.obs[i * d..(i + 1) * d]);
            }
            if m > 0 {
                policy.infer_values(
                    &boot.obs[..m * d],
                    m,
                    &mut self.infer,
                    &mut boot.values,
                    self.threads,
                );
            }
            for (k, &i) in boot.rows.iter().enumerate() {
                let keep = if b.terminated[i] != 0 { 0.0 } else { 1.0 };
                roll.next_values[t * n + i] = keep * boot.values[k];
            }
            pending = t + 1 < h;
        }
        stats.env_s = env_time.as_secs_f64();
        // sums over all ranks' environments: [steps, rewards, values, episodes, lengths,
        // returns, early endings, unstable steps, reward terms…, extension terms…]
        let mut s = vec![
            (h * n) as f64,
            roll.rewards.iter().map(|&r| r as f64).sum::<f64>(),
            roll.values.iter().map(|&v| v as f64).sum::<f64>(),
            ep_count as f64,
            ep_len_sum as f64,
            ep_ret_sum,
            early as f64,
            unstable as f64,
        ];
        s.extend_from_slice(&term_sums);
        s.extend_from_slice(&ext_sums);
        comm.all_reduce_f64(&mut s)?;
        let steps = s[0];
        stats.mean_reward = s[1] / steps;
        let names = env.spec().term_names.iter().map(String::as_str);
        // the extensions' terms (the motion prior: the task reward before mixing and the style
        // reward; the mixed one is `mean_reward`)
        let ext_names = extensions.iter().flat_map(|e| e.step_terms().iter().copied());
        stats.reward_terms = names
            .chain(ext_names)
            .zip(&s[8..])
            .map(|(nm, v)| (nm.to_string(), v / steps))
            .collect();
        stats.episodes = s[3] as usize;
        stats.unstable_steps = s[7] as u64;
        if s[3] > 0.0 {
            stats.episode_length = s[4] / s[3];
            stats.episode_return = s[5] / s[3];
            stats.early_terminations = s[6] / s[3];
        }
        stats.value_mean = s[2] / steps;
        Ok(())
    }
}
