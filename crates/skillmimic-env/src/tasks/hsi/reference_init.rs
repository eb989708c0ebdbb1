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
use super::style::ClipSeat;
use crate::clip_state::clip_state;
use crate::error::{EnvError, bad};

/// The object of the task's episode that a reference start made against an object is placed
/// against (sit: the seat; [`super::Rule::anchor`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// World centre of the seat's top (m; its z is the seat's height).
    pub top: [f64; 3],
    /// Yaw of the seat's front (+x of its frame), rad.
    pub yaw: f64,
}

/// Reference clips and how often an episode starts from one.
pub struct ReferenceInit {
    clips: Vec<CharacterClip>,
    /// Per clip: the seat it was made against, if any.
    seats: Vec<Option<ClipSeat>>,
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
        let (clips, seats) = super::style::load_reference_clips(&paths)?.into_iter().unzip();
        Ok(Some(Self { clips, seats, spec: tokenhsi::spec(), probability }))
    }

    /// Replace the character part of `state` (placed by the task's rule) by a reference frame,
    /// with probability `hybrid_init_prob` under `hybrid` (see the module doc). A clip made
    /// against a seat, when the task has one (`anchor`), is replaced by the clip of those made
    /// against a seat whose seat height is nearest the task's, and its frame is placed where
    /// the clip has the character relative to its seat, turned to the seat's yaw (the clip's
    /// root height kept). No allocation.
    pub fn apply(&self, rng: &mut ChaCha8Rng, state: &mut ResetState, anchor: Option<Anchor>) {
        if self.probability < 1.0 && rng.random::<f64>() >= self.probability {
            return;
        }
        let mut k = rng.random_range(0..self.clips.len());
        if let (Some(_), Some(a)) = (self.seats[k], anchor) {
            let gap =
                |s: &Option<ClipSeat>| s.map_or(f64::INFINITY, |s| (s.top[2] - a.top[2]).abs());
            k = (0..self.seats.len())
                .min_by(|&i, &j| gap(&self.seats[i]).total_cmp(&gap(&self.seats[j])))
                .unwrap_or(k);
        }
        let clip = &self.clips[k];
        let t = rng.random_range(0..clip.num_frames);
        if let (Some(seat), Some(a)) = (self.seats[k], anchor) {
            clip_state(&self.spec, clip, t, state);
            // the clip's seat faces +x: turn its frame by the seat's yaw about the seat's top
            let turn = Quat::about_z(a.yaw);
            let rel = turn.rotate([
                state.root_pos[0] - seat.top[0],
                state.root_pos[1] - seat.top[1],
                0.0,
            ]);
            state.root_quat = turn.mul(state.root_quat).normalized();
            state.root_linvel = turn.rotate(state.root_linvel);
            state.root_pos = [a.top[0] + rel[0], a.top[1] + rel[1], state.root_pos[2]];
            return;
        }
        let (at, yaw) = (state.root_pos, heading(state.root_quat));
        clip_state(&self.spec, clip, t, state);
        let turn = Quat::about_z(yaw - heading(state.root_quat));
        state.root_quat = turn.mul(state.root_quat).normalized();
        state.root_linvel = turn.rotate(state.root_linvel);
        state.root_pos = [at[0], at[1], state.root_pos[2]];
    }
}
