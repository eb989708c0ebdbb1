//! The SkillMimic imitation task (with the SkillMimic-V2 parts): imitate a reference clip of
//! human–ball interaction, rewarded by the unified HOI reward.
//!
//! Per environment and step: the observation of the new state (902, plus the history embedding μ
//! when the V2 encoder is on), the reward against the episode's reference frame (every sub-term
//! kept in `reward::TERM_NAMES` order), the simulated contact graph (info, `hoi::cg_names`), the
//! frame metrics ([`FRAME_METRIC_NAMES`]) and the termination flags. Episode starts: reference
//! state initialisation, or the SkillMimic-V2 variants (State Transition Field, Stitched
//! Trajectory Graph, Adaptive Trajectory Sampling) when switched on in `[env.v2]`.
//!
//! [`SkillEnv`] = the batched driver running this task; its constructors and task-specific
//! accessors are in [`mod@env`].

pub mod env;

use std::sync::Arc;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{EnvState, ResetState, Scene};

use crate::config::{EnvConfig, MaskedReward, StateInit};
use crate::episode::{Episode, fill_from_clip, random_ball};
use crate::hoi::{ContactGraph, HoiState, dist};
use crate::obs::{layout, write_observation};
use crate::reward::{self, NUM_TERMS, TERM_NAMES};
use crate::task::{StepOut, Task, TaskSpec};
use crate::v2::ats::AdaptiveSampler;
use crate::v2::graph::StitchGraph;
use crate::v2::history::{HistoryBuffer, HistoryEncoder, observe};
use crate::v2::similarity::bridge_steps;
use crate::v2::transition::{connect, perturb};
use crate::vec_env::VecEnv;

pub use env::{BUILTIN_DEMO, load_motion_library};

/// The batched environment running the imitation task.
pub type SkillEnv = VecEnv<Imitation>;

/// Per-step evaluation errors stored for every environment.
pub const NUM_FRAME_METRICS: usize = 4;
/// Names of the frame metrics: body error (m, mean Euclidean error of root + 17 key bodies),
/// ball error (m), contact graph matches the reference (0/1), contact-graph squared error.
/// Per-environment episode fields of the imitation task (`Env::episode_info`): the clip (library
/// index), the reference frame the episode started at, the current reference frame, the steps
/// taken, the episode's length in steps and the skill label.
pub const EPISODE_NAMES: [&str; 6] =
    ["clip", "ref_start", "ref_frame", "progress", "length", "skill"];

pub const FRAME_METRIC_NAMES: [&str; NUM_FRAME_METRICS] =
    ["body_err", "ball_err", "cg_match", "cg_sq_err"];

/// How a pending reset starts (SkillMimic-V2 plans; `Plain` otherwise).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ResetPlan {
    /// Reference-state initialisation at the sampled (clip, frame).
    Plain,
    /// Perturbed start, connected after forward kinematics to the most similar frame of the clip.
    Connect,
    /// Start state of the sampled (clip, frame), imitating another skill (graph connection).
    Switch,
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
    ep.masked_steps = bridge_steps(beta, b.max_masked_steps, b.tau, cfg.compat);
    ep.inserted = match b.masked_reward(cfg.compat) {
        MaskedReward::Exclude => ep.masked_steps,
        MaskedReward::ReplaceWithClipMean => 0,
    };
}

/// Per-environment state of the imitation task.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ImitationSlot {
    pub episode: Episode,
    /// The history buffer (`None` without the SkillMimic-V2 history encoder).
    pub history: Option<HistoryBuffer>,
    /// The pending or last reset plan.
    pub plan: ResetPlan,
    /// (clip, frame) the physical start state came from (with `env.compat = "paper"` its
    /// reference rows fill the history at the reset; with an STG switch the imitated clip
    /// differs).
    pub source: (usize, usize),
}

/// The imitation task: configuration, motion library and the SkillMimic-V2 state shared by all
/// environments (parts that are switched off stay empty).
pub struct Imitation {
    pub(crate) cfg: EnvConfig,
    pub(crate) lib: Arc<MotionLibrary>,
    spec: TaskSpec,
    ball_radius: f64,
    pub(crate) encoder: Option<Arc<HistoryEncoder>>,
    /// `[clip][T × 316]` reference history features.
    ref_features: Vec<Vec<f32>>,
    pub(crate) graph: Option<StitchGraph>,
    pub(crate) ats: Option<AdaptiveSampler>,
    /// Per clip (reward sum, count) scratch of the masked-reward compatibility mode.
    clip_sums: Vec<(f64, usize)>,
    /// Skill condition forced on every new episode (transition success rate evaluation).
    pub(crate) skill_override: Option<u32>,
}

impl Task for Imitation {
    type Slot = ImitationSlot;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }

    fn new_slot(&self) -> ImitationSlot {
        ImitationSlot {
            episode: Episode::new(self.lib.get(0), 0, 2, self.cfg.episode_length),
            history: self.encoder.as_ref().map(|e| HistoryBuffer::new(e)),
            plan: ResetPlan::Plain,
            source: (0, 2),
        }
    }

    /// Choose a clip and start frame (class-balanced clip and uniform frame 2…T−2, the
    /// configured frame, or the adaptive sampler), then the SkillMimic-V2 start variants: with
    /// probability p_n a perturbed start (connected to the clip after forward kinematics, in
    /// `after_reset`), otherwise with probability p_e the imitation of another skill from this
    /// state through the Stitched Trajectory Graph.
    fn plan_reset(
        &mut self,
        _i: usize,
        slot: &mut ImitationSlot,
        rng: &mut ChaCha8Rng,
        _scene: &Scene,
        state: &mut ResetState,
    ) {
        let lib = Arc::clone(&self.lib);
        let (clip, start) = match (self.cfg.state_init, self.ats.as_ref()) {
            (StateInit::Random, Some(ats)) => ats.sample(rng),
            (StateInit::Random, None) => {
                let c = lib.sample_clip(rng);
                (c, lib.sample_start(c, rng))
            }
            (StateInit::Frame(f), _) => {
                let c = lib.sample_clip(rng);
                (c, f.min(lib.get(c).clip.num_frames - 2))
            }
        };
        let m = lib.get(clip);
        let after_getup = slot.episode.skill == 0;
        let mut ep = new_episode(&self.cfg, &lib, clip, start);
        fill_from_clip(state, m, start);
        if ep.ball_free {
            random_ball(state, self.ball_radius, rng);
        }
        let v2 = &self.cfg.v2;
        let mut plan = ResetPlan::Plain;
        if v2.stf.enabled && rng.random::<f64>() < v2.stf.prob {
            perturb(state, &v2.stf.eps, !ep.ball_free, self.cfg.compat, after_getup, rng);
            plan = ResetPlan::Connect;
        } else if v2.stg.enabled && rng.random::<f64>() < v2.stg.prob {
            let conns = self.graph.as_ref().map_or(&[][..], |g| g.connections(clip, start));
            if !conns.is_empty() {
                let c = conns[rng.random_range(0..conns.len())];
                ep = new_episode(&self.cfg, &lib, c.clip, c.frame);
                ep.align = c.align;
                set_bridge(&mut ep, &self.cfg, c.similarity);
                plan = ResetPlan::Switch;
            }
        }
        if let Some(s) = self.skill_override {
            ep.skill = s;
        }
        slot.episode = ep;
        slot.plan = plan;
        slot.source = (clip, start);
    }

    /// Adaptive Trajectory Sampling bookkeeping of a finished episode.
    fn end_episode(&mut self, _i: usize, slot: &ImitationSlot) {
        let ep = &slot.episode;
        if let (Some(ats), true) = (self.ats.as_mut(), ep.progress > 0) {
            ats.record(ep.clip, ep.ref_start, ep.reward_sum / ep.rewarded_horizon().max(1) as f64);
        }
    }

    /// Connect perturbed starts to their clip, fill the history buffer, write the observation.
    ///
    /// `env.compat` decides two details: the history rows come from the physical start state's
    /// (clip, frame) (`paper`) or from the imitated (clip, frame) after the STF/STG resampling
    /// (`code`); the velocity regulariser's "previous" joint velocity for the first step is the
    /// reset state's (`paper`) or zero (`code`).
    fn after_reset(&self, _i: usize, slot: &mut ImitationSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        let ImitationSlot { episode: ep, history, plan, source } = slot;
        let (lib, cfg, enc): (&MotionLibrary, &EnvConfig, _) =
            (&self.lib, &self.cfg, self.encoder.as_deref());
        if *plan == ResetPlan::Connect {
            let m = lib.get(ep.clip);
            let (j, beta) =
                connect(&HoiState::from_sim(st), m, &cfg.reward, ep.ball_free, cfg.compat);
            let skill = ep.skill;
            *ep = new_episode(cfg, lib, ep.clip, j);
            ep.skill = skill;
            set_bridge(ep, cfg, beta);
        }
        if cfg.compat.is_code() {
            ep.prev_dof_vel.fill(0.0);
        } else {
            ep.prev_dof_vel.copy_from_slice(st.dof_vel);
        }
        write_observation(st, ep.skill, &mut obs[..layout::OBS_DIM]);
        if let (Some(enc), Some(h)) = (enc, history.as_mut()) {
            let (clip, frame) =
                if cfg.compat.is_code() { (ep.clip, ep.ref_start) } else { *source };
            h.fill_from_reference(enc, &self.ref_features[clip], frame);
            observe(h, enc, obs, st.dof_pos, !ep.ball_free);
        }
    }

    fn step_env(&self, _i: usize, slot: &mut ImitationSlot, st: &EnvState<'_>, out: StepOut<'_>) {
        let (lib, cfg, enc): (&MotionLibrary, &EnvConfig, _) =
            (&self.lib, &self.cfg, self.encoder.as_deref());
        let ep = &mut slot.episode;
        ep.progress += 1;
        let m = lib.get(ep.clip);
        let frame = ep.ref_frame().min(m.clip.num_frames - 1);
        let sim_hoi = HoiState::from_sim(st);
        let ref_hoi = HoiState::from_reference(m, frame).aligned(&ep.align);
        let mode = cfg.reward.contact_graph;
        let cg_sim = ContactGraph::from_sim(st, mode, cfg.reward.force_threshold);
        let cg_ref = ContactGraph::reference(m.clip.contact[frame] as f64, mode);
        let t = reward::compute(
            &sim_hoi,
            &ep.prev_dof_vel,
            &ref_hoi,
            &cg_sim,
            &cg_ref,
            &cfg.reward,
            cfg.compat,
            ep.ball_free,
        );
        ep.prev_dof_vel = sim_hoi.dof_vel;
        for (o, v) in out.terms.iter_mut().zip(t.as_array()) {
            *o = v as f32;
        }
        *out.reward = if ep.is_masked() { 0.0 } else { t.total as f32 };
        if !ep.is_masked() {
            ep.reward_sum += t.total;
            ep.reward_steps += 1;
        }
        // the mode's entries (`hoi::cg_names`): 4 exact edges or 2 force-threshold nodes
        for (o, &v) in out.info.iter_mut().zip(&cg_sim.values) {
            *o = v as f32;
        }
        // frame metrics
        let mut body = dist(sim_hoi.root_pos, ref_hoi.root_pos);
        for k in 0..sim_hoi.key_pos.len() {
            body += dist(sim_hoi.key_pos[k], ref_hoi.key_pos[k]);
        }
        out.metrics[0] = (body / (1 + sim_hoi.key_pos.len()) as f64) as f32;
        out.metrics[1] = dist(sim_hoi.ball_pos, ref_hoi.ball_pos) as f32;
        out.metrics[2] = f32::from(u8::from(cg_sim.matches(&cg_ref)));
        out.metrics[3] = cg_sim.sq_error(&cg_ref) as f32;

        write_observation(st, ep.skill, &mut out.obs[..layout::OBS_DIM]);
        if let (Some(enc), Some(h)) = (enc, slot.history.as_mut()) {
            // h_t from frames t−k … t−1, then the current frame joins the history
            observe(h, enc, out.obs, st.dof_pos, !ep.ball_free);
        }
        // the get-up skill (label 0) never terminates early in SkillMimic-V2 runs (its released
        // code); SkillMimic's code has no such exemption
        let exempt = ep.skill == 0 && cfg.v2.any();
        let fell = st.pos(0)[2] < cfg.termination_height && ep.progress > 1 && !exempt;
        *out.terminated = u8::from(fell || st.unstable);
        *out.truncated = u8::from(*out.terminated == 0 && ep.progress >= ep.horizon());
    }

    fn observe(&self, slot: &mut ImitationSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        // the history embedding entries keep the value computed at the last step or reset
        write_observation(st, slot.episode.skill, &mut obs[..layout::OBS_DIM]);
    }

    /// Reference-code compatibility of the masked steps (their reward becomes the mean reward of
    /// all environments currently on the same clip), then the sampler's update clock.
    fn after_step(&mut self, slots: &[ImitationSlot], reward: &mut [f32], terms: &[f32]) {
        if self.cfg.v2.bridge.masked_reward(self.cfg.compat) == MaskedReward::ReplaceWithClipMean
            && slots.iter().any(|s| s.episode.masked_steps > 0 && s.episode.is_masked())
        {
            let total = TERM_NAMES.len() - 1;
            let sums = &mut self.clip_sums;
            sums.clear();
            sums.resize(self.lib.len(), (0.0, 0));
            for (i, s) in slots.iter().enumerate() {
                let e = &mut sums[s.episode.clip];
                e.0 += terms[i * NUM_TERMS + total] as f64;
                e.1 += 1;
            }
            for (i, s) in slots.iter().enumerate() {
                if s.episode.masked_steps > 0 && s.episode.is_masked() {
                    let (sum, c) = sums[s.episode.clip];
                    reward[i] = (sum / c as f64) as f32;
                }
            }
        }
        if let Some(ats) = self.ats.as_mut() {
            ats.tick();
        }
    }

    /// [`EPISODE_NAMES`] of the slot's episode.
    fn episode_info(&self, slot: &ImitationSlot, out: &mut [i64]) {
        let e = &slot.episode;
        let v = [e.clip, e.ref_start, e.ref_frame(), e.progress, e.length, e.skill as usize];
        for (o, x) in out.iter_mut().zip(v) {
            *o = x as i64;
        }
    }
    fn library(&self) -> Option<&Arc<MotionLibrary>> {
        Some(&self.lib)
    }
    fn history_window(&self, slot: &ImitationSlot) -> Option<Vec<f32>> {
        slot.history.as_ref().map(|h| h.window())
    }
    /// The adaptive sampler's running state (SkillMimic-V2 ATS; empty without it). The
    /// masked-reward sums are scratch of each step.
    fn save_shared(&self) -> Vec<u8> {
        self.ats
            .as_ref()
            .map_or(Vec::new(), |a| postcard::to_stdvec(&a.saved()).expect("plain numbers encode"))
    }
    fn restore_shared(&mut self, bytes: &[u8]) -> Result<(), String> {
        match (self.ats.as_mut(), bytes.is_empty()) {
            (None, true) => Ok(()),
            (Some(a), false) => {
                let s = postcard::from_bytes(bytes)
                    .map_err(|e| format!("adaptive sampler state unreadable ({e})"))?;
                a.restore(s)
            }
            (None, false) => Err("the saved run used adaptive trajectory sampling \
                (env.v2.ats), this configuration does not"
                .into()),
            (Some(_), true) => Err("this configuration uses adaptive trajectory sampling \
                (env.v2.ats), the saved run did not"
                .into()),
        }
    }
}
