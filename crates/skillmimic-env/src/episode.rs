//! Episode bookkeeping and reference-state initialisation (reference-facts §6).
//!
//! Timing convention (a choice recommended by the facts, differing from both original codes):
//! after a reset to frame s, policy step k moves the simulation from s_{k−1} to s_k and the reward
//! compares the **new** state s_k with reference frame s + k. Forward kinematics runs on reset, so
//! the first reward already sees the right body positions. The episode holds
//! E = min(T − s, episode_length) reference frames and ends (truncation, bootstrapped) after
//! E − 1 steps; it terminates early (no bootstrap) when the root drops below the termination
//! height after the first step, or when MuJoCo reports an instability.

use rand::Rng;
use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::Quat;
use skillmimic_motion::MotionClip;
use skillmimic_motion::reference::vec3_at;
use skillmimic_sim::ResetState;

use crate::hoi::RefAlign;

/// Skill labels of clips without a ball interaction: 0 (get-up) and 10 (run without ball).
pub const BALL_FREE_SKILLS: [u32; 2] = [0, 10];

/// Per-environment episode state.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Episode {
    /// Library index of the reference clip.
    pub clip: usize,
    /// Reference frame that corresponds to the reset state (progress 0).
    pub ref_start: usize,
    /// Number of reference frames E of this episode.
    pub length: usize,
    /// Policy steps taken since the reset.
    pub progress: usize,
    /// Skill label given to the policy (one-hot condition).
    pub skill: u32,
    /// The reference has no ball interaction (ball terms off).
    pub ball_free: bool,
    /// Transform applied to the reference (identity unless a V2 switch re-anchored it).
    pub align: RefAlign,
    /// Steps at the start of the episode whose reward is masked (SkillMimic-V2 bridging).
    pub masked_steps: usize,
    /// Of those, the steps inserted before the reference starts to advance (the reference holds
    /// frame `ref_start` meanwhile): `masked_steps` in the paper's mode, 0 in the reference
    /// code's compatibility mode.
    pub inserted: usize,
    /// Simulated joint velocities of the previous step (regulariser).
    #[serde(with = "skillmimic_core::serde_array")]
    pub prev_dof_vel: [f64; NUM_DOFS],
    /// Sum of rewards and count of rewarded steps in this episode.
    pub reward_sum: f64,
    pub reward_steps: usize,
}

impl Episode {
    /// A fresh episode on `clip` from frame `start`.
    pub fn new(m: &MotionClip, clip: usize, start: usize, max_len: usize) -> Self {
        let skill = m.clip.skill;
        Self {
            clip,
            ref_start: start,
            length: (m.clip.num_frames - start).min(max_len),
            progress: 0,
            skill,
            ball_free: BALL_FREE_SKILLS.contains(&skill),
            align: RefAlign::IDENTITY,
            masked_steps: 0,
            inserted: 0,
            prev_dof_vel: [0.0; NUM_DOFS],
            reward_sum: 0.0,
            reward_steps: 0,
        }
    }

    /// Reference frame index of the current step.
    pub fn ref_frame(&self) -> usize {
        self.ref_start + self.progress.saturating_sub(self.inserted)
    }

    /// Policy steps after which the episode is truncated: E − 1 plus the inserted steps.
    pub fn horizon(&self) -> usize {
        self.length - 1 + self.inserted
    }

    /// Steps whose reward counts (the horizon without the masked steps).
    pub fn rewarded_horizon(&self) -> usize {
        self.horizon().saturating_sub(self.masked_steps)
    }

    /// True while the current step's reward is masked.
    pub fn is_masked(&self) -> bool {
        self.progress <= self.masked_steps
    }
}

/// The physical state of frame `t` of a clip (a SkillMimic scene with the ball): root pose and
/// velocities (root angular velocity in the root frame), joint exp maps and their
/// finite-difference velocities, ball position and velocity with the clip's ball orientation and
/// zero angular velocity.
pub fn reset_state_from_clip(m: &MotionClip, t: usize) -> ResetState {
    let mut s = ResetState::default();
    fill_from_clip(&mut s, m, t);
    s
}

/// [`reset_state_from_clip`] written into `s` in place (no allocation); `s` holds the
/// humanoid's 156 dofs and the ball as object 0.
pub fn fill_from_clip(s: &mut ResetState, m: &MotionClip, t: usize) {
    let (c, r) = (&m.clip, &m.reference);
    s.root_pos = c.root_pos_at(t);
    s.root_quat = c.root_quat_at(t);
    s.root_linvel = vec3_at(&r.root_linvel, t);
    s.root_angvel_local = vec3_at(&r.root_angvel_local, t);
    for (j, (p, v)) in s.dof_pos.iter_mut().zip(s.dof_vel.iter_mut()).enumerate() {
        *p = c.dof_at(t)[j] as f64;
        *v = r.dof_vel[t * NUM_DOFS + j] as f64;
    }
    let ball = s.ball_mut();
    ball.pos = c.ball_pos_at(t);
    ball.quat = c.ball_quat_at(t);
    ball.linvel = vec3_at(&r.ball_linvel, t);
    ball.angvel_local = [0.0; 3];
}

/// Random ball state for clips without a ball: position uniform in [−5, 5]² × [radius, 5] (the
/// original draws z from [−5, 5], i.e. possibly below the floor; we keep it above), velocity
/// uniform in [0, 5]³, a uniformly random orientation, angular velocity uniform in [0, 0.1]³.
pub fn random_ball<R: Rng>(s: &mut ResetState, radius: f64, rng: &mut R) {
    let s = s.ball_mut();
    s.pos =
        [rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0), rng.random_range(radius..5.0)];
    s.linvel = [rng.random_range(0.0..5.0), rng.random_range(0.0..5.0), rng.random_range(0.0..5.0)];
    // uniform random rotation (Shoemake)
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = std::f64::consts::TAU;
    s.quat = Quat {
        w: (1.0 - u1).sqrt() * (tau * u2).sin(),
        x: (1.0 - u1).sqrt() * (tau * u2).cos(),
        y: u1.sqrt() * (tau * u3).sin(),
        z: u1.sqrt() * (tau * u3).cos(),
    };
    s.angvel_local =
        [rng.random_range(0.0..0.1), rng.random_range(0.0..0.1), rng.random_range(0.0..0.1)];
}

/// Pose every frame of every clip of `lib` in `scene` (batched resets to
/// [`reset_state_from_clip`], no physics step) and call `f(clip, frame, state)` for each, clips in
/// library order and frames ascending. The one path by which reference quantities are computed
/// in the environment's own scene (history features, tracking references, motion-prior frames).
pub fn pose_clips(
    scene: std::sync::Arc<skillmimic_sim::Scene>,
    lib: &skillmimic_motion::MotionLibrary,
    mut f: impl FnMut(usize, usize, &skillmimic_sim::EnvState<'_>),
) -> Result<(), skillmimic_sim::SimError> {
    const N: usize = 32;
    let mut sim = skillmimic_sim::BatchSim::new(scene, N, 1)?;
    let mut states = vec![ResetState::default(); N];
    let mut mask = vec![false; N];
    for c in 0..lib.len() {
        let m = lib.get(c);
        for start in (0..m.clip.num_frames).step_by(N) {
            let frames = start..(start + N).min(m.clip.num_frames);
            mask.fill(false);
            for (k, t) in frames.clone().enumerate() {
                fill_from_clip(&mut states[k], m, t);
                mask[k] = true;
            }
            sim.reset(&mask, &states)?;
            for (k, t) in frames.enumerate() {
                f(c, t, &sim.state().env(k));
            }
        }
    }
    Ok(())
}
