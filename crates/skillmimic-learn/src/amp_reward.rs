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
//! * Buffer: every step, `buffer / horizon` randomly chosen environments' windows (all of them
//!   when fewer) go into a ring buffer of `buffer` windows; each iteration takes `updates`
//!   discriminator steps on `batch` buffer windows against `batch` reference windows.
//! * Checkpoint tensors: `amp.disc.{0,2,…}.weight/.bias`, `amp.norm.{mean,var,count}`,
//!   `amp.optim.step`, `amp.optim.{m,v}.<param>`.
//! * Data-parallel runs: every rank keeps the windows of its own environments in a buffer of
//!   `buffer / world` windows and brings `batch / world` reference and buffer windows to each
//!   discriminator step ([`Discriminator::update_with`]: merged normaliser, averaged gradients),
//!   so a step sees `batch` windows of each kind as in one process; the replicas start from rank
//!   0's discriminator (fresh or resumed) and stay equal. Window draws use per-rank streams.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile};
use skillmimic_env::amp::{FEATURE_DIM, clip_features, frame_features, window_of};
use skillmimic_env::tasks::hsi::style;
use skillmimic_env::obs::layout;
use skillmimic_env::tasks::imitation::load_motion_library;
use skillmimic_sim::Scene;

use crate::amp::{DiscLoss, Discriminator};
use crate::collective::Collective;
use crate::config::{AmpConfig, TrainConfig};
use crate::error::LearnError;

/// Maps one observation row to its frame's prior features.
type FrameFeatures = fn(&[f32], &mut [f32]);

/// The motion prior's state in a training run.
pub struct AmpReward {
    pub disc: Discriminator,
    cfg: AmpConfig,
    horizon: usize,
    reference: Vec<Vec<f32>>,
    /// Features per frame (the humanoid's `FEATURE_DIM`, or the TokenHSI character's 222).
    fdim: usize,
    /// The per-frame feature map of the task's observation.
    features: FrameFeatures,
    /// `n × window × fdim`: every environment's current window, oldest frame first.
    rings: Vec<f32>,
    /// Environments whose window restarts at the next step (new episode).
    fresh: Vec<bool>,
    buffer: Vec<f32>,
    filled: usize,
    next: usize,
    rng: ChaCha8Rng,
    frame: Vec<f32>,
    picks: Vec<usize>,
    style: Vec<f32>,
}

impl AmpReward {
    /// The prior for `n` environments of the run configured by `cfg` (the reference clips are
    /// `env.motion`, posed in the task's scene); `seed` drives reference sampling, buffer choice
    /// and the discriminator's initialisation.
    pub fn new(cfg: &TrainConfig, obs_dim: usize, n: usize, seed: u64) -> Result<Self, LearnError> {
        let a = cfg.ppo.amp.clone();
        let (fdim, features, reference): (usize, FrameFeatures, _) = if skillmimic_env::registry::character(&cfg.env.task) == Some(skillmimic_env::registry::Character::TokenHsi) {
            // TokenHSI character: the proprioception, references from env.hsi.style_motion
            let clips = style::load_style_clips(&cfg.env.hsi.style_motion)?;
            (style::STYLE_DIM, style::frame_features, style::clip_features(&clips)?)
        } else {
            if obs_dim < layout::HUMANOID_DIM {
                return Err(LearnError::Config(format!("ppo.amp needs an observation that starts with the {} humanoid entries; task '{}' has {obs_dim}", layout::HUMANOID_DIM, cfg.env.task)));
            }
            let lib = load_motion_library(&cfg.env.motion)?;
            let scene = Arc::new(Scene::new(cfg.env.scene_options().map_err(|e| LearnError::Config(e.to_string()))?).map_err(|e| LearnError::Config(e.to_string()))?);
            (FEATURE_DIM, frame_features, clip_features(scene, &lib).map_err(|e| LearnError::Config(format!("ppo.amp reference clips: {e}")))?)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x616d_705f_7265_6621);
        let width = a.window * fdim;
        let disc = Discriminator::new(width, a.clone(), &mut rng);
        Ok(Self {
            disc,
            horizon: cfg.ppo.horizon,
            reference,
            rings: vec![0.0; n * width],
            fresh: vec![true; n],
            buffer: vec![0.0; a.buffer * width],
            filled: 0,
            next: 0,
            rng,
            frame: vec![0.0; fdim],
            fdim,
            features,
            picks: Vec::new(),
            style: vec![0.0; n],
            cfg: a,
        })
    }

    /// The prior of a training run when `ppo.amp.enabled` (restored from `resume` when that
    /// checkpoint holds one; in a data-parallel run rank 0 reads it and broadcasts).
    pub fn for_run(cfg: &TrainConfig, obs_dim: usize, n: usize, comm: &mut dyn Collective, resume: Option<&std::path::Path>) -> Result<Option<Self>, LearnError> {
        if !cfg.ppo.amp.enabled {
            return Ok(None);
        }
        let (rank, world) = (comm.rank(), comm.world_size());
        let mut local = cfg.clone();
        if world > 1 {
            let a = &cfg.ppo.amp;
            if !a.batch.is_multiple_of(world) || !a.buffer.is_multiple_of(world) || a.batch / world < 2 {
                return Err(LearnError::Config(format!(
                    "config fields 'ppo.amp.batch' ({}) and 'ppo.amp.buffer' ({}): in a data-parallel run of {world} ranks both must be multiples of {world}, with at least 2 windows per rank",
                    a.batch, a.buffer
                )));
            }
            local.ppo.amp.batch /= world;
            local.ppo.amp.buffer /= world;
        }
        let mut a = Self::new(&local, obs_dim, n, cfg.run.seed)?;
        if rank > 0 {
            a.rng = ChaCha8Rng::seed_from_u64(crate::collective::mix_seed(cfg.run.seed ^ 0x616d_705f_7265_6621, rank as u64));
        }
        if let Some(path) = resume.filter(|_| rank == 0) {
            let f = TensorFile::open(path).map_err(|e| crate::error::bad_checkpoint(path)(e.to_string()))?;
            if !a.load_from(&f).map_err(crate::error::bad_checkpoint(path))? {
                tracing::warn!("{}: no motion-prior discriminator in the checkpoint; starting a fresh one", path.display());
            }
        }
        if world > 1 {
            a.disc.broadcast(comm)?;
        }
        Ok(Some(a))
    }

    /// Every environment starts a new window at the next step (new episodes everywhere).
    pub fn restart(&mut self) {
        self.fresh.fill(true);
    }

    fn width(&self) -> usize {
        self.cfg.window * self.fdim
    }

    /// Before a step: environments that start a new episode fill their window with their first
    /// frame (`obs`: `n × d`, the observations the policy acts on).
    pub fn begin_step(&mut self, obs: &[f32], d: usize) {
        let w = self.width();
        for (i, fresh) in self.fresh.iter_mut().enumerate() {
            if *fresh {
                (self.features)(&obs[i * d..(i + 1) * d], &mut self.frame);
                let f = self.fdim;
                for k in 0..self.cfg.window {
                    self.rings[i * w + k * f..i * w + (k + 1) * f].copy_from_slice(&self.frame);
                }
                *fresh = false;
            }
        }
    }

    /// After a step: push the new frames (`obs_after`: `n × d`), mix the style reward into
    /// `rewards` (in place) and keep some windows. `done[i]` = the episode ended in this step.
    /// Returns the sums over the environments of the task and the style reward.
    pub fn after_step(&mut self, obs_after: &[f32], d: usize, done: &[u8], rewards: &mut [f32]) -> (f64, f64) {
        let (w, n) = (self.width(), rewards.len());
        for i in 0..n {
            let ring = &mut self.rings[i * w..(i + 1) * w];
            ring.copy_within(self.fdim.., 0);
            (self.features)(&obs_after[i * d..(i + 1) * d], &mut ring[w - self.fdim..]);
            self.fresh[i] = done[i] != 0;
        }
        self.disc.style_reward_into(&self.rings, n, &mut self.style);
        let (mut st, mut ss) = (0.0, 0.0);
        for (r, &s) in rewards.iter_mut().zip(&self.style) {
            st += *r as f64;
            ss += s as f64;
            *r = (self.cfg.task_weight * *r as f64 + self.cfg.style_weight * s as f64) as f32;
        }
        // keep `buffer / horizon` windows per step
        let keep = (self.cfg.buffer / self.horizon.max(1)).clamp(1, n);
        self.picks.clear();
        self.picks.extend(0..n);
        for k in 0..keep {
            let j = self.rng.random_range(k..n);
            self.picks.swap(k, j);
            let i = self.picks[k];
            let at = self.next * w;
            self.buffer[at..at + w].copy_from_slice(&self.rings[i * w..(i + 1) * w]);
            self.next = (self.next + 1) % self.cfg.buffer;
            self.filled = (self.filled + 1).min(self.cfg.buffer);
        }
        (st, ss)
    }

    /// The discriminator steps of one iteration over the ranks of `comm` (one process:
    /// [`crate::collective::Single`]); returns the mean loss over them.
    pub fn update(&mut self, comm: &mut dyn Collective) -> Result<DiscLoss, LearnError> {
        let (w, b) = (self.width(), self.cfg.batch);
        let mut mean = DiscLoss::default();
        // every rank fills its buffer at the same steps, so all skip or all step together
        if self.filled == 0 || self.cfg.updates == 0 {
            return Ok(mean);
        }
        let (mut xr, mut xs) = (vec![0.0f32; b * w], vec![0.0f32; b * w]);
        for _ in 0..self.cfg.updates {
            for k in 0..b {
                let c = self.rng.random_range(0..self.reference.len());
                let end = self.rng.random_range(0..self.reference[c].len() / self.fdim);
                window_of(&self.reference[c], self.fdim, end, self.cfg.window, &mut xr[k * w..(k + 1) * w]);
                let j = self.rng.random_range(0..self.filled);
                xs[k * w..(k + 1) * w].copy_from_slice(&self.buffer[j * w..(j + 1) * w]);
            }
            let l = self.disc.update_with(&xr, b, &xs, b, comm)?;
            let u = self.cfg.updates as f64;
            mean.adversarial += l.adversarial / u;
            mean.grad_penalty += l.grad_penalty / u;
            mean.logit_reg += l.logit_reg / u;
            mean.total += l.total / u;
            mean.mean_ref += l.mean_ref / u;
            mean.mean_sim += l.mean_sim / u;
        }
        Ok(mean)
    }

    /// The discriminator, its normaliser and its Adam state as checkpoint tensors.
    pub fn tensors(&self) -> Vec<OwnedTensor> {
        let d = &self.disc;
        let mut out = Vec::new();
        let names = d.mlp.param_names("amp.disc");
        for ((name, shape), p) in names.iter().zip(d.mlp.params()) {
            out.push(OwnedTensor::f32(name, shape, p));
        }
        let n = d.norm.dim();
        out.push(OwnedTensor::f64("amp.norm.mean", &[n], &d.norm.mean));
        out.push(OwnedTensor::f64("amp.norm.var", &[n], &d.norm.var));
        out.push(OwnedTensor::f64("amp.norm.count", &[], &[d.norm.count]));
        out.push(OwnedTensor::i64("amp.optim.step", &[], &[d.adam.step as i64]));
        for (k, (name, shape)) in names.iter().enumerate() {
            let tail = name.trim_start_matches("amp.");
            out.push(OwnedTensor::f32(&format!("amp.optim.m.{tail}"), shape, &d.adam.m[k]));
            out.push(OwnedTensor::f32(&format!("amp.optim.v.{tail}"), shape, &d.adam.v[k]));
        }
        out
    }

    /// Restore the discriminator from a checkpoint written with [`AmpReward::tensors`]; `Ok(false)`
    /// when the file has no motion prior (training then starts a fresh discriminator).
    pub fn load_from(&mut self, f: &TensorFile) -> Result<bool, String> {
        if !f.names().iter().any(|n| n == "amp.norm.mean") {
            return Ok(false);
        }
        let e = |x: skillmimic_core::tensorfile::TensorFileError| x.to_string();
        let d = &mut self.disc;
        let names = d.mlp.param_names("amp.disc");
        let want = |shape: &[usize]| shape.iter().map(|&s| Some(s)).collect::<Vec<_>>();
        for ((name, shape), dst) in names.iter().zip(d.mlp.params_mut()) {
            *dst = f.f32(name, &want(shape)).map_err(e)?.1;
        }
        let n = d.norm.dim();
        d.norm.mean = f.f64("amp.norm.mean", &[Some(n)]).map_err(e)?.1;
        d.norm.var = f.f64("amp.norm.var", &[Some(n)]).map_err(e)?.1;
        d.norm.count = f.f64("amp.norm.count", &[]).map_err(e)?.1[0];
        d.adam.step = f.i64("amp.optim.step", &[]).map_err(e)?.1[0] as u64;
        for (k, (name, shape)) in names.iter().enumerate() {
            let tail = name.trim_start_matches("amp.");
            d.adam.m[k] = f.f32(&format!("amp.optim.m.{tail}"), &want(shape)).map_err(e)?.1;
            d.adam.v[k] = f.f32(&format!("amp.optim.v.{tail}"), &want(shape)).map_err(e)?.1;
        }
        Ok(true)
    }
}
