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
use skillmimic_sim::{ObjectState, ResetState};

use super::config::{HsiConfig, StateInit};
use super::style::ClipObject;
use crate::clip_state::clip_state;
use crate::error::{EnvError, bad};

/// The object of the task's episode that a reference start made against an object is placed
/// against ([`super::Rule::anchor`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Anchor {
    /// Sit: the seat. `top` is the world centre of its top (m; its z is the seat's height), `yaw`
    /// the yaw of its front (+x of its frame, rad).
    Seat { top: [f64; 3], yaw: f64 },
    /// Climb: the platform's face the character climbs over. `edge` is the world centre of that
    /// face's top edge (m; its z is the platform's height), `yaw` the direction into the
    /// platform across it (rad).
    Step { edge: [f64; 3], yaw: f64 },
    /// Carry: the box, `object` its index in [`ResetState::objects`], `half` its half extents (m).
    Held { object: usize, half: [f64; 3] },
}

/// A held-box clip is used for a box whose side (the mean of its three) is within this (m) of
/// the clip's: half the released size step (0.05 m). A box farther from every clip's size stays
/// where the task's rule put it (the hands would sink into it or miss it).
pub const HELD_SIDE_TOLERANCE: f64 = 0.025;

/// Reference clips and how often an episode starts from one.
pub struct ReferenceInit {
    clips: Vec<CharacterClip>,
    /// Per clip: the object it was made against, if any.
    objects: Vec<Option<ClipObject>>,
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
        let (clips, objects) = super::style::load_reference_clips(&paths)?.into_iter().unzip();
        Ok(Some(Self { clips, objects, spec: tokenhsi::spec(), probability }))
    }

    /// Replace the character part of `state` (placed by the task's rule) by a reference frame,
    /// with probability `hybrid_init_prob` under `hybrid` (see the module doc). A clip made
    /// against an object of the kind the task has (`anchor`) is replaced by the clip of those
    /// whose object is nearest the task's in size (seat or platform height; box side), and then:
    /// * seat (sit) or step (climb): its frame is placed where the clip has the character
    ///   relative to its seat or platform edge, turned to the task's yaw (the clip's root height
    ///   kept, a step-up's lifted by how much the task's platform is higher than the clip's);
    /// * held box: the frame is placed as any other (the rule's position and heading) and the box
    ///   is moved into the hands, where the clip has it relative to the root, moving with the
    ///   root (linear velocity v + ω × r, the root's angular velocity), if its size is within
    ///   [`HELD_SIDE_TOLERANCE`] of the clip's; else the box stays where the rule put it.
    ///
    /// No allocation.
    pub fn apply(&self, rng: &mut ChaCha8Rng, state: &mut ResetState, anchor: Option<Anchor>) {
        if self.probability < 1.0 && rng.random::<f64>() >= self.probability {
            return;
        }
        let mut k = rng.random_range(0..self.clips.len());
        // the size gap between clip i's object and the task's (infinite: another kind, or none)
        let gap = |i: usize| match (self.objects[i], anchor) {
            (Some(ClipObject::Seat { top }), Some(Anchor::Seat { top: a, .. }))
            | (Some(ClipObject::Step { edge: top }), Some(Anchor::Step { edge: a, .. })) => {
                (top[2] - a[2]).abs()
            }
            (Some(ClipObject::Held { side, .. }), Some(Anchor::Held { half, .. })) => {
                (side - 2.0 * (half[0] + half[1] + half[2]) / 3.0).abs()
            }
            _ => f64::INFINITY,
        };
        if gap(k).is_finite() {
            k = (0..self.clips.len()).min_by(|&i, &j| gap(i).total_cmp(&gap(j))).unwrap_or(k);
        }
        let clip = &self.clips[k];
        let t = rng.random_range(0..clip.num_frames);
        // a seat or a step: the clip's object point and the task's, with the task's yaw
        let placed = match (self.objects[k], anchor) {
            (Some(ClipObject::Seat { top: c }), Some(Anchor::Seat { top, yaw }))
            | (Some(ClipObject::Step { edge: c }), Some(Anchor::Step { edge: top, yaw })) => {
                Some((c, top, yaw))
            }
            _ => None,
        };
        if let Some((seat, top, yaw)) = placed {
            clip_state(&self.spec, clip, t, state);
            // the clip's object faces +x: turn its frame by the task's yaw about the object point
            let turn = Quat::about_z(yaw);
            let rel = turn.rotate([state.root_pos[0] - seat[0], state.root_pos[1] - seat[1], 0.0]);
            state.root_quat = turn.mul(state.root_quat).normalized();
            state.root_linvel = turn.rotate(state.root_linvel);
            // a step-up of a lower platform than the task's is lifted by the difference (its feet
            // on the top would be inside it otherwise; those on the floor drop that little)
            let lift = match self.objects[k] {
                Some(ClipObject::Step { .. }) => (top[2] - seat[2]).max(0.0),
                _ => 0.0,
            };
            state.root_pos = [top[0] + rel[0], top[1] + rel[1], state.root_pos[2] + lift];
            return;
        }
        let (at, yaw) = (state.root_pos, heading(state.root_quat));
        clip_state(&self.spec, clip, t, state);
        let turn = Quat::about_z(yaw - heading(state.root_quat));
        state.root_quat = turn.mul(state.root_quat).normalized();
        state.root_linvel = turn.rotate(state.root_linvel);
        state.root_pos = [at[0], at[1], state.root_pos[2]];
        if let (Some(ClipObject::Held { in_root, .. }), Some(Anchor::Held { object, .. })) =
            (self.objects[k], anchor)
            && gap(k) <= HELD_SIDE_TOLERANCE
        {
            let r = state.root_quat.rotate(in_root);
            let w = state.root_quat.rotate(state.root_angvel_local);
            let spin =
                [w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]];
            let (p, v) = (state.root_pos, state.root_linvel);
            state.objects[object] = ObjectState {
                pos: [p[0] + r[0], p[1] + r[1], p[2] + r[2]],
                quat: state.root_quat,
                linvel: [v[0] + spin[0], v[1] + spin[1], v[2] + spin[2]],
                angvel_local: state.root_angvel_local,
            };
        }
    }
}
