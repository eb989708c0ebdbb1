//! The batched SkillMimic environment: one implementation used by training, evaluation and the
//! Python package.
//!
//! Each call to [`SkillEnv::step`] advances all environments one policy step (60 Hz), then, in
//! parallel on the simulation threads, computes for every environment the observation of the new
//! state, the reward against its reference frame (all sub-terms kept), the evaluation errors of
//! the frame and the termination flags. Finished environments are reset either explicitly
//! ([`SkillEnv::reset_done`], the reference learner's loop) or automatically in the same call
//! (`autoreset`, gymnasium's SAME_STEP semantics, terminal observations kept in `final_obs`).

use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use skillmimic_core::skeleton::NUM_DOFS;
use skillmimic_motion::{ClipError, MotionLibrary};
use skillmimic_sim::{BatchSim, BatchState, ResetState, Scene, SimError};

use crate::config::{ConfigError, EnvConfig, StateInit};
use crate::episode::{Episode, random_ball, reset_state_from_clip};
use crate::hoi::{ContactGraph, HoiState, MAX_CG, dist};
use crate::obs::{layout, write_observation};
use crate::reward::{self, NUM_TERMS};

/// Motion source name of the built-in demo clips (the clips of `motions/`, synthesised in memory).
pub const BUILTIN_DEMO: &str = "builtin:demo";

/// Load a motion library from clip files/folders; the entry `builtin:demo` stands for the
/// procedurally synthesised demo clips (identical to the shipped `motions/` files).
pub fn load_motion_library(paths: &[std::path::PathBuf]) -> Result<MotionLibrary, EnvError> {
    let (builtin, files): (Vec<_>, Vec<_>) = paths.iter().cloned().partition(|p| p.as_os_str() == BUILTIN_DEMO);
    let mut clips = Vec::new();
    if !builtin.is_empty() {
        clips.extend(crate::synth::demo_clips()?);
    }
    if !files.is_empty() {
        let lib = MotionLibrary::load(&files)?;
        clips.extend(lib.clips().iter().map(|m| m.clip.clone()));
    }
    Ok(MotionLibrary::from_clips(clips)?)
}

/// Per-step evaluation errors stored for every environment.
pub const NUM_FRAME_METRICS: usize = 4;
/// Names of the frame metrics: body error (m, mean Euclidean error of root + 17 key bodies),
/// ball error (m), contact graph matches the reference (0/1), contact-graph squared error.
pub const FRAME_METRIC_NAMES: [&str; NUM_FRAME_METRICS] = ["body_err", "ball_err", "cg_match", "cg_sq_err"];

/// Environment error.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Clip(#[from] ClipError),
    #[error(transparent)]
    Config(#[from] ConfigError),
}

/// Output buffers of the last step (environment-major, float32).
#[derive(Clone, Debug, Default)]
pub struct StepBuffers {
    /// `[N][obs_dim]`
    pub obs: Vec<f32>,
    /// `[N]`
    pub reward: Vec<f32>,
    /// `[N][12]` sub-rewards in `reward::TERM_NAMES` order.
    pub terms: Vec<f32>,
    /// `[N][4]` simulated contact-graph entries (`hoi::cg_names`).
    pub contact_graph: Vec<f32>,
    /// `[N][4]` frame metrics (`FRAME_METRIC_NAMES`).
    pub metrics: Vec<f32>,
    /// `[N]` 1 = early termination (fall or instability).
    pub terminated: Vec<u8>,
    /// `[N]` 1 = time limit reached.
    pub truncated: Vec<u8>,
    /// `[N][obs_dim]` terminal observations of environments auto-reset in the last step.
    pub final_obs: Vec<f32>,
    /// `[N]` 1 where `final_obs` is valid.
    pub final_mask: Vec<u8>,
}

/// The batched environment.
pub struct SkillEnv {
    cfg: EnvConfig,
    lib: Arc<MotionLibrary>,
    sim: BatchSim,
    rng: ChaCha8Rng,
    episodes: Vec<Episode>,
    buf: StepBuffers,
    autoreset: bool,
    reset_mask: Vec<bool>,
    reset_states: Vec<ResetState>,
    ball_radius: f64,
}

impl SkillEnv {
    /// Build the scene, the batch and reset every environment.
    pub fn new(cfg: EnvConfig, lib: Arc<MotionLibrary>) -> Result<Self, EnvError> {
        cfg.validate()?;
        let options = cfg.scene_options()?;
        let scene = Arc::new(Scene::new(options)?);
        let n = cfg.num_envs;
        let sim = BatchSim::new(scene, n, cfg.threads)?;
        let obs_dim = layout::OBS_DIM;
        let first = &lib.get(0);
        let mut env = Self {
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            episodes: vec![Episode::new(first, 0, 2, cfg.episode_length); n],
            buf: StepBuffers {
                obs: vec![0.0; n * obs_dim],
                reward: vec![0.0; n],
                terms: vec![0.0; n * NUM_TERMS],
                contact_graph: vec![0.0; n * MAX_CG],
                metrics: vec![0.0; n * NUM_FRAME_METRICS],
                terminated: vec![0; n],
                truncated: vec![0; n],
                final_obs: vec![0.0; n * obs_dim],
                final_mask: vec![0; n],
            },
            autoreset: false,
            reset_mask: vec![false; n],
            reset_states: vec![ResetState::default(); n],
            ball_radius: options.ball.radius,
            cfg,
            lib,
            sim,
        };
        env.reset_all(None);
        Ok(env)
    }

    /// Load the motion library named in the config, then build the environment.
    pub fn from_config(cfg: EnvConfig) -> Result<Self, EnvError> {
        cfg.validate()?;
        let lib = Arc::new(load_motion_library(&cfg.motion)?);
        Self::new(cfg, lib)
    }

    /// Recompute every observation from the current simulation state (after raw state edits).
    pub fn refresh_observations(&mut self) {
        let Self { sim, episodes, buf, .. } = self;
        let state = sim.state();
        sim.install(|| {
            (episodes.par_iter(), buf.obs.par_chunks_mut(layout::OBS_DIM))
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (ep, obs))| write_observation(&state.env(i), ep.skill, obs));
        });
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.episodes.len()
    }
    /// Observation width.
    pub fn obs_dim(&self) -> usize {
        layout::OBS_DIM
    }
    /// Action width.
    pub fn act_dim(&self) -> usize {
        NUM_DOFS
    }
    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }
    /// The motion library.
    pub fn library(&self) -> &Arc<MotionLibrary> {
        &self.lib
    }
    /// The simulation batch (state read-out, raw MuJoCo data).
    pub fn sim(&self) -> &BatchSim {
        &self.sim
    }
    /// Mutable access to the simulation batch (advanced use: raw state edits).
    pub fn sim_mut(&mut self) -> &mut BatchSim {
        &mut self.sim
    }
    /// Output buffers of the last step or reset.
    pub fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    /// Episode state of environment `i`.
    pub fn episode(&self, i: usize) -> &Episode {
        &self.episodes[i]
    }
    /// All episode states.
    pub fn episodes(&self) -> &[Episode] {
        &self.episodes
    }
    /// SAME_STEP autoreset on or off (default off: call [`reset_done`](Self::reset_done)).
    pub fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }

    /// Reseed (if `seed` is given) and reset every environment.
    pub fn reset_all(&mut self, seed: Option<u64>) {
        if let Some(s) = seed {
            self.rng = ChaCha8Rng::seed_from_u64(s);
        }
        let mask = vec![true; self.num_envs()];
        self.reset_envs(&mask);
    }

    /// Reset the environments that terminated or were truncated in the last step.
    pub fn reset_done(&mut self) {
        let mut any = false;
        for i in 0..self.num_envs() {
            let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
            self.reset_mask[i] = done;
            if done {
                any = true;
                self.plan_reset(i);
            }
        }
        if any {
            self.apply_resets(true);
        }
    }

    /// Choose the start of a new episode for environment `i`: a clip from the class-balanced
    /// distribution and a start frame (random 2…T−2 or the configured frame).
    fn plan_reset(&mut self, i: usize) {
        let lib = Arc::clone(&self.lib);
        let clip = lib.sample_clip(&mut self.rng);
        let m = lib.get(clip);
        let t = m.clip.num_frames;
        let start = match self.cfg.state_init {
            StateInit::Random => lib.sample_start(clip, &mut self.rng),
            StateInit::Frame(f) => f.min(t - 2),
        };
        let max_len = if self.cfg.fixed_horizon > 0 { usize::MAX } else { self.cfg.episode_length };
        let mut ep = Episode::new(m, clip, start, max_len);
        if self.cfg.fixed_horizon > 0 {
            ep.length = self.cfg.fixed_horizon + 1;
        }
        let mut state = reset_state_from_clip(m, start);
        if ep.ball_free {
            random_ball(&mut state, self.ball_radius, &mut self.rng);
        }
        self.episodes[i] = ep;
        self.reset_states[i] = state;
    }

    /// Reset the environments selected by `mask` to newly sampled reference states.
    pub fn reset_envs(&mut self, mask: &[bool]) {
        assert_eq!(mask.len(), self.num_envs(), "reset mask length");
        for i in 0..mask.len() {
            self.reset_mask[i] = mask[i];
            if mask[i] {
                self.plan_reset(i);
            }
        }
        self.apply_resets(true);
    }

    /// Reset the environments in `reset_mask` to the states already placed in `reset_states`
    /// and `episodes`, then refresh their observations (and clear their done flags if asked).
    fn apply_resets(&mut self, clear_flags: bool) {
        self.sim.reset(&self.reset_mask, &self.reset_states).expect("reset states come from validated clips");
        let Self { sim, episodes, buf, reset_mask, .. } = self;
        let state = sim.state();
        let mask = &*reset_mask;
        sim.install(|| {
            (episodes.par_iter_mut(), buf.obs.par_chunks_mut(layout::OBS_DIM)).into_par_iter().enumerate().for_each(
                |(i, (ep, obs))| {
                    if !mask[i] {
                        return;
                    }
                    let st = state.env(i);
                    ep.prev_dof_vel.copy_from_slice(st.dof_vel);
                    write_observation(&st, ep.skill, obs);
                },
            );
        });
        if clear_flags {
            for (i, &m) in mask.iter().enumerate() {
                if m {
                    self.buf.terminated[i] = 0;
                    self.buf.truncated[i] = 0;
                }
            }
        }
    }

    /// Advance all environments by one policy step with `actions` (`N × 156`, clamped to [−1, 1]).
    pub fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        self.sim.step(actions)?;
        let Self { sim, episodes, buf, lib, cfg, .. } = self;
        let (state, lib, cfg): (&BatchState, &MotionLibrary, &EnvConfig) = (sim.state(), lib, cfg);
        sim.install(|| {
            (
                episodes.par_iter_mut(),
                buf.obs.par_chunks_mut(layout::OBS_DIM),
                buf.reward.par_iter_mut(),
                buf.terms.par_chunks_mut(NUM_TERMS),
                buf.contact_graph.par_chunks_mut(MAX_CG),
                buf.metrics.par_chunks_mut(NUM_FRAME_METRICS),
                buf.terminated.par_iter_mut(),
                buf.truncated.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (ep, obs, rew, terms, cg, metrics, term, trunc))| {
                    let st = state.env(i);
                    ep.progress += 1;
                    let m = lib.get(ep.clip);
                    let frame = ep.ref_frame().min(m.clip.num_frames - 1);
                    let sim_hoi = HoiState::from_sim(&st);
                    let ref_hoi = HoiState::from_reference(m, frame).aligned(&ep.align);
                    let mode = cfg.reward.contact_graph;
                    let cg_sim = ContactGraph::from_sim(&st, mode, cfg.reward.force_threshold);
                    let cg_ref = ContactGraph::reference(m.clip.contact[frame] as f64, mode);
                    let t = reward::compute(&sim_hoi, &ep.prev_dof_vel, &ref_hoi, &cg_sim, &cg_ref, &cfg.reward, ep.ball_free);
                    ep.prev_dof_vel = sim_hoi.dof_vel;
                    for (o, v) in terms.iter_mut().zip(t.as_array()) {
                        *o = v as f32;
                    }
                    *rew = if ep.progress <= ep.masked_steps { 0.0 } else { t.total as f32 };
                    if ep.progress > ep.masked_steps {
                        ep.reward_sum += t.total;
                        ep.reward_steps += 1;
                    }
                    for k in 0..MAX_CG {
                        cg[k] = cg_sim.values[k] as f32;
                    }
                    // frame metrics
                    let mut body = dist(sim_hoi.root_pos, ref_hoi.root_pos);
                    for k in 0..sim_hoi.key_pos.len() {
                        body += dist(sim_hoi.key_pos[k], ref_hoi.key_pos[k]);
                    }
                    metrics[0] = (body / (1 + sim_hoi.key_pos.len()) as f64) as f32;
                    metrics[1] = dist(sim_hoi.ball_pos, ref_hoi.ball_pos) as f32;
                    metrics[2] = f32::from(u8::from(cg_sim.matches(&cg_ref)));
                    metrics[3] = cg_sim.sq_error(&cg_ref) as f32;

                    write_observation(&st, ep.skill, obs);
                    // the get-up skill (label 0) never terminates early (SkillMimic-V2)
                    let fell = st.pos(0)[2] < cfg.termination_height && ep.progress > 1 && ep.skill != 0;
                    *term = u8::from(fell || st.unstable);
                    *trunc = u8::from(*term == 0 && ep.progress + 1 >= ep.length);
                });
        });
        if self.autoreset {
            let n = self.num_envs();
            let d = layout::OBS_DIM;
            let mut any = false;
            for i in 0..n {
                let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
                self.buf.final_mask[i] = u8::from(done);
                self.reset_mask[i] = done;
                if done {
                    any = true;
                    let (obs, fin) = (&self.buf.obs[i * d..(i + 1) * d], &mut self.buf.final_obs[i * d..(i + 1) * d]);
                    fin.copy_from_slice(obs);
                }
            }
            if any {
                for i in 0..n {
                    if self.reset_mask[i] {
                        self.plan_reset(i);
                    }
                }
                // the flags describe the finished step: keep them
                self.apply_resets(false);
            }
        }
        Ok(())
    }
}
