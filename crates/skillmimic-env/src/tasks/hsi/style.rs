//! Style features of the TokenHSI tasks for the adversarial motion prior (`[ppo.amp]`, one
//! discriminator per task as in TokenHSI, 10-frame windows by default): a frame's features are
//! the 222-d proprioception ([`super::proprio`]) — body positions, rotations and velocities in
//! the heading frame — read from the first 222 observation entries of every TokenHSI task.
//!
//! Reference frames: clips of the character (`tokenhsi-clip` files of `env.hsi.style_motion`,
//! e.g. `skillmimic retarget` output) posed in the character's scene with velocities from
//! finite differences of consecutive frames (root linear velocity in the world frame, angular
//! velocities from the relative rotation of consecutive frames), observed the same way.

use std::path::PathBuf;
use std::sync::Arc;

use skillmimic_core::characters::tokenhsi::{self, BODIES, JointSpec, NUM_DOFS};
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::library::find_clip_files;
use skillmimic_sim::{BatchSim, ResetState, Scene, SceneOptions};

use super::proprio::{PROPRIO_DIM, write_proprio};
use crate::error::{EnvError, bad};

/// Features per frame.
pub const STYLE_DIM: usize = PROPRIO_DIM;

/// Write the style features of a TokenHSI observation (its first 222 entries) into `out`.
pub fn frame_features(obs: &[f32], out: &mut [f32]) {
    out[..STYLE_DIM].copy_from_slice(&obs[..STYLE_DIM]);
}

/// Load every TokenHSI `character-clip` below `paths` (errors name the file and a clip of another
/// character).
pub fn load_style_clips(paths: &[PathBuf]) -> Result<Vec<CharacterClip>, EnvError> {
    if paths.is_empty() {
        return Err(bad("env.hsi.style_motion", "the motion prior of a TokenHSI task needs reference clips of the character (skillmimic retarget writes them)").into());
    }
    let mut clips = Vec::new();
    for p in paths {
        for f in find_clip_files(p)? {
            let c = CharacterClip::load(&f)?;
            if c.character != "tokenhsi" {
                let msg = format!(
                    "{}: a clip of the {} character, not of the TokenHSI character",
                    f.display(),
                    c.character
                );
                return Err(bad("env.hsi.style_motion", msg).into());
            }
            clips.push(c);
        }
    }
    if clips.is_empty() {
        return Err(
            bad("env.hsi.style_motion", format!("no .safetensors clips under {paths:?}")).into()
        );
    }
    Ok(clips)
}

/// The reset state of frame `t` of `clip` (velocities: finite differences to the next frame,
/// the last frame uses the previous interval).
pub fn clip_state(clip: &CharacterClip, t: usize) -> ResetState {
    let t0 = t.min(clip.num_frames - 2);
    let dt = 1.0 / clip.fps;
    let (p0, p1) = (clip.root_pos_at(t0), clip.root_pos_at(t0 + 1));
    let (q0, q1) = (clip.root_quat_at(t0), clip.root_quat_at(t0 + 1));
    let w = q0.conj().mul(q1).normalized().to_rotvec();
    let mut s = ResetState::of(&skillmimic_core::characters::tokenhsi::spec(), 0);
    s.root_pos = clip.root_pos_at(t);
    s.root_quat = clip.root_quat_at(t).normalized();
    s.root_linvel = [(p1[0] - p0[0]) / dt, (p1[1] - p0[1]) / dt, (p1[2] - p0[2]) / dt];
    s.root_angvel_local = [w[0] / dt, w[1] / dt, w[2] / dt];
    let (d, d0, d1) = (clip.dof_at(t), clip.dof_at(t0), clip.dof_at(t0 + 1));
    let mut k = 0;
    for b in &BODIES {
        match b.joint {
            JointSpec::Ball { .. } => {
                let r = |x: &[f32]| {
                    skillmimic_core::math::Quat::from_rotvec([
                        x[k] as f64,
                        x[k + 1] as f64,
                        x[k + 2] as f64,
                    ])
                };
                let w = r(d0).conj().mul(r(d1)).normalized().to_rotvec();
                for a in 0..3 {
                    s.dof_pos[k + a] = d[k + a] as f64;
                    s.dof_vel[k + a] = w[a] / dt;
                }
            }
            JointSpec::HingeY { .. } => {
                s.dof_pos[k] = d[k] as f64;
                s.dof_vel[k] = (d1[k] - d0[k]) as f64 / dt;
            }
            _ => {}
        }
        k += b.joint.dofs();
    }
    debug_assert_eq!(k, NUM_DOFS);
    s
}

/// Style features of every frame of every clip (`[clip][T × STYLE_DIM]`), posed in the bare
/// character scene (no physics step).
pub fn clip_features(clips: &[CharacterClip]) -> Result<Vec<Vec<f32>>, EnvError> {
    let scene = Arc::new(Scene::new(SceneOptions::bare(tokenhsi::CHARACTER))?);
    let mut sim = BatchSim::new(scene, 1, 1)?;
    let mut out = Vec::with_capacity(clips.len());
    for c in clips {
        let mut rows = vec![0.0f32; c.num_frames * STYLE_DIM];
        for t in 0..c.num_frames {
            sim.reset(&[true], &[clip_state(c, t)])?;
            write_proprio(&sim.state().env(0), &mut rows[t * STYLE_DIM..(t + 1) * STYLE_DIM]);
        }
        out.push(rows);
    }
    Ok(out)
}
