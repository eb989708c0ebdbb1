//! History encoder of SkillMimic-V2 (seed 003 §4.6, App. B.5; reference-facts §9.1–9.3).
//!
//! **Per-frame feature** (316 values, float32): root height (1) | positions of bodies 1…52
//! relative to the root in the heading frame (156) | the 156 joint exp-map components |
//! ball position in the heading frame with absolute height (3) — i.e. observation entries
//! 0..157, the joint vector and observation entries 823..826. Clips without a ball (labels 0,
//! 10) have the ball part set to zero, online and in the reference rows.
//!
//! **Heading**: always the true heading of the root quaternion. The reference code builds the
//! reference rows (reset and pre-training) from the root *exp map* passed where a quaternion is
//! expected, which tilts the heading by up to ≈ 88° on BallPlay-M clips; we do not reproduce
//! that, so an encoder pre-trained here sees the same frame convention offline and online.
//!
//! **Reference rows** come from forward kinematics of the clip's pose in the environment's own
//! scene ([`reference_features`]), not from the stored body positions (which differ from FK by
//! ≈ 3 cm): the rows placed in the buffer at a reset then continue seamlessly into the simulated
//! rows that follow.
//!
//! **Encoder**: the network (and its online per-environment buffer) is
//! `skillmimic_nn::history`, one definition shared with pre-training; this module defines the
//! feature it reads and feeds it ([`observe`]): at every observation the embedding is computed
//! from the last k frames *before* the current frame is pushed, so h_t summarises frames
//! t−k … t−1.

use std::sync::Arc;

use skillmimic_motion::MotionLibrary;
pub use skillmimic_nn::history::{
    CHANNELS, DEFAULT_EMBED, DEFAULT_LENGTH, FEATURE_DIM, FORMAT, HistoryBuffer, HistoryEncoder,
    HistoryError, KERNEL, TENSOR_NAMES, random_encoder, reference_window,
};
use skillmimic_sim::{Scene, SimError};

use crate::episode::BALL_FREE_SKILLS;
use crate::obs::{layout, write_state_obs};

/// Write the 316 features of a frame from its observation (the first 838 entries are used) and
/// joint exp maps; `ball` = false zeroes the ball part.
pub fn features_from_obs(state_obs: &[f32], dof_pos: &[f64], ball: bool, out: &mut [f32]) {
    out[..157].copy_from_slice(&state_obs[..157]);
    for (o, &d) in out[157..313].iter_mut().zip(dof_pos) {
        *o = d as f32;
    }
    if ball {
        out[313..316].copy_from_slice(&state_obs[layout::BALL_POS]);
    } else {
        out[313..316].fill(0.0);
    }
}

/// Reference features of every frame of every clip (`[clip][T × 316]`), by forward kinematics of
/// the clip poses in `scene`.
pub fn reference_features(
    scene: Arc<Scene>,
    lib: &MotionLibrary,
) -> Result<Vec<Vec<f32>>, SimError> {
    let mut obs = vec![0.0f32; layout::STATE_DIM];
    let mut out: Vec<Vec<f32>> =
        lib.clips().iter().map(|m| vec![0.0f32; m.clip.num_frames * FEATURE_DIM]).collect();
    crate::episode::pose_clips(scene, lib, |c, t, st| {
        let ball = !BALL_FREE_SKILLS.contains(&lib.get(c).clip.skill);
        write_state_obs(st, &mut obs);
        features_from_obs(
            &obs,
            st.dof_pos,
            ball,
            &mut out[c][t * FEATURE_DIM..(t + 1) * FEATURE_DIM],
        );
    })?;
    Ok(out)
}

/// One observation's history update: write h (from the frames before this one) into
/// `obs[902..902+μ]`, then push this frame's features, taken from `obs` and `dof_pos`.
pub fn observe(
    buf: &mut HistoryBuffer,
    enc: &HistoryEncoder,
    obs: &mut [f32],
    dof_pos: &[f64],
    ball: bool,
) {
    buf.embedding(enc, &mut obs[layout::OBS_DIM..]);
    let mut f = [0.0f32; FEATURE_DIM];
    features_from_obs(obs, dof_pos, ball, &mut f);
    buf.push(enc, &f);
}
