//! `skillmimic play`: roll out a policy, or play a reference clip back kinematically, and write a
//! headless video (MP4 or GIF) and/or the visited states in one step.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, bail};
use skillmimic_core::tensorfile::{OwnedTensor, write_atomic};
use skillmimic_env::config::EnvConfig;
use skillmimic_env::{Env, load_motion_library};
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_sim::Scene;

use crate::common::{ConfigFlags, load_checkpoint};
use crate::ghost::{ClipPoser, GhostMode, current_reference, ghost_states, reference_fields};
use crate::video::{Frames, Ghost, SceneRenderer, write_video};
use skillmimic_env::markers::Marker;
use skillmimic_env::tasks::hlc::config::HlcConfig;

#[derive(clap::Args)]
pub struct Args {
    /// Policy checkpoint to roll out.
    #[arg(long, conflicts_with = "reference")]
    pub checkpoint: Option<PathBuf>,
    /// Play this clip back kinematically instead: a SkillMimic clip (`.pt`, `.safetensors`) or
    /// another character's `character-clip` file (the SMPL humanoid, TokenHSI).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    #[command(flatten)]
    pub flags: ConfigFlags,
    /// Policy steps to roll out; for a reference, 60 Hz frames (default: whole clip).
    #[arg(long, default_value_t = 240)]
    pub steps: usize,
    /// Video file (.mp4 or .gif), rendered headless.
    #[arg(long)]
    pub video: Option<PathBuf>,
    /// Save the visited states (qpos per step, safetensors).
    #[arg(long)]
    pub states: Option<PathBuf>,
    /// Frame size.
    #[arg(long, default_value_t = 480)]
    pub width: usize,
    #[arg(long, default_value_t = 360)]
    pub height: usize,
    /// Video frame rate (every (policy rate / fps)-th step is rendered: the SkillMimic
    /// humanoid's policy runs at 60 Hz, the SMPL humanoid's at 30 Hz).
    #[arg(long, default_value_t = 30)]
    pub fps: u32,
    /// Seed of the episode sampling.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Sample actions from the Gaussian instead of using the mean.
    #[arg(long)]
    pub stochastic: bool,
    /// The reference motion in a policy's video, drawn as a translucent ghost: `auto` (over the
    /// character when the task plays reference clips), `overlay`, `beside` (1.2 m to the side),
    /// `off`.
    #[arg(long, value_enum, default_value_t = GhostMode::Auto)]
    pub ghost: GhostMode,
    /// High-level tasks: open MuJoCo's interactive viewer instead (keys switch skills, a floor
    /// double-click places the target; runs `python -m skillmimic_rs.interactive`, needs a
    /// display and the Python package).
    #[arg(long)]
    pub interactive: bool,
}

/// Hand a high-level checkpoint to the Python viewer with its whole configuration (the flags on
/// top), written to a temporary TOML file for the viewer's `--config`.
fn interactive(ckpt: &Path, flags: &ConfigFlags) -> anyhow::Result<()> {
    let (_, mut cfg) = load_checkpoint(ckpt)?;
    flags.apply(&mut cfg)?;
    if !skillmimic_env::registry::is_high_level(&cfg.env.task) {
        let high: Vec<&str> = skillmimic_env::registry::TASKS
            .iter()
            .filter(|t| t.high_level.is_some())
            .map(|t| t.name)
            .collect();
        bail!(
            "--interactive plays the high-level tasks ({}); this checkpoint's task is '{}'",
            high.join(", "),
            cfg.env.task
        );
    }
    let python = crate::video::python_candidates()
        .into_iter()
        .find(|p| p.exists())
        .unwrap_or_else(|| PathBuf::from("python3"));
    let config =
        std::env::temp_dir().join(format!("skillmimic-interactive-{}.toml", std::process::id()));
    skillmimic_core::tensorfile::write_bytes_atomic(&config, cfg.to_toml().as_bytes())
        .with_context(|| format!("cannot write {}", config.display()))?;
    let mut cmd = std::process::Command::new(&python);
    cmd.args(["-m", "skillmimic_rs.interactive", "--task", &cfg.env.task, "--llc"])
        .arg(&cfg.env.table::<HlcConfig>().llc)
        .arg("--checkpoint")
        .arg(ckpt)
        .arg("--config")
        .arg(&config);
    let status = cmd.status();
    let _ = std::fs::remove_file(&config);
    let status = status.with_context(|| {
        format!(
            "cannot start {} (the interactive viewer is part of the Python package: pip install .)",
            python.display()
        )
    })?;
    if !status.success() {
        bail!("the interactive viewer exited with {status}");
    }
    Ok(())
}

/// A filmed rollout: qpos of environment 0 after every policy step, its task information row
/// (the goal of a high-level task; empty rows otherwise) and, for a task playing reference clips,
/// the (clip, frame) the state is compared with.
pub struct Rollout {
    pub qpos: Vec<Vec<f64>>,
    pub info: Vec<Vec<f32>>,
    pub reference: Vec<Option<(usize, usize)>>,
}

/// Environment 0's state, information row and reference.
fn snapshot(env: &dyn Env, r: &mut Rollout) {
    let ni = env.spec().info_names.len();
    r.qpos.push(env.mujoco().env_qpos(0).to_vec());
    r.info.push(env.buffers().info[..ni].to_vec());
    r.reference.push(reference_fields(env).and_then(|f| current_reference(env, f)));
}

/// Rollout of `policy` in one environment (auto-reset on episode end).
pub fn rollout_states(
    policy: &Policy,
    env: &mut dyn Env,
    steps: usize,
    stochastic: bool,
    seed: u64,
) -> anyhow::Result<Rollout> {
    use rand::SeedableRng;
    if (env.obs_dim(), env.act_dim()) != (policy.obs_dim(), policy.act_dim()) {
        let base = skillmimic_env::obs::layout::OBS_DIM;
        let hint = match (policy.obs_dim(), env.obs_dim()) {
            (p, e) if p == e + 3 && e == base => {
                " (the policy was trained with SkillMimic-V2's history embedding, 902 + 3: enable \
                    env.v2.history with its encoder file, or play with the checkpoint's own \
                    configuration)"
            }
            (p, e) if e == p + 3 && p == base => {
                " (the environment appends SkillMimic-V2's history embedding, 902 + 3, but the \
                    policy was trained without it: set env.v2.history.enabled = false)"
            }
            _ => "",
        };
        bail!(
            "the policy takes observations of {} and gives actions of {}; task '{}' has \
                observations of {} and actions of {}{hint}",
            policy.obs_dim(),
            policy.act_dim(),
            env.spec().name,
            env.obs_dim(),
            env.act_dim()
        );
    }
    let (n, a, o) = (env.num_envs(), env.act_dim(), policy.actor_outputs());
    env.set_autoreset(true);
    env.reset_all(Some(seed));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut buf = InferenceBuffers::default();
    let (mut mu, mut v, mut act, mut nl) =
        (vec![0.0; n * o], vec![0.0; n], vec![0.0; n * a], vec![0.0; n]);
    let mut states = Rollout { qpos: Vec::new(), info: Vec::new(), reference: Vec::new() };
    snapshot(env, &mut states);
    for _ in 0..steps {
        policy.infer(&env.buffers().obs, n, &mut buf, &mut mu, &mut v, 0);
        if stochastic {
            policy.sample(&mu, n, &mut rng, &mut act, &mut nl);
        } else {
            policy.mode(&mu, n, &mut act);
        }
        env.step(&act)?;
        snapshot(env, &mut states);
    }
    Ok(states)
}

/// What a video draws besides the states: the markers of `markers[k]` on frame k's state, and the
/// ghost state `ghosts[k]` shifted by `ghost_offset` (world, m).
#[derive(Clone, Copy, Default)]
pub struct Overlays<'a> {
    pub markers: Option<&'a [Vec<Marker>]>,
    pub ghosts: Option<&'a [Option<Vec<f64>>]>,
    pub ghost_offset: [f64; 3],
}

/// Render `states` (every `stride`-th) into frames with their overlays.
pub fn render_states(
    model: &Arc<mujoco_rs::prelude::MjModel>,
    states: &[Vec<f64>],
    over: Overlays<'_>,
    stride: usize,
    (w, h): (usize, usize),
    fps: u32,
) -> anyhow::Result<Frames> {
    let mut r = SceneRenderer::new(model, w, h)?;
    let mut rgb = Vec::new();
    for (k, q) in states.iter().enumerate().step_by(stride.max(1)) {
        let ghost = over.ghosts.and_then(|g| g[k].as_deref());
        let ghost = ghost.map(|qpos| Ghost { qpos, offset: over.ghost_offset });
        rgb.push(r.render_frame(q, over.markers.map_or(&[][..], |m| &m[k]), ghost)?);
    }
    Ok(Frames { width: w, height: h, fps, rgb })
}

/// Frame stride and video rate for states recorded at `rate` Hz (one per policy step) at a
/// requested `fps`.
pub fn video_rate(rate: f64, fps: u32) -> (usize, u32) {
    let rate = (rate.round() as u32).max(1);
    let stride = (rate / fps.max(1)).max(1);
    (stride as usize, rate / stride)
}

/// Policy steps per second of a task's environment: the character's control rate (60 Hz for
/// the SkillMimic humanoid, 30 Hz for the SMPL humanoid and the TokenHSI character) over the
/// task's `steps_per_action`. The character is the one the task runs on (the task's default
/// when `env.character` is empty, as the `hsi_*` tasks' saved configurations have it).
fn policy_rate(env: &dyn Env, cfg: &EnvConfig) -> anyhow::Result<f64> {
    let spec = skillmimic_env::registry::character(cfg)?.spec();
    let dt = spec.timestep * spec.substeps as f64 * env.spec().steps_per_action.max(1) as f64;
    Ok(1.0 / dt)
}

/// Render a rollout of a task's environment (configured by `cfg`): its markers from the
/// information rows and the reference ghost as `ghost` says.
fn render_rollout(
    env: &dyn Env,
    cfg: &EnvConfig,
    r: &Rollout,
    ghost: GhostMode,
    fps: u32,
    size: (usize, usize),
) -> anyhow::Result<Frames> {
    let markers: Vec<Vec<Marker>> = r.info.iter().map(|row| env.markers(row)).collect();
    let ghosts = ghost_states(env, cfg, ghost, &r.reference)?;
    let over = Overlays {
        markers: Some(&markers),
        ghosts: Some(&ghosts),
        ghost_offset: ghost.offset().unwrap_or_default(),
    };
    let (stride, fps) = video_rate(policy_rate(env, cfg)?, fps);
    render_states(env.mujoco().env_model(0), &r.qpos, over, stride, size, fps)
}

/// Roll out `policy` deterministically in `env` (its first environment is filmed; configured by
/// `cfg`) for `steps` steps from seed `seed` and write a video with the reference ghost where the
/// task has one.
pub fn render_policy_video(
    policy: &Policy,
    (mut env, cfg): (Box<dyn Env>, &EnvConfig),
    seed: u64,
    steps: usize,
    path: &Path,
    size: (usize, usize),
) -> anyhow::Result<()> {
    let states = rollout_states(policy, env.as_mut(), steps, false, seed)?;
    let frames = render_rollout(env.as_ref(), cfg, &states, GhostMode::Auto, 30, size)?;
    write_video(path, &frames)
}

fn save_states(path: &Path, states: &[Vec<f64>], xml: &str, source: &str) -> anyhow::Result<()> {
    let nq = states[0].len();
    let flat: Vec<f64> = states.iter().flatten().copied().collect();
    let mut meta = BTreeMap::new();
    meta.insert("mjcf".to_string(), xml.to_string());
    meta.insert("source".to_string(), source.to_string());
    meta.insert("fps".to_string(), "60".to_string());
    write_atomic(path, &[OwnedTensor::f64("qpos", &[states.len(), nq], &flat)], &meta)
        .with_context(|| format!("cannot write {}", path.display()))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.interactive {
        let ckpt = a
            .checkpoint
            .as_deref()
            .context("--interactive needs --checkpoint (a high-level policy)")?;
        return interactive(ckpt, &a.flags);
    }
    if a.video.is_none() && a.states.is_none() {
        bail!("nothing to do: give --video out.mp4|out.gif and/or --states out.safetensors");
    }
    let stride = (60 / a.fps.max(1)) as usize;
    let (states, scene, source) = match (&a.checkpoint, &a.reference) {
        (Some(ckpt), None) => {
            let (c, mut cfg) = load_checkpoint(ckpt)?;
            a.flags.apply(&mut cfg)?;
            cfg.env.num_envs = 1;
            cfg.env.threads = 1;
            let mut env = skillmimic_env::registry::make(&cfg.env)?;
            let r = rollout_states(&c.policy, env.as_mut(), a.steps, a.stochastic, a.seed)
                .with_context(|| format!("{}", ckpt.display()))?;
            if let Some(p) = &a.states {
                save_states(
                    p,
                    &r.qpos,
                    env.mujoco().env_xml(0),
                    &format!("policy {}", ckpt.display()),
                )?;
                println!("states {} ({} steps)", p.display(), r.qpos.len());
            }
            if let Some(p) = &a.video {
                let size = (a.width, a.height);
                let frames = render_rollout(env.as_ref(), &cfg.env, &r, a.ghost, a.fps, size)?;
                write_video(p, &frames)?;
                println!(
                    "video  {} ({} frames at {} fps)",
                    p.display(),
                    frames.rgb.len(),
                    frames.fps
                );
            }
            return Ok(());
        }
        (None, Some(clip)) => {
            let (states, scene) = match load_motion_library(std::slice::from_ref(clip)) {
                Ok(lib) => {
                    let m = lib.get(0);
                    let scene = Arc::new(Scene::default_for(skillmimic_sim::HandModel::Full)?);
                    let mut poser = ClipPoser::new(scene.clone())?;
                    let frames = m.clip.num_frames.min(a.steps.max(1));
                    let states: Vec<Vec<f64>> =
                        (0..frames).map(|t| poser.qpos(m, t)).collect::<anyhow::Result<_>>()?;
                    (states, scene)
                }
                // another character's clip (`character-clip`: SMPL, TokenHSI)
                Err(lib_err) => character_clip_states(clip, a.steps).map_err(|e| {
                    anyhow::anyhow!(
                        "{}: neither a SkillMimic clip ({lib_err}) nor a character clip ({e})",
                        clip.display()
                    )
                })?,
            };
            (states, scene, format!("reference {}", clip.display()))
        }
        _ => bail!("give exactly one of --checkpoint or --reference"),
    };
    if let Some(p) = &a.states {
        save_states(p, &states, scene.xml(), &source)?;
        println!("states {} ({} steps)", p.display(), states.len());
    }
    if let Some(p) = &a.video {
        let size = (a.width, a.height);
        let frames =
            render_states(scene.model(), &states, Overlays::default(), stride, size, a.fps)?;
        write_video(p, &frames)?;
        println!("video  {} ({} frames at {} fps)", p.display(), frames.rgb.len(), a.fps);
    }
    Ok(())
}

/// The MuJoCo states (qpos per 60 Hz frame, at most `steps`) of a `character-clip` file played
/// back kinematically in its character's bare scene, and that scene.
fn character_clip_states(path: &Path, steps: usize) -> anyhow::Result<(Vec<Vec<f64>>, Arc<Scene>)> {
    use skillmimic_motion::character_clip::CharacterClip;
    let clip = CharacterClip::load(path)?;
    let hands = skillmimic_sim::HandModel::Full;
    let character = skillmimic_core::characters::Character::by_name(&clip.character, hands)
        .with_context(|| format!("no registered character '{}'", clip.character))?;
    let scene = Arc::new(Scene::new(skillmimic_sim::SceneOptions::bare(character))?);
    let spec = scene.character().clone();
    // the renderer's frames are 60 Hz states
    let clip = clip.resampled(&spec, 60.0);
    let mut sim = skillmimic_sim::BatchSim::new(scene.clone(), 1, 1)?;
    let mut state = skillmimic_sim::ResetState::rest(&scene);
    let mut states = Vec::new();
    for t in 0..clip.num_frames.min(steps.max(1)) {
        skillmimic_env::clip_state::clip_state(&spec, &clip, t, &mut state);
        sim.reset(&[true], std::slice::from_ref(&state))?;
        states.push(sim.qpos(0).to_vec());
    }
    Ok((states, scene))
}
