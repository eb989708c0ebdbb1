//! The reference motion drawn with a policy's rollout in `skillmimic play` videos: for a task
//! that plays reference clips (imitation on the BallPlay-M character, tracking on any), each
//! filmed step's episode fields name the clip and the reference frame the state is compared
//! with, and that frame's pose (the character, and the ball of a BallPlay-M clip) is drawn as a
//! translucent ghost over the character or beside it.

use std::sync::Arc;

use anyhow::{Context, bail};
use skillmimic_env::Env;
use skillmimic_env::config::EnvConfig;
use skillmimic_env::episode::reset_state_from_clip;
use skillmimic_motion::MotionClip;
use skillmimic_sim::{BatchSim, ResetState, Scene};

/// The poses of clip frames as `qpos` of a scene of the BallPlay-M character: one simulated
/// environment set to each frame's reference state (`--reference` playback and the ghost).
pub struct ClipPoser {
    sim: BatchSim,
}

impl ClipPoser {
    pub fn new(scene: Arc<Scene>) -> anyhow::Result<Self> {
        Ok(Self { sim: BatchSim::new(scene, 1, 1)? })
    }

    /// `qpos` of frame `t` of clip `m` (humanoid and ball).
    pub fn qpos(&mut self, m: &MotionClip, t: usize) -> anyhow::Result<Vec<f64>> {
        self.qpos_of(&reset_state_from_clip(m, t))
    }

    /// `qpos` of a state of the scene.
    pub fn qpos_of(&mut self, state: &ResetState) -> anyhow::Result<Vec<f64>> {
        self.sim.reset(&[true], std::slice::from_ref(state)).context("a clip frame's state")?;
        Ok(self.sim.qpos(0).to_vec())
    }
}

/// Where the reference motion is drawn in a policy's video (`play --ghost`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum GhostMode {
    /// Over the character when the task plays reference clips, else not at all.
    #[default]
    Auto,
    /// Over the character (translucent).
    Overlay,
    /// Beside the character: shifted by [`BESIDE_OFFSET`].
    Beside,
    /// Not drawn.
    Off,
}

/// Shift of a ghost drawn beside the character: 1.2 m along world +x, the `side` camera's
/// horizontal axis.
pub const BESIDE_OFFSET: [f64; 3] = [1.2, 0.0, 0.0];

impl GhostMode {
    /// The world offset of the ghost, or `None` when it is not drawn.
    pub fn offset(self) -> Option<[f64; 3]> {
        match self {
            GhostMode::Auto | GhostMode::Overlay => Some([0.0; 3]),
            GhostMode::Beside => Some(BESIDE_OFFSET),
            GhostMode::Off => None,
        }
    }
}

/// Positions of the episode fields `clip` and `ref_frame` of the environment's task, when it
/// declares them (a task that plays reference clips; whether it can pose them for a ghost is
/// [`ghost_states`]' question, asked once per video, not at every recorded step).
pub fn reference_fields(env: &dyn Env) -> Option<(usize, usize)> {
    let names = &env.spec().episode_names;
    let clip = names.iter().position(|n| *n == "clip")?;
    let frame = names.iter().position(|n| *n == "ref_frame")?;
    Some((clip, frame))
}

/// The (clip, frame) environment 0 is compared with now, by the fields of [`reference_fields`].
pub fn current_reference(env: &dyn Env, fields: (usize, usize)) -> Option<(usize, usize)> {
    let e = env.episode_info(0);
    let (c, f) = (*e.get(fields.0)?, *e.get(fields.1)?);
    Some((usize::try_from(c).ok()?, usize::try_from(f).ok()?))
}

/// The ghost states (`qpos` of the task's scene) of the recorded references; `None` where a step
/// has none. Errors when `mode` asks for a ghost the task cannot give.
pub fn ghost_states(
    env: &dyn Env,
    cfg: &EnvConfig,
    mode: GhostMode,
    refs: &[Option<(usize, usize)>],
) -> anyhow::Result<Vec<Option<Vec<f64>>>> {
    let none = || vec![None; refs.len()];
    if mode == GhostMode::Off {
        return Ok(none());
    }
    // a library's clips fit the scene only on the BallPlay-M character (its own clips); other
    // tasks pose their clips themselves
    let ballplay = skillmimic_env::registry::character(cfg).is_ok_and(|c| c.plays_ballplay());
    let library = env.library().filter(|_| ballplay);
    if reference_fields(env).is_none() || (library.is_none() && env.reference_state(0, 0).is_none())
    {
        if mode == GhostMode::Auto {
            return Ok(none());
        }
        bail!(
            "--ghost {mode:?}: task '{}' plays no reference clips (use --ghost off)",
            env.spec().name
        );
    }
    let mut poser =
        ClipPoser::new(Arc::new(Scene::new(skillmimic_env::registry::scene_options(cfg)?)?))?;
    let mut out = Vec::with_capacity(refs.len());
    for r in refs {
        out.push(match (*r, library) {
            (Some((clip, frame)), Some(lib)) if clip < lib.len() => {
                let m = lib.get(clip);
                Some(poser.qpos(m, frame.min(m.clip.num_frames.saturating_sub(1)))?)
            }
            (Some((clip, frame)), None) => match env.reference_state(clip, frame) {
                Some(state) => Some(poser.qpos_of(&state)?),
                None => None,
            },
            _ => None,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env_of(task: &str) -> (Box<dyn Env>, EnvConfig) {
        let cfg = EnvConfig { task: task.into(), num_envs: 1, threads: 1, ..EnvConfig::default() };
        (skillmimic_env::registry::make(&cfg).unwrap(), cfg)
    }

    /// Over four seeded resets, the ghost of the reset's reference frame equals the reset state.
    fn ghosts_equal_resets(env: &mut dyn Env, cfg: &EnvConfig) {
        for seed in 0..4 {
            env.reset_all(Some(seed));
            let r = current_reference(env, reference_fields(env).unwrap());
            let g = ghost_states(env, cfg, GhostMode::Overlay, &[r]).unwrap();
            let (ghost, sim) = (g[0].as_ref().unwrap(), env.mujoco().env_qpos(0));
            assert_eq!(ghost.len(), sim.len());
            let worst = ghost.iter().zip(sim).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-9, "seed {seed}: ghost and reset state differ by {worst}");
        }
    }

    #[test]
    fn the_ghost_of_a_reset_is_the_reset_state() {
        // a reset places the character (and ball) exactly at the reference frame it starts from,
        // so the ghost of that step must coincide with the simulated state
        let (mut env, cfg) = env_of("imitation");
        ghosts_equal_resets(env.as_mut(), &cfg);
    }

    #[test]
    fn the_ghost_of_a_tracking_reset_on_smpl_is_the_reset_state() {
        // the SMPL humanoid's clips are posed by the tracking task itself
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions");
        // episodes start at random frames of the demo clips retargeted onto SMPL
        let cfg = EnvConfig {
            task: "tracking".into(),
            num_envs: 1,
            threads: 1,
            motion: vec![dir],
            character: "smpl".into(),
            ..EnvConfig::default()
        };
        let mut env = skillmimic_env::registry::make(&cfg).unwrap();
        ghosts_equal_resets(env.as_mut(), &cfg);
    }

    #[test]
    fn a_task_without_clips_has_no_ghost() {
        let (mut env, cfg) = env_of("stand");
        env.reset_all(Some(0));
        assert!(reference_fields(env.as_ref()).is_none());
        let auto = ghost_states(env.as_ref(), &cfg, GhostMode::Auto, &[None, None]).unwrap();
        assert_eq!(auto, vec![None, None]);
        let err = ghost_states(env.as_ref(), &cfg, GhostMode::Beside, &[None]).unwrap_err();
        assert!(err.to_string().contains("plays no reference clips"), "{err}");
    }
}
