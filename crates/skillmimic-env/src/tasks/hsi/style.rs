//! Style features of the TokenHSI tasks for the adversarial motion prior (`[ppo.amp]`, one
//! discriminator per task, 10-frame windows by default). A frame's features are, by default
//! (`env.hsi.style_features = "released"`), the released discriminator's 129
//! ([`released_features`]), computed from the simulation state by the environment
//! (`Env::style_features`); or (`"proprioception"`) the 222-d proprioception ([`super::proprio`])
//! read from the first 222 observation entries of every TokenHSI task.
//!
//! Reference frames: clips of the character (`tokenhsi-clip` files of `env.hsi.style_motion`,
//! e.g. `skillmimic retarget` output) posed in the character's scene with velocities from
//! finite differences of consecutive frames (root linear velocity in the world frame, angular
//! velocities from the relative rotation of consecutive frames), observed the same way.

use std::path::PathBuf;

use skillmimic_core::characters::tokenhsi;
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::library::find_clip_files;
use skillmimic_sim::EnvState;

use super::geometry::{Local, put};
use super::proprio::{PROPRIO_DIM, write_proprio};
use crate::clip_state::posed_features;
use crate::error::{EnvError, bad};

/// Features per frame.
pub const STYLE_DIM: usize = PROPRIO_DIM;

/// Write the style features of a TokenHSI observation (its first 222 entries) into `out`.
pub fn frame_features(obs: &[f32], out: &mut [f32]) {
    out[..STYLE_DIM].copy_from_slice(&obs[..STYLE_DIM]);
}

/// Width of the released TokenHSI discriminator's per-frame features ([`released_features`]).
pub const RELEASED_STYLE_DIM: usize = 1 + 6 + 3 + 3 + 72 + tokenhsi::NUM_DOFS + 3 * 4;

/// The released discriminator's features of one frame (ASE's `build_amp_observations` with a
/// heading-local root and no root height, as TokenHSI configures it), 129 wide:
/// `[0 (the root height, off) | root rotation in its heading frame, tan-norm 6D | root linear
/// velocity (m/s) and angular velocity (rad/s) in the heading frame | 12 joints × tan-norm 6D |
/// the 32 dof rates | the hands' and feet's positions relative to the root in the heading frame
/// (m)]`. A joint's rotation is read the released way: the three hinge angles of a 3-DoF joint
/// taken as a rotation vector (the released code's reading of its three-hinge joints), an elbow's
/// angle about y. Checked against the released function on the golden fixture
/// (`hsi_released_follow.rs`); what the discriminator of `[ppo.amp]` reads by default.
pub fn released_features(st: &EnvState<'_>, out: &mut [f32]) {
    use skillmimic_core::characters::JointDef;
    use skillmimic_core::math::{Quat, tan_norm};
    let l = Local::of(st);
    let mut k = put(out, 0, &[0.0]);
    k = put(out, k, &l.rotation(st.quat(0)));
    k = put(out, k, &l.vector(st.linvel(0)));
    k = put(out, k, &l.vector(st.angvel(0)));
    for body in &SPEC.bodies {
        let d = body.dofs.start;
        let q = match &body.joint {
            JointDef::Hinges { hinges, .. } if hinges.len() == 3 => {
                Quat::from_rotvec([st.dof_pos[d], st.dof_pos[d + 1], st.dof_pos[d + 2]])
            }
            JointDef::Hinges { .. } => Quat::from_axis_angle([0.0, 1.0, 0.0], st.dof_pos[d]),
            _ => continue,
        };
        k = put(out, k, &tan_norm(q));
    }
    k = put(out, k, &st.dof_vel[..tokenhsi::NUM_DOFS]);
    for b in tokenhsi::KEY_BODIES {
        k = put(out, k, &l.point(st.pos(b)));
    }
    debug_assert_eq!(k, RELEASED_STYLE_DIM);
}

static SPEC: std::sync::LazyLock<skillmimic_core::characters::CharacterSpec> =
    std::sync::LazyLock::new(tokenhsi::spec);

/// Entry of `env.hsi.style_motion` (and of each task's own `style_motion`) that stands for the
/// built-in procedural walks of the character
/// ([`skillmimic_motion::synth_walk::tokenhsi_walks`]: 0.7, 1.0 and 1.3 m/s straight, 1.0 m/s
/// turning left and right), synthesised in memory, so that no file is needed.
pub const BUILTIN_WALKS: &str = "builtin:walks";

static WALK_CLIPS: std::sync::LazyLock<Vec<CharacterClip>> =
    std::sync::LazyLock::new(skillmimic_motion::synth_walk::tokenhsi_walks);

/// Entry of a task's `style_motion` that stands for the built-in procedural stand-to-sit clips
/// ([`skillmimic_motion::synth_sit::tokenhsi_sits`], one per seat height 0.35–0.55 m in steps of
/// 0.025 m). Their reference starts are placed against the task's seat (`hsi_sit`), from the clip
/// whose seat height is nearest the seat's.
pub const BUILTIN_SITS: &str = "builtin:sit";

static SIT_CLIPS: std::sync::LazyLock<Vec<skillmimic_motion::synth_sit::SitClip>> =
    std::sync::LazyLock::new(skillmimic_motion::synth_sit::tokenhsi_sits);

/// Entry of a task's `style_motion` that stands for the built-in procedural carrying walks
/// ([`skillmimic_motion::synth_carry::tokenhsi_carries`]: cubes of 0.3, 0.4 and 0.45 m carried
/// at 0.7–1.0 m/s, straight and turning). Their reference starts in `hsi_carry` put the box into
/// the hands when its size is that of a clip (within
/// [`super::reference_init::HELD_SIDE_TOLERANCE`]).
pub const BUILTIN_CARRIES: &str = "builtin:carry";

/// Entry of a task's `style_motion` that stands for the built-in procedural step-ups
/// ([`skillmimic_motion::synth_climb::tokenhsi_climbs`], one per platform height 0.2–0.6 m in
/// steps of 0.025 m). Their reference starts in `hsi_climb` are placed against the face of the
/// platform that looks towards the character's start, from the clip of the nearest height.
pub const BUILTIN_CLIMBS: &str = "builtin:climb";

static CLIMB_CLIPS: std::sync::LazyLock<Vec<skillmimic_motion::synth_climb::ClimbClip>> =
    std::sync::LazyLock::new(skillmimic_motion::synth_climb::tokenhsi_climbs);

static CARRY_CLIPS: std::sync::LazyLock<Vec<skillmimic_motion::synth_carry::CarryClip>> =
    std::sync::LazyLock::new(skillmimic_motion::synth_carry::tokenhsi_carries);

/// What a reference clip was made against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClipObject {
    /// A seat: the world centre of its top in the clip's frame (m; its z is the seat's height);
    /// the seat faces +x.
    Seat { top: [f64; 3] },
    /// A platform climbed over its face towards +x: the centre of that face's top edge in the
    /// clip's frame (m; its z is the platform's height).
    Step { edge: [f64; 3] },
    /// A carried cube of side `side` (m) whose centre is `in_root` in the root's frame (m; x
    /// forward, y left, z up) at every frame, turned as the root.
    Held { side: f64, in_root: [f64; 3] },
}

/// Load every TokenHSI `character-clip` below `paths` (see [`load_reference_clips`]).
pub fn load_style_clips(paths: &[PathBuf]) -> Result<Vec<CharacterClip>, EnvError> {
    Ok(load_reference_clips(paths)?.into_iter().map(|(c, _)| c).collect())
}

/// The clips a built-in set's name stands for, each with the object it was made against;
/// `None` for any other name.
fn builtin_set(name: &str) -> Option<Vec<(CharacterClip, Option<ClipObject>)>> {
    Some(match name {
        BUILTIN_WALKS => WALK_CLIPS.iter().map(|c| (c.clone(), None)).collect(),
        BUILTIN_SITS => SIT_CLIPS
            .iter()
            .map(|s| (s.clip.clone(), Some(ClipObject::Seat { top: s.seat_top })))
            .collect(),
        BUILTIN_CLIMBS => CLIMB_CLIPS
            .iter()
            .map(|c| (c.clip.clone(), Some(ClipObject::Step { edge: c.edge })))
            .collect(),
        BUILTIN_CARRIES => CARRY_CLIPS
            .iter()
            .map(|c| {
                (c.clip.clone(), Some(ClipObject::Held { side: c.side, in_root: c.box_in_root }))
            })
            .collect(),
        _ => return None,
    })
}

/// Load every TokenHSI `character-clip` below `paths`, the built-in walks for an entry
/// [`BUILTIN_WALKS`], the built-in sits for [`BUILTIN_SITS`], the built-in step-ups for
/// [`BUILTIN_CLIMBS`] and the built-in carrying walks for [`BUILTIN_CARRIES`], each with the
/// object it was made against (the built-in sits, step-ups and carries) or `None`. Errors name
/// the file and a clip of another character, or an unknown `builtin:` name.
pub fn load_reference_clips(
    paths: &[PathBuf],
) -> Result<Vec<(CharacterClip, Option<ClipObject>)>, EnvError> {
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
        if let Some(set) = p.to_str().and_then(builtin_set) {
            clips.extend(set);
            continue;
        }
        if p.to_str().is_some_and(|s| s.starts_with("builtin:")) {
            let msg = format!(
                "'{}' is not a built-in motion set; built in: {BUILTIN_WALKS}, {BUILTIN_SITS}, \
                {BUILTIN_CLIMBS}, {BUILTIN_CARRIES}",
                p.display()
            );
            return Err(bad("env.hsi.style_motion", msg).into());
        }
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
            clips.push((c, None));
        }
    }
    if clips.is_empty() {
        return Err(
            bad("env.hsi.style_motion", format!("no .safetensors clips under {paths:?}")).into()
        );
    }
    Ok(clips)
}

/// Style features (the proprioception, [`STYLE_DIM`]) of every frame of every clip
/// (`[clip][T × STYLE_DIM]`), posed in the bare character scene (no physics step).
pub fn clip_features(clips: &[CharacterClip]) -> Result<Vec<Vec<f32>>, EnvError> {
    posed_features(tokenhsi::CHARACTER, clips, STYLE_DIM, write_proprio)
}

/// The released discriminator's features ([`released_features`], [`RELEASED_STYLE_DIM`]) of every
/// frame of every clip, posed in the bare character scene (joint rates from the clip's finite
/// differences).
pub fn clip_released_features(clips: &[CharacterClip]) -> Result<Vec<Vec<f32>>, EnvError> {
    posed_features(tokenhsi::CHARACTER, clips, RELEASED_STYLE_DIM, released_features)
}
