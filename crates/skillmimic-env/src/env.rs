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

use rand::Rng;

use crate::config::{ConfigError, EnvConfig, MaskedReward, StateInit};
use crate::episode::{Episode, random_ball, reset_state_from_clip};
use crate::hoi::{ContactGraph, HoiState, MAX_CG, dist};
use crate::obs::{layout, write_observation};
use crate::reward::{self, NUM_TERMS};
use crate::v2::ats::AdaptiveSampler;
use crate::v2::graph::StitchGraph;
use crate::v2::history::{HistoryBuffer, HistoryEncoder, HistoryError, reference_features};
use crate::v2::similarity::masked_steps;
use crate::v2::transition::{connect, perturb};

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
    #[error(transparent)]
    History(#[from] HistoryError),
}

/// How a pending reset starts (SkillMimic-V2 plans; `Plain` otherwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ResetPlan {
    /// Reference-state initialisation at the sampled (clip, frame).
    Plain,
    /// Perturbed start, connected after forward kinematics to the most similar frame of the clip.
    Connect,
    /// Start state of the sampled (clip, frame), imitating another skill (graph connection).
    Switch,
}

/// SkillMimic-V2 state of the environment (parts that are switched off stay empty).
#[derive(Default)]
struct V2State {
    encoder: Option<Arc<HistoryEncoder>>,
    /// `[clip][T × 316]` reference history features.
    ref_features: Vec<Vec<f32>>,
    /// One per environment (`None` without the history encoder).
    history: Vec<Option<HistoryBuffer>>,
    graph: Option<StitchGraph>,
    ats: Option<AdaptiveSampler>,
    plans: Vec<ResetPlan>,
    /// Per clip (reward sum, count) scratch of the masked-reward compatibility mode.
    clip_sums: Vec<(f64, usize)>,
    /// (clip, frame) the physical start state came from (its reference rows fill the history
    /// at the reset).
    sources: Vec<(usize, usize)>,
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
    obs_dim: usize,
    v2: V2State,
    /// Skill condition forced on every new episode (transition success rate evaluation).
    skill_override: Option<u32>,
}

/// A fresh episode on frame `start` of `clip` with the configured length rules.
fn new_episode(cfg: &EnvConfig, lib: &MotionLibrary, clip: usize, start: usize) -> Episode {
    let m = lib.get(clip);
    let max_len = if cfg.fixed_horizon > 0 { usize::MAX } else { cfg.episode_length };
    let mut ep = Episode::new(m, clip, start, max_len);
    if cfg.fixed_horizon > 0 {
        ep.length = cfg.fixed_horizon + 1;
    }
    ep
}

/// Set the masked bridging steps of a connection with similarity `beta`.
fn set_bridge(ep: &mut Episode, cfg: &EnvConfig, beta: f64) {
    let b = &cfg.v2.bridge;
    ep.masked_steps = masked_steps(beta, b.max_masked_steps, b.tau);
    ep.inserted = match b.masked_reward {
        MaskedReward::Exclude => ep.masked_steps,
        MaskedReward::ReplaceWithClipMean => 0,
    };
}

impl SkillEnv {
    /// Build the scene, the batch and reset every environment.
    pub fn new(cfg: EnvConfig, lib: Arc<MotionLibrary>) -> Result<Self, EnvError> {
        cfg.validate()?;
        let options = cfg.scene_options()?;
        let scene = Arc::new(Scene::new(options)?);
        let n = cfg.num_envs;
        let sim = BatchSim::new(Arc::clone(&scene), n, cfg.threads)?;
        let mut v2 = V2State { plans: vec![ResetPlan::Plain; n], sources: vec![(0, 2); n], history: vec![None; n], ..Default::default() };
        if cfg.v2.history.enabled {
            let enc = Arc::new(HistoryEncoder::load(&cfg.v2.history.encoder)?);
            v2.ref_features = reference_features(Arc::clone(&scene), &lib)?;
            v2.history = (0..n).map(|_| Some(HistoryBuffer::new(&enc))).collect();
            v2.encoder = Some(enc);
        }
        if cfg.v2.stg.enabled {
            v2.graph = Some(sim.install(|| StitchGraph::build(&lib, &cfg.reward, cfg.v2.bridge.tau)));
        }
        if cfg.v2.ats.enabled {
            v2.ats = Some(AdaptiveSampler::new(&lib, &cfg.v2.ats));
        }
        let obs_dim = layout::OBS_DIM + v2.encoder.as_ref().map_or(0, |e| e.embed_dim());
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
            obs_dim,
            v2,
            skill_override: None,
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
    /// The history embedding entries (last μ) keep the value computed at the last step or reset.
    pub fn refresh_observations(&mut self) {
        let Self { sim, episodes, buf, obs_dim, .. } = self;
        let state = sim.state();
        sim.install(|| {
            (episodes.par_iter(), buf.obs.par_chunks_mut(*obs_dim))
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (ep, obs))| write_observation(&state.env(i), ep.skill, &mut obs[..layout::OBS_DIM]));
        });
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.episodes.len()
    }
    /// Observation width: 902, plus the history embedding width μ when the encoder is on.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
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
    /// The pending or last reset plan of environment `i` (SkillMimic-V2 diagnostics).
    pub fn reset_plan(&self, i: usize) -> ResetPlan {
        self.v2.plans[i]
    }
    /// The (clip, frame) whose state started the current episode of environment `i` (before any
    /// perturbation; with an STG switch the imitated clip differs).
    pub fn start_source(&self, i: usize) -> (usize, usize) {
        self.v2.sources[i]
    }
    /// The history encoder, when on.
    pub fn history_encoder(&self) -> Option<&Arc<HistoryEncoder>> {
        self.v2.encoder.as_ref()
    }
    /// The current history window of environment `i` (k × 316, oldest first), when on.
    pub fn history_window(&self, i: usize) -> Option<Vec<f32>> {
        self.v2.history[i].as_ref().map(|h| h.window())
    }
    /// The Stitched Trajectory Graph, when on.
    pub fn stitch_graph(&self) -> Option<&StitchGraph> {
        self.v2.graph.as_ref()
    }
    /// The adaptive sampler, when on.
    pub fn adaptive_sampler(&self) -> Option<&AdaptiveSampler> {
        self.v2.ats.as_ref()
    }
    /// Force the skill condition of every new episode (`None` = the clip's own label); used to
    /// measure transition success (start from one skill's states, ask for another).
    pub fn set_skill_override(&mut self, skill: Option<u32>) {
        self.skill_override = skill;
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
                self.finish_episode(i);
                self.plan_reset(i);
            }
        }
        if any {
            self.apply_resets(true);
        }
    }

    /// Bookkeeping of a finished episode (Adaptive Trajectory Sampling).
    fn finish_episode(&mut self, i: usize) {
        let ep = &self.episodes[i];
        if let Some(ats) = self.v2.ats.as_mut() {
            if ep.progress > 0 {
                ats.record(ep.clip, ep.ref_start, ep.reward_sum / ep.rewarded_horizon().max(1) as f64);
            }
        }
    }

    /// Choose the start of a new episode for environment `i`: a clip and start frame (class-
    /// balanced clip and uniform frame 2…T−2, the configured frame, or the adaptive sampler),
    /// then the SkillMimic-V2 start variants: with probability p_n a perturbed start (connected
    /// to the clip after forward kinematics, in `apply_resets`), otherwise with probability p_e
    /// the imitation of another skill from this state through the Stitched Trajectory Graph.
    fn plan_reset(&mut self, i: usize) {
        let lib = Arc::clone(&self.lib);
        let (clip, start) = match (self.cfg.state_init, self.v2.ats.as_ref()) {
            (StateInit::Random, Some(ats)) => ats.sample(&mut self.rng),
            (StateInit::Random, None) => {
                let c = lib.sample_clip(&mut self.rng);
                (c, lib.sample_start(c, &mut self.rng))
            }
            (StateInit::Frame(f), _) => {
                let c = lib.sample_clip(&mut self.rng);
                (c, f.min(lib.get(c).clip.num_frames - 2))
            }
        };
        let m = lib.get(clip);
        let mut ep = new_episode(&self.cfg, &lib, clip, start);
        let mut state = reset_state_from_clip(m, start);
        if ep.ball_free {
            random_ball(&mut state, self.ball_radius, &mut self.rng);
        }
        let v2 = &self.cfg.v2;
        let mut plan = ResetPlan::Plain;
        if v2.stf.enabled && self.rng.random::<f64>() < v2.stf.prob {
            perturb(&mut state, &v2.stf.eps, !ep.ball_free, &mut self.rng);
            plan = ResetPlan::Connect;
        } else if v2.stg.enabled && self.rng.random::<f64>() < v2.stg.prob {
            let conns = self.v2.graph.as_ref().map_or(&[][..], |g| g.connections(clip, start));
            if !conns.is_empty() {
                let c = conns[self.rng.random_range(0..conns.len())];
                ep = new_episode(&self.cfg, &lib, c.clip, c.frame);
                ep.align = c.align;
                set_bridge(&mut ep, &self.cfg, c.similarity);
                plan = ResetPlan::Switch;
            }
        }
        if let Some(s) = self.skill_override {
            ep.skill = s;
        }
        self.episodes[i] = ep;
        self.reset_states[i] = state;
        self.v2.plans[i] = plan;
        self.v2.sources[i] = (clip, start);
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
    /// and `episodes`, connect perturbed starts to their clip, fill the history buffers, then
    /// refresh the observations (and clear the done flags if asked).
    fn apply_resets(&mut self, clear_flags: bool) {
        self.sim.reset(&self.reset_mask, &self.reset_states).expect("reset states come from validated clips");
        let Self { sim, episodes, buf, reset_mask, v2, lib, cfg, obs_dim, .. } = self;
        let state = sim.state();
        let mask = &*reset_mask;
        let (lib, cfg): (&MotionLibrary, &EnvConfig) = (lib, cfg);
        let (enc, ref_features, plans, sources) = (v2.encoder.as_deref(), &v2.ref_features, &v2.plans, &v2.sources);
        sim.install(|| {
            (episodes.par_iter_mut(), buf.obs.par_chunks_mut(*obs_dim), v2.history.par_iter_mut()).into_par_iter().enumerate().for_each(
                |(i, (ep, obs, hist))| {
                    if !mask[i] {
                        return;
                    }
                    let st = state.env(i);
                    if plans[i] == ResetPlan::Connect {
                        let m = lib.get(ep.clip);
                        let (j, beta) = connect(&HoiState::from_sim(&st), m, &cfg.reward, ep.ball_free);
                        let skill = ep.skill;
                        *ep = new_episode(cfg, lib, ep.clip, j);
                        ep.skill = skill;
                        set_bridge(ep, cfg, beta);
                    }
                    ep.prev_dof_vel.copy_from_slice(st.dof_vel);
                    write_observation(&st, ep.skill, &mut obs[..layout::OBS_DIM]);
                    if let (Some(enc), Some(h)) = (enc, hist.as_mut()) {
                        let (clip, frame) = sources[i];
                        h.fill_from_reference(enc, &ref_features[clip], frame);
                        h.observe(enc, obs, st.dof_pos, !ep.ball_free);
                    }
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
        let Self { sim, episodes, buf, lib, cfg, v2, obs_dim, .. } = self;
        let (state, lib, cfg): (&BatchState, &MotionLibrary, &EnvConfig) = (sim.state(), lib, cfg);
        let enc = v2.encoder.as_deref();
        sim.install(|| {
            (
                episodes.par_iter_mut(),
                buf.obs.par_chunks_mut(*obs_dim),
                v2.history.par_iter_mut(),
                buf.reward.par_iter_mut(),
                buf.terms.par_chunks_mut(NUM_TERMS),
                buf.contact_graph.par_chunks_mut(MAX_CG),
                buf.metrics.par_chunks_mut(NUM_FRAME_METRICS),
                buf.terminated.par_iter_mut(),
                buf.truncated.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (ep, obs, hist, rew, terms, cg, metrics, term, trunc))| {
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
                    *rew = if ep.is_masked() { 0.0 } else { t.total as f32 };
                    if !ep.is_masked() {
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

                    write_observation(&st, ep.skill, &mut obs[..layout::OBS_DIM]);
                    if let (Some(enc), Some(h)) = (enc, hist.as_mut()) {
                        // h_t from frames t−k … t−1, then the current frame joins the history
                        h.observe(enc, obs, st.dof_pos, !ep.ball_free);
                    }
                    // the get-up skill (label 0) never terminates early (SkillMimic-V2)
                    let fell = st.pos(0)[2] < cfg.termination_height && ep.progress > 1 && ep.skill != 0;
                    *term = u8::from(fell || st.unstable);
                    *trunc = u8::from(*term == 0 && ep.progress >= ep.horizon());
                });
        });
        if self.cfg.v2.bridge.masked_reward == MaskedReward::ReplaceWithClipMean {
            self.replace_masked_rewards();
        }
        if let Some(ats) = self.v2.ats.as_mut() {
            ats.tick();
        }
        if self.autoreset {
            let n = self.num_envs();
            let d = self.obs_dim;
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
                        self.finish_episode(i);
                        self.plan_reset(i);
                    }
                }
                // the flags describe the finished step: keep them
                self.apply_resets(false);
            }
        }
        Ok(())
    }

    /// Reference-code compatibility of the masked steps: their reward becomes the mean reward of
    /// all environments currently on the same clip.
    fn replace_masked_rewards(&mut self) {
        if !self.episodes.iter().any(|e| e.masked_steps > 0 && e.is_masked()) {
            return;
        }
        let total = reward::TERM_NAMES.len() - 1;
        let sums = &mut self.v2.clip_sums;
        sums.clear();
        sums.resize(self.lib.len(), (0.0, 0));
        for (i, ep) in self.episodes.iter().enumerate() {
            let s = &mut sums[ep.clip];
            s.0 += self.buf.terms[i * NUM_TERMS + total] as f64;
            s.1 += 1;
        }
        for (i, ep) in self.episodes.iter().enumerate() {
            if ep.masked_steps > 0 && ep.is_masked() {
                let (s, c) = sums[ep.clip];
                self.buf.reward[i] = (s / c as f64) as f32;
            }
        }
    }
}
