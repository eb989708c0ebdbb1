//! Reference-state initialisation of the TokenHSI tasks (the released `stateInit: Random`): an
//! episode starts from a random frame of a random reference clip of the task (its
//! `style_motion` clips; each clip equally likely, then each of its frames), posed where the
//! task's rule placed the character: the clip's root is moved to the rule's start position
//! (x, y; the clip's own height is kept) and the whole pose turned about +z so that its heading is
//! the rule's start heading (random or +x, `env.hsi.random_heading`). Joint positions and rates
//! are the clip's ([`crate::clip_state`]); the root velocity turns with the pose. Objects stay as
//! the rule placed them.
//!
//! `env.hsi.state_init` chooses: `auto` (reference frames when the task has clips, else the rest
//! pose), `default` (always the rest pose), `reference` (always a reference frame; clips
//! required), `hybrid` (a reference frame with probability `hybrid_init_prob`, else the rest
//! pose — ASE's hybrid initialisation).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::{CharacterSpec, tokenhsi};
use skillmimic_core::math::{Quat, heading};
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_sim::ResetState;

use super::config::{HsiConfig, StateInit};
use crate::clip_state::clip_state;
use crate::error::{EnvError, bad};

/// Reference clips and how often an episode starts from one.
pub struct ReferenceInit {
    clips: Vec<CharacterClip>,
    spec: CharacterSpec,
    probability: f64,
}

impl ReferenceInit {
    /// The initialisation `env.hsi.state_init` asks for task `task` (`None`: the rest pose).
    pub fn from_config(h: &HsiConfig, task: &str) -> Result<Option<Self>, EnvError> {
        let paths = h.style_motion_of(task);
        let probability = match h.state_init {
            StateInit::Default => return Ok(None),
            StateInit::Auto if paths.is_empty() => return Ok(None),
            StateInit::Auto | StateInit::Reference => 1.0,
            StateInit::Hybrid => h.hybrid_init_prob,
        };
        if paths.is_empty() {
            let name = if h.state_init == StateInit::Hybrid { "hybrid" } else { "reference" };
            let msg = format!(
                "state_init = \"{name}\" needs reference clips of '{task}' \
                (env.hsi.style_motion or the task's own style_motion)"
            );
            return Err(bad("env.hsi.state_init", msg).into());
        }
        // the loader refuses clips of another character, non-finite values and < 2 frames
        let clips = super::style::load_style_clips(&paths)?;
        Ok(Some(Self { clips, spec: tokenhsi::spec(), probability }))
    }

    /// Replace the character part of `state` (placed by the task's rule) by a reference frame,
    /// with probability `hybrid_init_prob` under `hybrid` (see the module doc). No allocation.
    pub fn apply(&self, rng: &mut ChaCha8Rng, state: &mut ResetState) {
        if self.probability < 1.0 && rng.random::<f64>() >= self.probability {
            return;
        }
        let clip = &self.clips[rng.random_range(0..self.clips.len())];
        let t = rng.random_range(0..clip.num_frames);
        let (at, yaw) = (state.root_pos, heading(state.root_quat));
        clip_state(&self.spec, clip, t, state);
        let turn = Quat::about_z(yaw - heading(state.root_quat));
        state.root_quat = turn.mul(state.root_quat).normalized();
        state.root_linvel = turn.rotate(state.root_linvel);
        state.root_pos = [at[0], at[1], state.root_pos[2]];
    }
}
