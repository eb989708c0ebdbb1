//! `tracking`: motion tracking without the ball — ModSkill's and PHC's task (seed 001 §4;
//! modskill-tokenhsi-facts §1.5), on the SkillMimic humanoid (project / BallPlay-M clips, the
//! body only; the ball is parked 50 m away) or the SMPL humanoid (its `character-clip`s, or
//! SkillMimic-skeleton clips retargeted by joint name on load; [`motion`]).
//!
//! * **Reference**: every frame of every clip posed in the environment's own scene (forward
//!   kinematics of the clip's root, joints and their velocities), so a kinematic replay has zero
//!   error ([`reference_frames`]).
//! * **Episode**: starts at a uniformly random frame t₀ ∈ [0, T−2] of a clip drawn with the
//!   library's weights (frame 0 with `random_start = false`) in the clip's state; after step k the
//!   simulation is compared with reference frame t₀ + k; truncated at the clip's last frame;
//!   terminated when the mean distance of the judged bodies (SMPL: all but the ankles and toes,
//!   as released) exceeds `termination_distance` from the second step on, or when the
//!   simulation is unstable.
//! * **Observation** (P + 24 × bodies): the character's proprioception ([`crate::proprio`]; the
//!   SkillMimic humanoid's 823, the SMPL humanoid's 358) | the reference block of the *next*
//!   frame ([`formulas::write_reference_obs`]).
//! * **Reward** ([`formulas::reward`]): 0.5·e^(−100·mean Δp²) + 0.3·e^(−10·mean θ²) +
//!   0.1·e^(−0.1·mean Δv²) + 0.1·e^(−0.1·mean Δω²) − 0.0005·Σ|τ·q̇|, over the tracked
//!   bodies; as the released ModSkill code, a vector error's mean runs over the bodies and its
//!   x, y, z components (`error_mean = "vector"`: the paper's squared norms), the power penalty
//!   is zero for the first 3 steps of an episode and the distance rule skips its first step.
//! * **Metrics** ([`formulas::METRICS`]): E_g-mpjpe and E_mpjpe (mm), velocity and acceleration
//!   errors of the body positions (mm/frame, mm/frame²; before the episode start the simulated
//!   trajectory counts as the reference's), success. Info: `clip`, `ref_frame`.

pub mod config;
pub mod formulas;
pub mod motion;
pub mod prior;

use std::sync::Arc;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::CharacterSpec;
use skillmimic_core::math::Quat;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{EnvState, ResetState, Scene, SimError};

use crate::config::EnvConfig;
use crate::error::{EnvError, bad};
use crate::task::{ActionSpace, StepOut, Task, TaskSpec};
use crate::vec_env::{Env, VecEnv};
use config::TrackingConfig;
use formulas::{Bodies, METRICS, REF_WIDTH, TERMS};
use motion::Motion;

/// The `[env.tracking]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<config::TrackingConfig>();

/// Floats per body per reference frame: position 3, quaternion 4, linear and angular velocity 3 +
/// 3.
const PACKED: usize = 13;

/// Evaluation episode starts: tracking episodes run to the clip's end, from frame 0
/// (`start_frame` 0: whole clips, `random_start` off) or from random frames (nothing given).
pub fn episode_starts(cfg: &mut EnvConfig, s: crate::task::EpisodeStarts) -> Result<(), String> {
    match (s.horizon, s.start_frame) {
        (None, None) => Ok(()),
        (None, Some(0)) => {
            cfg.table_mut::<TrackingConfig>().random_start = false;
            Ok(())
        }
        (None, Some(f)) => Err(format!(
            "--start-frame {f}: the tracking task evaluates from frame 0 (--start-frame 0, whole \
                clips) or from random frames (no flag)"
        )),
        (Some(h), _) => {
            Err(format!("--horizon {h}: tracking episodes run to the end of their clip"))
        }
    }
}

/// The observation: the character's proprioception, then the reference part
/// ([`formulas::REF_WIDTH`] per tracked body).
pub const LAYOUT: crate::obs_blocks::ObsLayout =
    crate::obs_blocks::ObsLayout::Proprio { part: "reference" };

/// Reference body states of one clip (float32, frame-major, `PACKED` per body).
#[derive(Clone, Debug, PartialEq)]
pub struct ClipFrames {
    pub frames: usize,
    bodies: usize,
    data: Vec<f32>,
}

/// One reference frame: the bodies' states (a view of [`ClipFrames`]).
#[derive(Clone, Copy, Debug)]
pub struct RefFrame<'a> {
    row: &'a [f32],
}

impl RefFrame<'_> {
    fn at(&self, b: usize, k: usize) -> f64 {
        self.row[b * PACKED + k] as f64
    }
}

impl Bodies for RefFrame<'_> {
    fn pos(&self, b: usize) -> [f64; 3] {
        [self.at(b, 0), self.at(b, 1), self.at(b, 2)]
    }
    fn quat(&self, b: usize) -> Quat {
        Quat::from_wxyz([self.at(b, 3), self.at(b, 4), self.at(b, 5), self.at(b, 6)])
    }
    fn linvel(&self, b: usize) -> [f64; 3] {
        [self.at(b, 7), self.at(b, 8), self.at(b, 9)]
    }
    fn angvel(&self, b: usize) -> [f64; 3] {
        [self.at(b, 10), self.at(b, 11), self.at(b, 12)]
    }
}

impl ClipFrames {
    /// The body states of frame `t` (clamped to the clip).
    pub fn frame(&self, t: usize) -> RefFrame<'_> {
        let (t, w) = (t.min(self.frames - 1), self.bodies * PACKED);
        RefFrame { row: &self.data[t * w..(t + 1) * w] }
    }
}

/// Every frame of every clip of `motion` posed in `scene` (batched resets, no physics step).
pub fn reference_frames(scene: Arc<Scene>, motion: &Motion) -> Result<Vec<ClipFrames>, SimError> {
    let nb = scene.num_character_bodies();
    let mut out: Vec<ClipFrames> = (0..motion.len())
        .map(|c| ClipFrames {
            frames: motion.frames(c),
            bodies: nb,
            data: vec![0.0; motion.frames(c) * nb * PACKED],
        })
        .collect();
    motion.pose(scene, |c, t, st| {
        for b in 0..nb {
            let (p, q, lv, av) = (st.pos(b), st.quat(b).to_wxyz(), st.linvel(b), st.angvel(b));
            let flat = [
                p[0], p[1], p[2], q[0], q[1], q[2], q[3], lv[0], lv[1], lv[2], av[0], av[1], av[2],
            ];
            let dst = &mut out[c].data[(t * nb + b) * PACKED..(t * nb + b + 1) * PACKED];
            dst.iter_mut().zip(&flat).for_each(|(d, &s)| *d = s as f32);
        }
    })?;
    Ok(out)
}

/// Per-environment episode state.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct TrackSlot {
    pub clip: usize,
    /// The reference frame the simulation is compared with now.
    pub frame: usize,
    /// Steps since the episode's reset (1 after the first; the released `progress_buf`).
    #[serde(default)]
    pub steps: usize,
    /// Whether the mean body distance exceeded `success_distance` in this episode.
    pub failed: bool,
    /// Simulated body positions two frames and one frame ago.
    older: Vec<[f64; 3]>,
    old: Vec<[f64; 3]>,
}

/// The `tracking` task.
pub struct Tracking {
    cfg: TrackingConfig,
    motion: Motion,
    refs: Vec<ClipFrames>,
    bodies: Vec<usize>,
    /// The bodies of the termination and success distance when they are not the tracked ones
    /// (`None`: the tracked bodies, whose mean distance `errors` already gives).
    judged: Option<Vec<usize>>,
    spec: TaskSpec,
    character: CharacterSpec,
    /// Cumulative clip weights: library weights × `clip_weights` multipliers.
    cumulative: Vec<f64>,
    /// The motion prior's state features of the character (the SMPL humanoid's released ones,
    /// [`prior`]); `None`: the prior reads the observation.
    prior: Option<(usize, prior::Features)>,
}

impl Tracking {
    /// The task over `motion`, posed in `scene`.
    pub fn new(cfg: &EnvConfig, motion: Motion, scene: Arc<Scene>) -> Result<Self, EnvError> {
        let t = cfg.table::<TrackingConfig>().clone();
        let character = scene.character().clone();
        let bodies = formulas::tracked_bodies(&character, t.fingers);
        let judged = formulas::termination_bodies(&character, &bodies, &t)
            .map_err(|e| bad("env.tracking.termination_bodies", e))?;
        let judged = (judged != bodies).then_some(judged);
        let refs = reference_frames(scene, &motion)?;
        let longest = refs.iter().map(|r| r.frames).max().unwrap_or(2);
        let nd = character.num_dofs;
        let p = character.proprio_dim();
        let obs_blocks = LAYOUT.blocks(&character, p + REF_WIDTH * bodies.len());
        let spec = TaskSpec {
            name: "tracking",
            obs_dim: p + REF_WIDTH * bodies.len(),
            action_space: ActionSpace::Box { dim: nd },
            max_episode_steps: longest - 1,
            term_names: crate::task::names(&TERMS),
            metric_names: crate::task::names(&METRICS),
            info_names: vec!["clip".into(), "ref_frame".into()],
            obs_blocks,
            body_blocks: bodies
                .iter()
                .enumerate()
                .map(|(k, &b)| (b, p + REF_WIDTH * k..p + REF_WIDTH * (k + 1)))
                .collect(),
            episode_names: vec!["clip", "ref_frame"],
            ..TaskSpec::default()
        };
        let cumulative = motion.cumulative(|name| t.clip_weights.get(name).copied().unwrap_or(1.0));
        if cumulative.last().is_none_or(|&total| !(total > 0.0 && total.is_finite())) {
            let msg = format!(
                "every clip's sampling weight is 0 ({:?}); at least one clip must keep a weight",
                t.clip_weights
            );
            return Err(bad("env.tracking.clip_weights", msg).into());
        }
        let prior = (character.name == skillmimic_core::characters::smpl::ENTRY.name)
            .then_some((prior::SMPL_PRIOR_DIM, prior::smpl_features as prior::Features));
        Ok(Self { cfg: t, motion, refs, bodies, judged, spec, character, cumulative, prior })
    }

    /// The probability of each clip (library order) to start an episode.
    pub fn clip_probabilities(&self) -> Vec<f64> {
        let total = self.cumulative[self.cumulative.len() - 1];
        let mut prev = 0.0;
        self.cumulative.iter().map(|&c| (c - std::mem::replace(&mut prev, c)) / total).collect()
    }

    /// The reference frames of clip `c`.
    pub fn reference(&self, c: usize) -> &ClipFrames {
        &self.refs[c]
    }
    /// The tracked bodies.
    pub fn tracked_bodies(&self) -> &[usize] {
        &self.bodies
    }
    /// The SkillMimic clip library (`None` on another character).
    pub fn library(&self) -> Option<&Arc<MotionLibrary>> {
        self.motion.library()
    }

    fn write_obs(&self, slot: &TrackSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        let p = self.character.proprio_dim();
        crate::proprio::write_for(&self.character, st, &mut obs[..p]);
        let next = self.refs[slot.clip].frame(slot.frame + 1);
        formulas::write_reference_obs(st, &next, &self.bodies, &mut obs[p..]);
    }
}

fn positions(st: &EnvState<'_>, out: &mut [[f64; 3]]) {
    for (b, o) in out.iter_mut().enumerate() {
        *o = st.pos(b);
    }
}

impl Task for Tracking {
    type Slot = TrackSlot;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    /// On the SMPL humanoid, the released discriminator features ([`prior::smpl_features`]).
    fn style_dim(&self) -> usize {
        self.prior.map_or(0, |p| p.0)
    }
    fn style_features(&self, st: &EnvState<'_>, out: &mut [f32]) {
        if let Some((_, f)) = self.prior {
            f(st, out);
        }
    }
    fn new_slot(&self) -> TrackSlot {
        let n = self.character.bodies.len();
        TrackSlot { older: vec![[0.0; 3]; n], old: vec![[0.0; 3]; n], ..TrackSlot::default() }
    }
    /// `clip` and `ref_frame` of the slot.
    fn episode_info(&self, slot: &TrackSlot, out: &mut [i64]) {
        out[0] = slot.clip as i64;
        out[1] = slot.frame as i64;
    }

    fn plan_reset(
        &mut self,
        _i: usize,
        slot: &mut TrackSlot,
        rng: &mut ChaCha8Rng,
        _scene: &Scene,
        state: &mut ResetState,
    ) {
        let clip = skillmimic_motion::library::sample_cumulative(&self.cumulative, rng);
        let frames = self.refs[clip].frames;
        let start = if self.cfg.random_start { rng.random_range(0..=frames - 2) } else { 0 };
        self.motion.fill_state(&self.character, clip, start, state);
        slot.clip = clip;
        slot.frame = start;
        slot.steps = 0;
        slot.failed = false;
        let r = self.refs[clip].frame(start.saturating_sub(1));
        for (b, o) in slot.older.iter_mut().enumerate() {
            *o = r.pos(b);
        }
        slot.old.fill([0.0; 3]);
    }

    fn after_reset(&self, _i: usize, slot: &mut TrackSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        positions(st, &mut slot.old);
        self.write_obs(slot, st, obs);
    }

    fn step_env(&self, _i: usize, slot: &mut TrackSlot, st: &EnvState<'_>, out: StepOut<'_>) {
        slot.frame += 1;
        slot.steps += 1;
        let refs = &self.refs[slot.clip];
        let r = refs.frame(slot.frame);
        let e = formulas::errors(st, &r, &self.bodies);
        let power = match formulas::power_counts(slot.steps, &self.cfg) {
            true => st.drive_power(),
            false => 0.0,
        };
        let terms = formulas::reward(&e, power, &self.cfg);
        out.terms.iter_mut().zip(&terms).for_each(|(o, &v)| *o = v as f32);
        *out.reward = terms[5] as f32;
        let (r0, r1) = (refs.frame(slot.frame.saturating_sub(2)), refs.frame(slot.frame - 1));
        let (ve, ae) = formulas::vel_acc_errors(
            [&|b| slot.older[b], &|b| slot.old[b], &|b| st.pos(b)],
            [&|b| r0.pos(b), &|b| r1.pos(b), &|b| r.pos(b)],
            &self.bodies,
        );
        // the history moves on one frame (no allocation: the oldest buffer takes the newest)
        std::mem::swap(&mut slot.older, &mut slot.old);
        positions(st, &mut slot.old);
        let dist = self.judged.as_ref().map_or(e.dist, |j| formulas::mean_distance(st, &r, j));
        let judged = formulas::distance_rule_applies(slot.steps, &self.cfg);
        slot.failed |= judged && dist > self.cfg.success_distance;
        let end = slot.frame + 1 >= refs.frames;
        let terminated = formulas::terminates(dist, slot.steps, &self.cfg) || st.unstable;
        let success = end && !terminated && !slot.failed;
        out.metrics.copy_from_slice(&[
            (1e3 * e.dist) as f32,
            (1e3 * e.dist_rel) as f32,
            (1e3 * ve) as f32,
            (1e3 * ae) as f32,
            f32::from(u8::from(success)),
        ]);
        out.info.copy_from_slice(&[slot.clip as f32, slot.frame as f32]);
        self.write_obs(slot, st, out.obs);
        *out.terminated = u8::from(terminated);
        *out.truncated = u8::from(!terminated && end);
    }

    /// Frame `frame` (clamped to the clip) of clip `clip` as the episode starts there.
    fn reference_state(&self, clip: usize, frame: usize, state: &mut ResetState) -> bool {
        if clip >= self.refs.len() {
            return false;
        }
        let t = frame.min(self.refs[clip].frames - 1);
        self.motion.fill_state(&self.character, clip, t, state);
        true
    }

    fn reset_info(&self, slot: &TrackSlot, info: &mut [f32]) {
        info.copy_from_slice(&[slot.clip as f32, slot.frame as f32]);
    }

    fn observe(&self, slot: &mut TrackSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        self.write_obs(slot, st, obs);
    }
}

/// Registry constructor: the `tracking` task from `[env]` (driver keys, the character,
/// `motion`) and `[env.tracking]`.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.table::<TrackingConfig>().validate()?;
    let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
    let character = cfg.resolved_character()?;
    let motion = Motion::load(&cfg.motion, character)?;
    if let Some(c) = (0..motion.len()).find(|&c| motion.frames(c) < 2) {
        let msg = format!(
            "clip '{}' has {} frame(s); tracking needs at least 2",
            motion.name(c),
            motion.frames(c)
        );
        return Err(bad("env.motion", msg).into());
    }
    let task = Tracking::new(cfg, motion, scene.clone())?;
    Ok(Box::new(VecEnv::with_task(task, scene, cfg.num_envs, cfg.threads, cfg.start_seed(0))?))
}
