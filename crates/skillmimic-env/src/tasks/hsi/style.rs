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

use skillmimic_core::characters::tokenhsi;
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::library::find_clip_files;
use skillmimic_sim::{BatchSim, ResetState, Scene, SceneOptions};

use super::proprio::{PROPRIO_DIM, write_proprio};
use crate::clip_state::clip_state;
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
        return Err(bad(
            "env.hsi.style_motion",
            "the motion prior of a TokenHSI task needs \
            reference clips of the character (skillmimic retarget writes them)",
        )
        .into());
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

/// Style features of every frame of every clip (`[clip][T × STYLE_DIM]`), posed in the bare
/// character scene (no physics step).
pub fn clip_features(clips: &[CharacterClip]) -> Result<Vec<Vec<f32>>, EnvError> {
    let scene = Arc::new(Scene::new(SceneOptions::bare(tokenhsi::CHARACTER))?);
    let mut sim = BatchSim::new(scene, 1, 1)?;
    let spec = tokenhsi::CHARACTER.spec();
    let mut state = ResetState::of(&spec, 0);
    let mut out = Vec::with_capacity(clips.len());
    for c in clips {
        let mut rows = vec![0.0f32; c.num_frames * STYLE_DIM];
        for t in 0..c.num_frames {
            clip_state(&spec, c, t, &mut state);
            sim.reset(&[true], std::slice::from_ref(&state))?;
            write_proprio(&sim.state().env(0), &mut rows[t * STYLE_DIM..(t + 1) * STYLE_DIM]);
        }
        out.push(rows);
    }
    Ok(out)
}
