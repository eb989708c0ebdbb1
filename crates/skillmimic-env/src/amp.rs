//! Per-frame features of the adversarial motion prior (AMP; Peng et al. 2021, used by ModSkill
//! and TokenHSI with 10-frame windows), read from the humanoid part of an observation (the first
//! 823 entries, `obs::layout`, heading frame), so they exist for every task whose observation
//! starts with it (imitation, stand, tracking, the high-level tasks) and for terminal
//! observations; reference frames are the clips posed in the scene and observed the same way.
//!
//! [`FEATURE_DIM`] = 535 float32 per frame: root height (1, m) | the 53 body rotations, tan-norm
//! 6D (318) | root linear and angular velocity (3 + 3; m/s, rad/s) | the 17 key bodies' positions
//! relative to the root (51, m) | the 53 body angular velocities (159, rad/s). A window is `k`
//! consecutive frames, oldest first, flattened (`k × 535`); frames before an episode's (or a
//! clip's) first frame repeat the first frame.

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::KEY_BODIES;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{Scene, SimError};

use crate::obs::{layout, write_state_obs};

/// Features per frame.
pub const FEATURE_DIM: usize = 1 + 318 + 6 + 3 * KEY_BODIES.len() + 159;

/// Write the features of the observation `obs` (at least its first 823 entries) into `out`.
pub fn frame_features(obs: &[f32], out: &mut [f32]) {
    out[0] = obs[layout::ROOT_HEIGHT.start];
    out[1..319].copy_from_slice(&obs[layout::BODY_ROT]);
    out[319..322].copy_from_slice(&obs[layout::BODY_LINVEL.start..layout::BODY_LINVEL.start + 3]);
    out[322..325].copy_from_slice(&obs[layout::BODY_ANGVEL.start..layout::BODY_ANGVEL.start + 3]);
    for (k, &b) in KEY_BODIES.iter().enumerate() {
        // body_pos holds bodies 1…52 relative to the root
        let at = layout::BODY_POS.start + 3 * (b - 1);
        out[325 + 3 * k..328 + 3 * k].copy_from_slice(&obs[at..at + 3]);
    }
    out[376..535].copy_from_slice(&obs[layout::BODY_ANGVEL]);
}

/// The features of every frame of every clip of `lib` (`[clip][T × FEATURE_DIM]`), by posing the
/// clip in `scene` (no physics step).
pub fn clip_features(scene: Arc<Scene>, lib: &MotionLibrary) -> Result<Vec<Vec<f32>>, SimError> {
    let mut obs = vec![0.0f32; layout::STATE_DIM];
    let mut out: Vec<Vec<f32>> =
        lib.clips().iter().map(|m| vec![0.0f32; m.clip.num_frames * FEATURE_DIM]).collect();
    crate::episode::pose_clips(scene, lib, |c, t, st| {
        write_state_obs(st, &mut obs);
        frame_features(&obs, &mut out[c][t * FEATURE_DIM..(t + 1) * FEATURE_DIM]);
    })?;
    Ok(out)
}

/// A reference window of `k` frames of clip features `rows` ending at frame `end` (frames before
/// the clip start repeat frame 0), flattened into `out` (`k × FEATURE_DIM`).
pub fn window(rows: &[f32], end: usize, k: usize, out: &mut [f32]) {
    window_of(rows, FEATURE_DIM, end, k, out)
}

/// [`window`] for frames of `dim` features (any character's prior).
pub fn window_of(rows: &[f32], dim: usize, end: usize, k: usize, out: &mut [f32]) {
    for i in 0..k {
        let t = (end + i + 1).saturating_sub(k);
        out[i * dim..(i + 1) * dim].copy_from_slice(&rows[t * dim..(t + 1) * dim]);
    }
}
