//! `tracking`: motion tracking without the ball — ModSkill's and PHC's task (seed 001 §4;
//! modskill-tokenhsi-facts §1.5), on any clip in the project format or BallPlay-M `.pt` (the
//! body only; the ball is parked 50 m away).
//!
//! * **Reference**: every frame of every clip posed in the environment's own scene (forward
//!   kinematics of the clip's root, joints and their velocities), so a kinematic replay has zero
//!   error ([`reference_frames`]).
//! * **Episode**: starts at a uniformly random frame t₀ ∈ [0, T−2] of a clip drawn with the
//!   library's weights (frame 0 with `random_start = false`) in the clip's state; after step k the
//!   simulation is compared with reference frame t₀ + k; truncated at the clip's last frame;
//!   terminated when the mean body distance exceeds `termination_distance` or the simulation is
//!   unstable.
//! * **Observation** (823 + 24 × bodies): the humanoid entries of the skill observation (0..823,
//!   heading frame) | the reference block of the *next* frame ([`formulas::write_reference_obs`]).
//! * **Reward** ([`formulas::reward`]): 0.5·e^(−100·mean‖Δp‖²) + 0.3·e^(−10·mean θ²) +
//!   0.1·e^(−0.1·mean‖Δv‖²) + 0.1·e^(−0.1·mean‖Δω‖²) − 0.0005·Σ|τ·q̇|, over the tracked bodies.
//! * **Metrics** ([`formulas::METRICS`]): E_g-mpjpe and E_mpjpe (mm), velocity and acceleration
//!   errors of the body positions (mm/frame, mm/frame²; before the episode start the simulated
//!   trajectory counts as the reference's), success. Info: `clip`, `ref_frame`.

pub mod formulas;

use std::sync::Arc;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::skillmimic::{NUM_BODIES, NUM_DOFS};
use skillmimic_core::math::Quat;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{EnvState, ResetState, Scene, SimError};

use crate::config::{EnvConfig, TrackingConfig};
use crate::episode::fill_from_clip;
use crate::error::{EnvError, bad};
use crate::obs::{layout, write_state_obs};
use crate::task::{ActionSpace, StepOut, Task, TaskSpec};
use crate::tasks::imitation::load_motion_library;
use crate::vec_env::{Env, VecEnv};
use formulas::{BodyFrame, METRICS, REF_WIDTH, TERMS};

/// Floats per body per reference frame: position 3, quaternion 4, linear and angular velocity 3 +
/// 3.
const PACKED: usize = 13;

/// Reference body states of one clip (float32, frame-major, [`PACKED`] per body).
#[derive(Clone, Debug, PartialEq)]
pub struct ClipFrames {
    pub frames: usize,
    data: Vec<f32>,
}

impl ClipFrames {
    fn row(&self, t: usize) -> &[f32] {
        let t = t.min(self.frames - 1);
        &self.data[t * NUM_BODIES * PACKED..(t + 1) * NUM_BODIES * PACKED]
    }

    /// The body positions of frame `t` (clamped to the clip).
    pub fn positions(&self, t: usize) -> [[f64; 3]; NUM_BODIES] {
        let row = self.row(t);
        std::array::from_fn(|b| std::array::from_fn(|k| row[b * PACKED + k] as f64))
    }

    /// The body states of frame `t` (clamped to the clip).
    pub fn frame(&self, t: usize) -> BodyFrame {
        let row = self.row(t);
        let at = |b: usize, k: usize| row[b * PACKED + k] as f64;
        BodyFrame {
            pos: self.positions(t),
            quat: std::array::from_fn(|b| {
                Quat::from_wxyz([at(b, 3), at(b, 4), at(b, 5), at(b, 6)])
            }),
            linvel: std::array::from_fn(|b| [at(b, 7), at(b, 8), at(b, 9)]),
            angvel: std::array::from_fn(|b| [at(b, 10), at(b, 11), at(b, 12)]),
        }
    }
}

/// Every frame of every clip of `lib` posed in `scene` (batched resets, no physics step).
pub fn reference_frames(
    scene: Arc<Scene>,
    lib: &MotionLibrary,
) -> Result<Vec<ClipFrames>, SimError> {
    let mut out: Vec<ClipFrames> = lib
        .clips()
        .iter()
        .map(|m| ClipFrames {
            frames: m.clip.num_frames,
            data: vec![0.0; m.clip.num_frames * NUM_BODIES * PACKED],
        })
        .collect();
    crate::episode::pose_clips(scene, lib, |c, t, st| {
        for b in 0..NUM_BODIES {
            let (p, q, lv, av) = (st.pos(b), st.quat(b).to_wxyz(), st.linvel(b), st.angvel(b));
            let flat = [
                p[0], p[1], p[2], q[0], q[1], q[2], q[3], lv[0], lv[1], lv[2], av[0], av[1], av[2],
            ];
            let dst =
                &mut out[c].data[(t * NUM_BODIES + b) * PACKED..(t * NUM_BODIES + b + 1) * PACKED];
            dst.iter_mut().zip(&flat).for_each(|(d, &s)| *d = s as f32);
        }
    })?;
    Ok(out)
}

/// Per-environment episode state.
#[derive(Clone, Debug)]
pub struct TrackSlot {
    pub clip: usize,
    /// The reference frame the simulation is compared with now.
    pub frame: usize,
    /// Whether the mean body distance exceeded `success_distance` in this episode.
    pub failed: bool,
    /// Simulated body positions one and two frames ago (newest last).
    hist: [[[f64; 3]; NUM_BODIES]; 2],
}

impl Default for TrackSlot {
    fn default() -> Self {
        Self { clip: 0, frame: 0, failed: false, hist: [[[0.0; 3]; NUM_BODIES]; 2] }
    }
}

/// The `tracking` task.
pub struct Tracking {
    cfg: TrackingConfig,
    lib: Arc<MotionLibrary>,
    refs: Vec<ClipFrames>,
    bodies: Vec<usize>,
    spec: TaskSpec,
    force_limit: f64,
    /// Which joint coordinates are actuated (welded fingers are not).
    active: Vec<bool>,
    /// The action rows of the current step (`N × 156`), for the power penalty.
    targets: Vec<f32>,
    /// Cumulative clip weights: library weights × `clip_weights` multipliers.
    cumulative: Vec<f64>,
}

impl Tracking {
    /// The task over `lib`, posed in `scene`.
    pub fn new(
        cfg: &EnvConfig,
        lib: Arc<MotionLibrary>,
        scene: Arc<Scene>,
    ) -> Result<Self, EnvError> {
        let t = cfg.tracking.clone();
        let bodies = formulas::tracked_bodies(t.fingers);
        let refs = reference_frames(scene.clone(), &lib)?;
        let longest = refs.iter().map(|r| r.frames).max().unwrap_or(2);
        let opts = cfg.scene_options()?;
        let welded = opts.character
            == skillmimic_sim::Character::SkillMimic { hands: skillmimic_sim::HandModel::Box };
        let active = (0..NUM_DOFS)
            .map(|j| !(welded && skillmimic_core::characters::skillmimic::is_finger(j / 3 + 1)))
            .collect();
        let spec = TaskSpec {
            name: "tracking",
            obs_dim: layout::HUMANOID_DIM + REF_WIDTH * bodies.len(),
            action_space: ActionSpace::Box { dim: NUM_DOFS },
            max_episode_steps: longest - 1,
            term_names: TERMS.to_vec(),
            metric_names: METRICS.to_vec(),
            info_names: vec!["clip".into(), "ref_frame".into()],
            steps_per_action: 1,
            choice_labels: Vec::new(),
            token_groups: Vec::new(),
        };
        let cumulative =
            lib.cumulative_weighted(|c| t.clip_weights.get(&c.name).copied().unwrap_or(1.0));
        Ok(Self {
            cfg: t,
            lib,
            refs,
            bodies,
            spec,
            force_limit: skillmimic_core::characters::skillmimic::FORCE_LIMIT,
            active,
            targets: vec![0.0; cfg.num_envs * NUM_DOFS],
            cumulative,
        })
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

    fn write_obs(&self, slot: &TrackSlot, sim: &BodyFrame, st: &EnvState<'_>, obs: &mut [f32]) {
        let mut state = [0.0f32; layout::STATE_DIM];
        write_state_obs(st, &mut state);
        obs[..layout::HUMANOID_DIM].copy_from_slice(&state[..layout::HUMANOID_DIM]);
        let next = self.refs[slot.clip].frame(slot.frame + 1);
        formulas::write_reference_obs(sim, &next, &self.bodies, &mut obs[layout::HUMANOID_DIM..]);
    }
}

impl Task for Tracking {
    type Slot = TrackSlot;

    fn spec(&self) -> &TaskSpec {
        &self.spec
    }
    fn new_slot(&self) -> TrackSlot {
        TrackSlot::default()
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
        fill_from_clip(state, self.lib.get(clip), start);
        // the ball plays no part: parked at rest far from the humanoid
        let ball = state.ball_mut();
        ball.pos = [50.0, 50.0, 0.5];
        ball.linvel = [0.0; 3];
        ball.angvel_local = [0.0; 3];
        *slot = TrackSlot {
            clip,
            frame: start,
            failed: false,
            hist: [self.refs[clip].positions(start.saturating_sub(1)), [[0.0; 3]; NUM_BODIES]],
        };
    }

    fn after_reset(&self, _i: usize, slot: &mut TrackSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        let sim = BodyFrame::from_state(st);
        slot.hist[1] = sim.pos;
        self.write_obs(slot, &sim, st, obs);
    }

    fn step_env(&self, i: usize, slot: &mut TrackSlot, st: &EnvState<'_>, out: StepOut<'_>) {
        slot.frame += 1;
        let refs = &self.refs[slot.clip];
        let (sim, r) = (BodyFrame::from_state(st), refs.frame(slot.frame));
        let e = formulas::errors(&sim, &r, &self.bodies);
        let power = formulas::power(
            st,
            &self.targets[i * NUM_DOFS..(i + 1) * NUM_DOFS],
            &self.active,
            self.force_limit,
        );
        let terms = formulas::reward(&e, power, &self.cfg);
        out.terms.iter_mut().zip(&terms).for_each(|(o, &v)| *o = v as f32);
        *out.reward = terms[5] as f32;
        let (p0, p1) =
            (refs.positions(slot.frame.saturating_sub(2)), refs.positions(slot.frame - 1));
        let (ve, ae) = formulas::vel_acc_errors(
            [&slot.hist[0], &slot.hist[1], &sim.pos],
            [&p0, &p1, &r.pos],
            &self.bodies,
        );
        slot.hist = [slot.hist[1], sim.pos];
        slot.failed |= e.dist > self.cfg.success_distance;
        let end = slot.frame + 1 >= refs.frames;
        let terminated = e.dist > self.cfg.termination_distance || st.unstable;
        let success = end && !terminated && !slot.failed;
        out.metrics.copy_from_slice(&[
            (1e3 * e.dist) as f32,
            (1e3 * e.dist_rel) as f32,
            (1e3 * ve) as f32,
            (1e3 * ae) as f32,
            f32::from(u8::from(success)),
        ]);
        out.info.copy_from_slice(&[slot.clip as f32, slot.frame as f32]);
        self.write_obs(slot, &sim, st, out.obs);
        *out.terminated = u8::from(terminated);
        *out.truncated = u8::from(!terminated && end);
    }

    fn reset_info(&self, slot: &TrackSlot, info: &mut [f32]) {
        info.copy_from_slice(&[slot.clip as f32, slot.frame as f32]);
    }

    fn observe(&self, slot: &mut TrackSlot, st: &EnvState<'_>, obs: &mut [f32]) {
        self.write_obs(slot, &BodyFrame::from_state(st), st, obs);
    }

    fn transforms_actions(&self) -> bool {
        true
    }
    /// The actions are the PD targets; they are kept for the power penalty.
    fn actions_to_targets(
        &mut self,
        _slots: &[TrackSlot],
        _obs: &[f32],
        actions: &[f32],
        targets: &mut [f32],
    ) -> Result<(), EnvError> {
        targets.copy_from_slice(actions);
        self.targets.resize(actions.len(), 0.0);
        self.targets.copy_from_slice(actions);
        Ok(())
    }
}

/// Registry constructor: the `tracking` task from `[env]` (driver keys, `motion`) and
/// `[env.tracking]`.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.validate_driver()?;
    cfg.tracking.validate()?;
    let lib = Arc::new(load_motion_library(&cfg.motion)?);
    if let Some(c) = lib.clips().iter().find(|m| m.clip.num_frames < 2) {
        return Err(bad(
            "env.motion",
            format!(
                "a clip of skill {} has {} frame(s); tracking needs at least 2",
                c.clip.skill, c.clip.num_frames
            ),
        )
        .into());
    }
    let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
    let task = Tracking::new(cfg, lib, scene.clone())?;
    Ok(Box::new(VecEnv::with_task(task, scene, cfg.num_envs, cfg.threads, cfg.start_seed(0))?))
}
