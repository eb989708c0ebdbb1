//! The adversarial motion prior inside PPO training (`[ppo.amp]`): per-environment windows of the
//! last `window` frames, the style reward mixed into the task reward at every step, a buffer of
//! simulated windows, the discriminator steps after each rollout, and the checkpoint tensors.
//!
//! * Frames: `skillmimic_env::amp::frame_features` of the observation after each step (terminal
//!   observations included: the trainer resets finished environments at the next step's start).
//!   A new episode's window starts as its first frame repeated.
//! * Reward: r = task_weight · r_task + style_weight · r_style, r_style = the discriminator's
//!   style reward of the window ending at the new frame; both parts are reported as the reward
//!   terms `task` and `style`.
//! * Reference windows: a clip of `env.motion` drawn uniformly, then an end frame drawn uniformly
//!   (frames before the clip start repeat its first frame), from the clips posed in the scene.
//! * Buffer (`ppo.amp.schedule = "per_iteration"`, the default): every step, `buffer / horizon`
//!   randomly chosen environments' windows (all of them when fewer) go into a ring buffer of
//!   `buffer` windows; each iteration takes `updates` discriminator steps on `batch` buffer
//!   windows against `batch` reference windows. `"per_minibatch"`: the released agent's step in
//!   every PPO minibatch with a replay buffer (module `replay`).
//! * Checkpoint tensors: `amp.disc.{0,2,…}.weight/.bias`, `amp.norm.{mean,var,count}`,
//!   `amp.optim.step`, `amp.optim.{m,v}.<param>`.
//! * Multi-task environments (`hsi_multi`): by default (`env.hsi.discriminator =
//!   "conditional"`, TokenHSI's released rule) one discriminator whose windows end with the task
//!   one-hot (each environment's its task's; each reference window its clip's task's, the task
//!   drawn by its share of the environments, the clip uniformly among its clips; tensors `amp.*`);
//!   with `"per_task"` one discriminator per task, each scoring its task's environment rows
//!   against its task's clips (`env.hsi.<task>.style_motion`), with its own buffer and steps;
//!   tensors `amp.<task>.*`.
//! * TokenHSI tasks read, by default, the environment's style features of its simulation state
//!   (`Env::style_features`: the released discriminator's 129 per frame) instead of a map of the
//!   observation.
//! * The tracking task on the SMPL humanoid reads the released ModSkill features of the state
//!   (`skillmimic_env::tasks::tracking::prior`, 232 per frame), references from its tracking
//!   clips at the control rate.
//! * Data-parallel runs: every rank keeps the windows of its own environments in a buffer of
//!   `buffer / world` windows and brings `batch / world` reference and buffer windows to each
//!   discriminator step ([`Discriminator::update_with`]: merged normaliser, averaged gradients),
//!   so a step sees `batch` windows of each kind as in one process; the replicas start from rank
//!   0's discriminator (fresh or resumed) and stay equal. Window draws use per-rank streams.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::smpl;
use skillmimic_core::tensorfile::TensorFile;
use skillmimic_env::amp::{FEATURE_DIM, clip_features, frame_features};
use skillmimic_env::clip_state::posed_features;
use skillmimic_env::obs::layout;
use skillmimic_env::tasks::hsi::style;
use skillmimic_env::tasks::imitation::load_motion_library;
use skillmimic_env::tasks::tracking::motion::Motion;
use skillmimic_env::tasks::tracking::prior;
use skillmimic_sim::Scene;

use crate::amp::{DiscLoss, Discriminator, FrameLayout};

mod extension;
mod replay;
mod replay_state;
mod resume;
mod tensors;
use crate::collective::Collective;
use crate::config::{AmpConfig, AmpNormalizer, AmpSchedule, TrainConfig};
use crate::error::LearnError;
use crate::trainer::StepView;
use skillmimic_env::tasks::hsi::config::HsiConfig;

/// Maps one observation row to its frame's prior features.
type FrameFeatures = fn(&[f32], &mut [f32]);

/// Where a frame's features come from.
#[derive(Clone, Copy)]
enum Source {
    /// A map of the observation row.
    Observation(FrameFeatures),
    /// The environment's style features of the state ([`StepView::style`]; TokenHSI's released
    /// discriminator features).
    Env,
}

/// One discriminator with its reference windows and its buffer of simulated windows (one per
/// task in multi-task training, TokenHSI's rule; otherwise one for the run).
pub struct Prior {
    /// Task name (multi-task) or empty (the run's one prior).
    pub name: String,
    pub disc: Discriminator,
    /// Environment rows this prior scores.
    rows: std::ops::Range<usize>,
    reference: Vec<Vec<f32>>,
    /// The condition (task index) of each reference clip (conditional prior; else 0).
    labels: Vec<usize>,
    /// Per condition, its reference clips (indices into `reference`) and the share of the
    /// environments that run it (the probability a reference window comes from that task).
    by_label: Vec<(Vec<usize>, f64)>,
    buffer: Vec<f32>,
    filled: usize,
    next: usize,
}

/// A uniformly random choice of `k` of `picks` moved to its front (the first `k` steps of a
/// Fisher-Yates shuffle: one draw per chosen entry).
fn shuffle_first(rng: &mut ChaCha8Rng, picks: &mut [usize], k: usize) {
    for i in 0..k {
        let j = rng.random_range(i..picks.len());
        picks.swap(i, j);
    }
}

impl Prior {
    /// Write window `x` at the buffer's next slot (a ring: the oldest window is overwritten once
    /// it is full).
    fn push_window(&mut self, x: &[f32]) {
        let (w, cap) = (x.len(), self.buffer.len() / x.len());
        self.buffer[self.next * w..(self.next + 1) * w].copy_from_slice(x);
        self.next = (self.next + 1) % cap;
        self.filled = (self.filled + 1).min(cap);
    }

    /// Checkpoint tensor prefix: `amp` (one prior) or `amp.<task>`.
    fn prefix(&self) -> String {
        if self.name.is_empty() { "amp".to_string() } else { format!("amp.{}", self.name) }
    }
}

/// The motion prior's state in a training run.
pub struct AmpReward {
    /// The discriminators (one, or one per task of a multi-task environment with
    /// `env.hsi.discriminator = "per_task"`).
    pub priors: Vec<Prior>,
    cfg: AmpConfig,
    horizon: usize,
    /// Features per frame (the humanoid's `FEATURE_DIM`; the TokenHSI character's released 129,
    /// or its 222-d proprioception).
    fdim: usize,
    /// Condition entries after each window: the task one-hot of the one conditional
    /// discriminator of a TokenHSI multi-task run (0: unconditional).
    cond: usize,
    /// Where the frames come from.
    source: Source,
    /// `n × window × fdim`: every environment's current window, oldest frame first.
    rings: Vec<f32>,
    /// Environments whose window restarts at the next step (new episode).
    fresh: Vec<bool>,
    rng: ChaCha8Rng,
    frame: Vec<f32>,
    picks: Vec<usize>,
    style: Vec<f32>,
    /// `ppo.amp.schedule = "per_minibatch"`: the rollout's windows and loss sums ([`replay`]).
    replay: Option<replay_state::Replay>,
}

impl AmpReward {
    /// The prior for `n` environments of the run configured by `cfg` (the reference clips are
    /// `env.motion`, posed in the task's scene; TokenHSI tasks: `env.hsi` style clips); `seed`
    /// drives reference sampling, buffer choice and the discriminators' initialisation. `tasks`:
    /// the (task, environment rows) of a multi-task environment, one discriminator each (empty:
    /// one discriminator for all rows).
    pub fn new(
        cfg: &TrainConfig,
        obs_dim: usize,
        n: usize,
        seed: u64,
        tasks: &[(String, std::ops::Range<usize>)],
    ) -> Result<Self, LearnError> {
        let a = cfg.ppo.amp.clone();
        let hsi = skillmimic_env::registry::character(&cfg.env).ok()
            == Some(skillmimic_core::characters::tokenhsi::CHARACTER);
        // TokenHSI multi-task: one discriminator conditioned on the task one-hot (released), or
        // one per task
        let conditional = hsi
            && tasks.len() > 1
            && cfg.env.table::<HsiConfig>().discriminator
                == skillmimic_env::tasks::hsi::config::Discriminators::Conditional;
        let per_episode =
            cfg.env.table::<skillmimic_env::tasks::multi::config::MultiConfig>().assign
                == skillmimic_env::tasks::multi::Assign::PerEpisode;
        if tasks.len() > 1 && !conditional && per_episode {
            return Err(LearnError::Config(
                "config fields 'env.hsi.discriminator' = \"per_task\" and 'env.multi.assign' = \
                    \"per_episode\" do not go together (a task's discriminator scores fixed \
                    environments); use \"conditional\" or \"fixed\""
                    .into(),
            ));
        }
        let groups: Vec<(String, std::ops::Range<usize>)> =
            if tasks.is_empty() { vec![(String::new(), 0..n)] } else { tasks.to_vec() };
        let released = hsi
            && cfg.env.table::<HsiConfig>().style_features
                == skillmimic_env::tasks::hsi::config::StyleFeatures::Released;
        // the SMPL humanoid's tracking task: the released ModSkill features of the state
        let smpl_tracking = cfg.env.task == "tracking"
            && skillmimic_env::registry::character(&cfg.env).ok() == Some(smpl::CHARACTER);
        let (fdim, source) = if released {
            (style::RELEASED_STYLE_DIM, Source::Env)
        } else if smpl_tracking {
            (prior::SMPL_PRIOR_DIM, Source::Env)
        } else if hsi {
            (style::STYLE_DIM, Source::Observation(style::frame_features))
        } else {
            (FEATURE_DIM, Source::Observation(frame_features))
        };
        let mut references = Vec::new();
        for (name, _) in &groups {
            references.push(if smpl_tracking {
                // the tracking clips at the control rate, posed in the humanoid's scene
                let err = |e: String| LearnError::Config(format!("ppo.amp reference clips: {e}"));
                let clips = match Motion::load(&cfg.env.motion, smpl::CHARACTER) {
                    Ok(Motion::Clips(clips)) => clips,
                    Ok(Motion::SkillMimic(_)) => {
                        return Err(err("not clips of the SMPL humanoid".into()));
                    }
                    Err(e) => return Err(err(e.to_string())),
                };
                posed_features(smpl::CHARACTER, &clips, prior::SMPL_PRIOR_DIM, prior::smpl_features)
                    .map_err(|e| err(e.to_string()))?
            } else if hsi {
                // TokenHSI character: the proprioception, references of the task's clips
                let task = if name.is_empty() { cfg.env.task.as_str() } else { name.as_str() };
                let clips =
                    style::load_style_clips(&cfg.env.table::<HsiConfig>().style_motion_of(task))?;
                if released {
                    style::clip_released_features(&clips)?
                } else {
                    style::clip_features(&clips)?
                }
            } else {
                if obs_dim < layout::HUMANOID_DIM {
                    return Err(LearnError::Config(format!(
                        "ppo.amp needs an observation that \
                        starts with the {} humanoid entries; task '{}' has {obs_dim}",
                        layout::HUMANOID_DIM,
                        cfg.env.task
                    )));
                }
                let lib = load_motion_library(&cfg.env.motion)?;
                let scene = Arc::new(
                    Scene::new(
                        skillmimic_env::registry::scene_options(&cfg.env)
                            .map_err(|e| LearnError::Config(e.to_string()))?,
                    )
                    .map_err(|e| LearnError::Config(e.to_string()))?,
                );
                clip_features(scene, &lib).map_err(|e| {
                    LearnError::Config(format!(
                        "ppo.amp reference \
                    clips: {e}"
                    ))
                })?
            });
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x616d_705f_7265_6621);
        let cond = if conditional { groups.len() } else { 0 };
        let width = a.window * fdim + cond;
        let prior = |name: String,
                     rows: std::ops::Range<usize>,
                     reference: Vec<Vec<f32>>,
                     labels: Vec<usize>,
                     by_label: Vec<(Vec<usize>, f64)>,
                     rng: &mut ChaCha8Rng| {
            let mut disc = Discriminator::new(width, a.clone(), rng);
            if a.normalizer == AmpNormalizer::PerFrame {
                disc = disc.per_frame(FrameLayout { window: a.window, fdim, cond })?;
            }
            let buffer = vec![0.0; a.buffer * width];
            Ok::<_, LearnError>(Prior {
                name,
                disc,
                rows,
                reference,
                labels,
                by_label,
                buffer,
                filled: 0,
                next: 0,
            })
        };
        let mut rings = vec![0.0; n * width];
        let priors = if conditional {
            let (mut all, mut labels, mut by_label) = (Vec::new(), Vec::new(), Vec::new());
            for (t, ((_, rows), reference)) in groups.iter().zip(references).enumerate() {
                let first = all.len();
                labels.extend(std::iter::repeat_n(t, reference.len()));
                all.extend(reference);
                by_label.push(((first..all.len()).collect(), rows.len() as f64 / n.max(1) as f64));
                for i in rows.clone() {
                    rings[(i + 1) * width - cond + t] = 1.0;
                }
            }
            vec![prior(String::new(), 0..n, all, labels, by_label, &mut rng)?]
        } else {
            groups
                .into_iter()
                .zip(references)
                .map(|((name, rows), reference)| {
                    let m = reference.len();
                    prior(
                        name,
                        rows,
                        reference,
                        vec![0; m],
                        vec![((0..m).collect(), 1.0)],
                        &mut rng,
                    )
                })
                .collect::<Result<_, _>>()?
        };
        Ok(Self {
            priors,
            horizon: cfg.ppo.horizon,
            rings,
            fresh: vec![true; n],
            rng,
            frame: vec![0.0; fdim],
            fdim,
            cond,
            source,
            picks: Vec::new(),
            style: vec![0.0; n],
            replay: (a.schedule == AmpSchedule::PerMinibatch)
                .then(|| replay_state::Replay::new(cfg.ppo.horizon, n, width)),
            cfg: a,
        })
    }

    /// The prior of a training run when `ppo.amp.enabled` (restored from `resume` when that
    /// checkpoint holds one; in a data-parallel run rank 0 reads it and broadcasts).
    pub fn for_run(
        cfg: &TrainConfig,
        obs_dim: usize,
        n: usize,
        tasks: &[(String, std::ops::Range<usize>)],
        comm: &mut dyn Collective,
        resume: Option<&std::path::Path>,
    ) -> Result<Option<Self>, LearnError> {
        if !cfg.ppo.amp.enabled {
            return Ok(None);
        }
        let (rank, world) = (comm.rank(), comm.world_size());
        let mut local = cfg.clone();
        if world > 1 && cfg.ppo.amp.schedule == AmpSchedule::PerMinibatch {
            return Err(LearnError::Config(format!(
                "config field 'ppo.amp.schedule' = \"per_minibatch\" runs in one process only \
                    (this run has {world} ranks); use \"per_iteration\""
            )));
        }
        if world > 1 {
            let a = &cfg.ppo.amp;
            if !a.batch.is_multiple_of(world)
                || !a.buffer.is_multiple_of(world)
                || a.batch / world < 2
            {
                return Err(LearnError::Config(format!(
                    "config fields 'ppo.amp.batch' ({}) and 'ppo.amp.buffer' ({}): in a \
                        data-parallel run of {world} ranks both must be multiples of {world}, \
                        with at least 2 windows per rank",
                    a.batch, a.buffer
                )));
            }
            local.ppo.amp.batch /= world;
            local.ppo.amp.buffer /= world;
        }
        let mut a = Self::new(&local, obs_dim, n, cfg.run.seed, tasks)?;
        if rank > 0 {
            a.rng = ChaCha8Rng::seed_from_u64(crate::collective::mix_seed(
                cfg.run.seed ^ 0x616d_705f_7265_6621,
                rank as u64,
            ));
        }
        if let Some(path) = resume.filter(|_| rank == 0) {
            let f = TensorFile::open(path)
                .map_err(|e| crate::error::bad_checkpoint(path)(e.to_string()))?;
            if !a.load_from(&f).map_err(crate::error::bad_checkpoint(path))? {
                tracing::warn!(
                    "{}: no motion-prior discriminator in the checkpoint; starting a fresh one",
                    path.display()
                );
            }
        }
        if world > 1 {
            for p in a.priors.iter_mut() {
                p.disc.broadcast(comm)?;
            }
        }
        Ok(Some(a))
    }

    /// The first (single-task runs: the only) discriminator.
    pub fn disc(&self) -> &Discriminator {
        &self.priors[0].disc
    }
    /// The first (single-task runs: the only) discriminator, mutably.
    pub fn disc_mut(&mut self) -> &mut Discriminator {
        &mut self.priors[0].disc
    }

    /// Every environment starts a new window at the next step (new episodes everywhere).
    pub fn restart(&mut self) {
        self.fresh.fill(true);
    }

    /// Entries of a stored window: `window` frames, then the condition one-hot.
    fn width(&self) -> usize {
        self.cfg.window * self.fdim + self.cond
    }

    /// Features per frame of the discriminator's windows.
    pub fn frame_dim(&self) -> usize {
        self.fdim
    }

    /// Environment `i`'s newest frame (`frame_dim` wide).
    pub fn last_frame(&self, i: usize) -> &[f32] {
        let end = i * self.width() + self.cfg.window * self.fdim;
        &self.rings[end - self.fdim..end]
    }

    /// Environment `i`'s condition entries (the task one-hot of a conditional prior; empty).
    pub fn condition(&self, i: usize) -> &[f32] {
        let w = self.width();
        &self.rings[(i + 1) * w - self.cond..(i + 1) * w]
    }

    /// Environment `i`'s frame of `v` into `out` (`fdim`).
    fn frame_of(&self, v: &StepView<'_>, i: usize, out: &mut [f32]) {
        match self.source {
            Source::Observation(f) => f(&v.obs[i * v.obs_dim..(i + 1) * v.obs_dim], out),
            Source::Env => {
                assert_eq!(
                    v.style_dim, self.fdim,
                    "the environment computes {} style features per frame; the prior reads {}",
                    v.style_dim, self.fdim
                );
                out.copy_from_slice(&v.style[i * self.fdim..(i + 1) * self.fdim]);
            }
        }
    }

    /// Before a step: environments that start a new episode fill their window with their first
    /// frame (`v`: the observations the policy acts on, and the style features of their states);
    /// where environments change task between episodes (`v.tasks`), a conditional prior's
    /// one-hot becomes the new episode's task.
    pub fn begin_step(&mut self, v: &StepView<'_>) {
        let (w, f) = (self.width(), self.fdim);
        let mut frame = std::mem::take(&mut self.frame);
        for i in 0..self.fresh.len() {
            if self.fresh[i] {
                self.frame_of(v, i, &mut frame);
                for k in 0..self.cfg.window {
                    self.rings[i * w + k * f..i * w + (k + 1) * f].copy_from_slice(&frame);
                }
                if self.cond > 0 && !v.tasks.is_empty() {
                    let hot = &mut self.rings[(i + 1) * w - self.cond..(i + 1) * w];
                    hot.fill(0.0);
                    hot[v.tasks[i] as usize] = 1.0;
                }
                self.fresh[i] = false;
            }
        }
        self.frame = frame;
    }

    /// After a step: push the new frames (`v`: the step's observations, style features and
    /// episode ends), mix the style reward into `rewards` (in place) and keep some windows.
    /// Returns the sums over the environments of the task and the style reward.
    pub fn after_step(&mut self, v: &StepView<'_>, rewards: &mut [f32]) -> (f64, f64) {
        let (w, n, f) = (self.width(), rewards.len(), self.fdim);
        let wf = self.cfg.window * f;
        let mut rings = std::mem::take(&mut self.rings);
        for i in 0..n {
            let ring = &mut rings[i * w..i * w + wf];
            ring.copy_within(f.., 0);
            self.frame_of(v, i, &mut ring[wf - f..]);
            self.fresh[i] = v.done[i] != 0;
        }
        self.rings = rings;
        for p in self.priors.iter_mut() {
            let r = p.rows.clone();
            p.disc.style_reward_into(
                &self.rings[r.start * w..r.end * w],
                r.len(),
                &mut self.style[r.clone()],
            );
        }
        let (mut st, mut ss) = (0.0, 0.0);
        for (r, &s) in rewards.iter_mut().zip(&self.style) {
            st += *r as f64;
            ss += s as f64;
            *r = (self.cfg.task_weight * *r as f64 + self.cfg.style_weight * s as f64) as f32;
        }
        if self.replay.is_some() {
            self.keep_step(v.t);
            return (st, ss);
        }
        // keep `buffer / horizon` windows per step and prior
        for p in self.priors.iter_mut() {
            let m = p.rows.len();
            let keep = (self.cfg.buffer / self.horizon.max(1)).clamp(1, m);
            self.picks.clear();
            self.picks.extend(p.rows.clone());
            shuffle_first(&mut self.rng, &mut self.picks, keep);
            for &i in &self.picks[..keep] {
                p.push_window(&self.rings[i * w..(i + 1) * w]);
            }
        }
        (st, ss)
    }

    /// The discriminator steps of one iteration over the ranks of `comm` (one process:
    /// [`crate::collective::Single`]); returns the mean loss over them.
    pub fn update(&mut self, comm: &mut dyn Collective) -> Result<DiscLoss, LearnError> {
        if self.replay.is_some() {
            return Ok(self.store_replay());
        }
        let (w, b) = (self.width(), self.cfg.batch);
        let mut mean = DiscLoss::default();
        let (mut xr, mut xs) = (vec![0.0f32; b * w], vec![0.0f32; b * w]);
        let u = (self.cfg.updates * self.priors.len()) as f64;
        for p in self.priors.iter_mut() {
            // every rank fills its buffers at the same steps, so all skip or all step together
            if p.filled == 0 || self.cfg.updates == 0 {
                continue;
            }
            let (fdim, window, cond) = (self.fdim, self.cfg.window, self.cond);
            for _ in 0..self.cfg.updates {
                for k in 0..b {
                    p.draw_reference(
                        &mut self.rng,
                        fdim,
                        window,
                        cond,
                        &mut xr[k * w..(k + 1) * w],
                    );
                    let j = self.rng.random_range(0..p.filled);
                    xs[k * w..(k + 1) * w].copy_from_slice(&p.buffer[j * w..(j + 1) * w]);
                }
                let l = p.disc.update_with(&xr, b, &xs, b, comm)?;
                mean.add_divided(&l, u);
            }
        }
        Ok(mean)
    }
}
