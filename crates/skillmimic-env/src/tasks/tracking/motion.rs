//! The motion a tracking episode follows, for any character: its clips, how an episode starts
//! in a clip's frame, and every frame posed in the task's own scene.
//!
//! * The SkillMimic humanoid tracks project / BallPlay-M clips ([`MotionLibrary`]); episodes
//!   start in a frame's state with the clip's reference velocities; the ball is parked at rest
//!   50 m away.
//! * Any other character tracks [`CharacterClip`]s of it from `env.motion`: `character-clip`
//!   files of the character, or SkillMimic-skeleton clips (the built-in demo clips, project or
//!   BallPlay-M files) retargeted by joint name on load (the SMPL humanoid,
//!   `skillmimic_motion::retarget_smpl`); episodes start in a frame's state with finite-difference
//!   velocities ([`clip_state`]). The SMPL humanoid also reads AMASS-layout `.npz` sequences
//!   directly (`skillmimic_motion::amass_smpl`: SMPL's joint rotations, no retargeting). Clips
//!   are resampled on load to the character's control rate
//!   (`CharacterClip::resampled`: the SMPL humanoid's 30 Hz, as the released ModSkill code reads
//!   its motion library at the policy's time step), so that an episode advances one frame per
//!   policy step at the clip's own speed.

use std::path::PathBuf;
use std::sync::Arc;

use skillmimic_core::characters::{Character, CharacterSpec};
use skillmimic_motion::MotionLibrary;
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::library::find_files;
use skillmimic_sim::{BatchSim, EnvState, ResetState, Scene, SimError};

use crate::clip_state::clip_state;
use crate::episode::fill_from_clip;
use crate::error::{EnvError, bad};

/// The file extensions of motion files in `env.motion` folders: SkillMimic clips (`.pt`,
/// `.safetensors`), character clips (`.safetensors`) and AMASS sequences (`.npz`).
pub const MOTION_EXTENSIONS: [&str; 3] = ["pt", "safetensors", "npz"];

/// The clips of a tracking task.
pub enum Motion {
    SkillMimic(Arc<MotionLibrary>),
    Clips(Vec<CharacterClip>),
}

/// An AMASS-layout `.npz` of `env.motion`: SMPL joint rotations as they are on the SMPL humanoid
/// (`skillmimic_motion::amass_smpl`, feet put on the floor over the clip as PHC's motion library
/// does); other characters are refused with the way to convert it.
fn load_amass(path: &std::path::Path, character: Character) -> Result<CharacterClip, EnvError> {
    if character.name() != "smpl" {
        let msg = format!(
            "{}: AMASS-layout motion is tracked by the smpl character as it is (set \
             env.character = \"smpl\"); for the {} character convert it first (skillmimic \
             retarget --amass)",
            path.display(),
            character.name()
        );
        return Err(bad("env.motion", msg).into());
    }
    Ok(skillmimic_motion::amass_smpl::load(path, true)?.0)
}

impl Motion {
    /// The clips of `env.motion` for `character`.
    pub fn load(paths: &[PathBuf], character: Character) -> Result<Self, EnvError> {
        // AMASS-layout files of another character are refused before any other loading
        let npz = paths.iter().find(|p| p.extension().is_some_and(|e| e == "npz"));
        if let Some(npz) = npz.filter(|_| character.name() != "smpl") {
            load_amass(npz, character)?;
        }
        if character.plays_ballplay() {
            return Ok(Motion::SkillMimic(Arc::new(crate::tasks::imitation::load_motion_library(
                paths,
            )?)));
        }
        let spec = character.spec();
        let mut clips = Vec::new();
        let onto = skillmimic_motion::retarget_onto::onto(character.name());
        let retarget =
            |lib: &MotionLibrary, clips: &mut Vec<CharacterClip>| -> Result<(), EnvError> {
                let Some(onto) = onto else {
                    let msg = format!(
                        "SkillMimic-skeleton clips have no retarget onto the {} character \
                         (skillmimic_motion::retarget_onto); give clips of the character",
                        character.name()
                    );
                    return Err(bad("env.motion", msg).into());
                };
                clips.extend(lib.clips().iter().map(|m| onto(&m.clip)));
                Ok(())
            };
        for p in paths {
            if p.as_os_str() == crate::config::BUILTIN_DEMO {
                retarget(
                    &crate::tasks::imitation::load_motion_library(std::slice::from_ref(p))?,
                    &mut clips,
                )?;
                continue;
            }
            for f in find_files(p, &MOTION_EXTENSIONS)? {
                if f.extension().is_some_and(|e| e == "npz") {
                    clips.push(load_amass(&f, character)?);
                    continue;
                }
                match CharacterClip::load(&f) {
                    Ok(c) if c.character == spec.name => clips.push(c),
                    Ok(c) => {
                        let msg = format!(
                            "{}: a clip of the {} character, the task runs on {}",
                            f.display(),
                            c.character,
                            spec.name
                        );
                        return Err(bad("env.motion", msg).into());
                    }
                    // not a character clip: a SkillMimic-skeleton clip, retargeted
                    Err(_) => retarget(
                        &crate::tasks::imitation::load_motion_library(std::slice::from_ref(&f))?,
                        &mut clips,
                    )?,
                }
            }
        }
        if clips.is_empty() {
            return Err(bad(
                "env.motion",
                format!("no clips of the {} character under {paths:?}", spec.name),
            )
            .into());
        }
        // one clip frame per policy step: the clips at the character's control rate
        let rate = 1.0 / (spec.timestep * spec.substeps as f64);
        Ok(Motion::Clips(clips.iter().map(|c| c.resampled(&spec, rate)).collect()))
    }

    /// Number of clips.
    pub fn len(&self) -> usize {
        match self {
            Motion::SkillMimic(lib) => lib.len(),
            Motion::Clips(c) => c.len(),
        }
    }
    /// Whether there is no clip.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Frames of clip `c`.
    pub fn frames(&self, c: usize) -> usize {
        match self {
            Motion::SkillMimic(lib) => lib.get(c).clip.num_frames,
            Motion::Clips(clips) => clips[c].num_frames,
        }
    }
    /// Name of clip `c`.
    pub fn name(&self, c: usize) -> &str {
        match self {
            Motion::SkillMimic(lib) => &lib.get(c).clip.name,
            Motion::Clips(clips) => &clips[c].name,
        }
    }
    /// Cumulative sampling weights: the library's weights (one per clip for character clips) ×
    /// `weight(name)`.
    pub fn cumulative(&self, weight: impl Fn(&str) -> f64) -> Vec<f64> {
        match self {
            Motion::SkillMimic(lib) => lib.cumulative_weighted(|c| weight(&c.name)),
            Motion::Clips(clips) => clips
                .iter()
                .scan(0.0, |acc, c| {
                    *acc += weight(&c.name);
                    Some(*acc)
                })
                .collect(),
        }
    }
    /// The SkillMimic library (`None` for another character's clips).
    pub fn library(&self) -> Option<&Arc<MotionLibrary>> {
        match self {
            Motion::SkillMimic(lib) => Some(lib),
            Motion::Clips(_) => None,
        }
    }

    /// Write the state of frame `t` of clip `c` into `s` (a state of `spec`'s scene).
    pub fn fill_state(&self, spec: &CharacterSpec, c: usize, t: usize, s: &mut ResetState) {
        match self {
            Motion::SkillMimic(lib) => {
                fill_from_clip(s, lib.get(c), t);
                // the ball plays no part: parked at rest far from the humanoid
                let ball = s.ball_mut();
                ball.pos = [50.0, 50.0, 0.5];
                ball.linvel = [0.0; 3];
                ball.angvel_local = [0.0; 3];
            }
            Motion::Clips(clips) => clip_state(spec, &clips[c], t, s),
        }
    }

    /// Pose every frame of every clip in `scene` (batched resets, no physics step) and call
    /// `f(clip, frame, state)` for each, clips in order and frames ascending.
    pub fn pose(
        &self,
        scene: Arc<Scene>,
        mut f: impl FnMut(usize, usize, &EnvState<'_>),
    ) -> Result<(), SimError> {
        const N: usize = 32;
        let spec = scene.character().clone();
        let mut states = vec![ResetState::rest(&scene); N];
        let mut sim = BatchSim::new(scene, N, 1)?;
        let mut mask = vec![false; N];
        for c in 0..self.len() {
            for start in (0..self.frames(c)).step_by(N) {
                let frames = start..(start + N).min(self.frames(c));
                mask.fill(false);
                for (k, t) in frames.clone().enumerate() {
                    self.fill_state(&spec, c, t, &mut states[k]);
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
}
