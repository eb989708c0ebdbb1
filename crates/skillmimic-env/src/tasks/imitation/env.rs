//! Building the imitation task and the accessors of [`SkillEnv`] that only it has (episodes,
//! motion library, SkillMimic-V2 diagnostics, evaluation options).

use std::path::PathBuf;
use std::sync::Arc;

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::Scene;

use super::{EPISODE_NAMES, FRAME_METRIC_NAMES, Imitation, ResetPlan, SkillEnv};
use crate::config::EnvConfig;
use crate::episode::Episode;
use crate::error::{EnvError, bad};
use crate::hoi::cg_names;
use crate::obs::layout;
use crate::reward::TERM_NAMES;
use crate::task::{ActionSpace, TaskSpec};
use crate::v2::ats::AdaptiveSampler;
use crate::v2::graph::StitchGraph;
use crate::v2::history::{HistoryEncoder, reference_features};
use crate::vec_env::VecEnv;

pub use crate::config::BUILTIN_DEMO;

/// Load a motion library from clip files/folders; the entry `builtin:demo` stands for the
/// procedurally synthesised demo clips (identical to the shipped `motions/` files).
pub fn load_motion_library(paths: &[PathBuf]) -> Result<MotionLibrary, EnvError> {
    let (builtin, files): (Vec<_>, Vec<_>) =
        paths.iter().cloned().partition(|p| p.as_os_str() == BUILTIN_DEMO);
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

impl Imitation {
    /// The task for `cfg` over `lib` in `scene` (reference history features and the Stitched
    /// Trajectory Graph are computed here when switched on; `threads` sizes the pool that builds
    /// the graph).
    pub fn new(
        cfg: EnvConfig,
        lib: Arc<MotionLibrary>,
        scene: &Arc<Scene>,
        threads: usize,
    ) -> Result<Self, EnvError> {
        cfg.validate()?;
        let (mut encoder, mut ref_features) = (None, Vec::new());
        if cfg.v2.history.enabled {
            encoder = Some(Arc::new(HistoryEncoder::load(&cfg.v2.history.encoder)?));
            ref_features = reference_features(Arc::clone(scene), &lib)?;
        }
        let graph = if cfg.v2.stg.enabled {
            // built on a pool of the simulation's size (0 = one thread per core)
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| bad("env.threads", format!("cannot start {threads} threads: {e}")))?;
            Some(pool.install(|| StitchGraph::build(&lib, &cfg.reward, cfg.v2.bridge.tau)))
        } else {
            None
        };
        let ats = cfg.v2.ats.enabled.then(|| {
            // before its first update: class-uniform clips (paper) or the library's
            // class-balanced weights with pickup counted twice (released code)
            let initial = cfg.compat.is_code().then(|| lib.weights());
            AdaptiveSampler::new(&lib, &cfg.v2.ats, initial)
        });
        let spec = TaskSpec {
            name: "imitation",
            obs_dim: layout::OBS_DIM + encoder.as_ref().map_or(0, |e| e.embed_dim()),
            action_space: ActionSpace::Box { dim: NUM_DOFS },
            // an episode covers frames start … start + length − 1: length − 1 steps
            max_episode_steps: if cfg.fixed_horizon > 0 {
                cfg.fixed_horizon
            } else {
                cfg.episode_length - 1
            },
            term_names: crate::task::names(&TERM_NAMES),
            metric_names: crate::task::names(&FRAME_METRIC_NAMES),
            info_names: cg_names(cfg.reward.contact_graph).iter().map(|s| s.to_string()).collect(),
            obs_blocks: crate::obs_blocks::skillmimic_blocks(
                crate::obs::layout::OBS_DIM,
                encoder.as_ref().map_or(0, |e| e.embed_dim()),
            ),
            info_label: "contact_graph",
            episode_names: EPISODE_NAMES.to_vec(),
            ..TaskSpec::default()
        };
        // random balls of ball-free clips are placed with the radius actually simulated
        let ball_radius = scene.options().ball.map_or(0.0, |b| b.radius);
        Ok(Self {
            cfg,
            lib,
            spec,
            ball_radius,
            encoder,
            ref_features,
            graph,
            ats,
            clip_sums: Vec::new(),
            skill_override: None,
        })
    }
}

impl VecEnv<Imitation> {
    /// Build the scene, the task and the batch, and reset every environment (episode starts
    /// seeded with `cfg.start_seed(0)`).
    pub fn new(cfg: EnvConfig, lib: Arc<MotionLibrary>) -> Result<Self, EnvError> {
        cfg.validate()?;
        let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
        let (n, threads, seed) = (
            cfg.num_envs,
            crate::config_range::capped_threads(cfg.threads, "env.threads"),
            cfg.start_seed(0),
        );
        let task = Imitation::new(cfg, lib, &scene, threads)?;
        VecEnv::with_task(task, scene, n, threads, seed)
    }

    /// Load the motion library named in the config, then build the environment.
    pub fn from_config(cfg: EnvConfig) -> Result<Self, EnvError> {
        cfg.validate()?;
        let lib = Arc::new(load_motion_library(&cfg.motion)?);
        Self::new(cfg, lib)
    }

    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.task.cfg
    }
    /// The motion library.
    pub fn library(&self) -> &Arc<MotionLibrary> {
        &self.task.lib
    }
    /// Episode state of environment `i`.
    pub fn episode(&self, i: usize) -> &Episode {
        &self.slots[i].episode
    }
    /// Episode states of every environment, in environment order.
    pub fn episodes(&self) -> impl ExactSizeIterator<Item = &Episode> {
        self.slots.iter().map(|s| &s.episode)
    }
    /// The pending or last reset plan of environment `i` (SkillMimic-V2 diagnostics).
    pub fn reset_plan(&self, i: usize) -> ResetPlan {
        self.slots[i].plan
    }
    /// The (clip, frame) whose state started the current episode of environment `i` (before any
    /// perturbation; with an STG switch the imitated clip differs).
    pub fn start_source(&self, i: usize) -> (usize, usize) {
        self.slots[i].source
    }
    /// The history encoder, when on.
    pub fn history_encoder(&self) -> Option<&Arc<HistoryEncoder>> {
        self.task.encoder.as_ref()
    }
    /// The current history window of environment `i` (k × 316, oldest first), when on.
    pub fn history_window(&self, i: usize) -> Option<Vec<f32>> {
        self.slots[i].history.as_ref().map(|h| h.window())
    }
    /// The Stitched Trajectory Graph, when on.
    pub fn stitch_graph(&self) -> Option<&StitchGraph> {
        self.task.graph.as_ref()
    }
    /// The adaptive sampler, when on.
    pub fn adaptive_sampler(&self) -> Option<&AdaptiveSampler> {
        self.task.ats.as_ref()
    }
    /// Force the skill condition of every new episode (`None` = the clip's own label); used to
    /// measure transition success (start from one skill's states, ask for another).
    pub fn set_skill_override(&mut self, skill: Option<u32>) {
        self.task.skill_override = skill;
    }
}

/// Registry constructor: the imitation task from the `[env]` table.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn crate::vec_env::Env>, EnvError> {
    Ok(Box::new(SkillEnv::from_config(cfg.clone())?))
}

/// Registry constructor over an already loaded motion library (evaluation and video
/// environments of a training run).
pub fn build_sharing(
    cfg: &EnvConfig,
    lib: Arc<MotionLibrary>,
) -> Result<Box<dyn crate::vec_env::Env>, EnvError> {
    Ok(Box::new(SkillEnv::new(cfg.clone(), lib)?))
}

/// Evaluation episode starts: `horizon` → `fixed_horizon` (steps), `start_frame` → every
/// episode from that reference frame.
pub fn episode_starts(cfg: &mut EnvConfig, s: crate::task::EpisodeStarts) -> Result<(), String> {
    if let Some(h) = s.horizon {
        cfg.fixed_horizon = h;
    }
    if let Some(f) = s.start_frame {
        cfg.state_init = crate::config::StateInit::Frame(f);
    }
    Ok(())
}
