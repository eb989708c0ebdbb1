//! `skillmimic trace`: record a physics trace of the batched core for the cross-checks with the
//! official `mujoco` Python package (`tests/test_physics_crosscheck.py`,
//! `tests/test_hsi_character.py`, `tests/test_smpl_character.py`), for any character.
//!
//! The file (safetensors) holds the MJCF text in its metadata (with `character`, `substeps`,
//! `unstable_steps`, and `hands` for the SkillMimic humanoid), the state right after reset
//! (`qpos0`, `qvel0`), the static objects' poses (`mocap_pos`, `mocap_quat`, envs × nmocap × 3/4,
//! where the scene has any), the action sequence (`actions`, steps × envs × dofs, float32) and the
//! raw state after every policy step (`qpos`, `qvel`, steps × envs × nq/nv).
//!
//! Scenes and start states per character:
//! * `skillmimic`: the humanoid and the ball (`--hands`); the upright zero pose, or frames of a
//!   BallPlay-M clip (`--clip`) with a little root and ball motion;
//! * `tokenhsi`: the character with a 5 kg box on a thin static support and a second support;
//!   environment i turned by 0.7·i rad, 2 cm above the floor, random joint angles in ±0.3 rad;
//! * `smpl`: the bare SMPL humanoid; the same kind of start as `tokenhsi`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::Quat;
use skillmimic_core::tensorfile::{OwnedTensor, write_atomic};
use skillmimic_motion::Clip;
use skillmimic_sim::mjcf::default_scene;
use skillmimic_sim::{
    BatchSim, BoxObject, Character, HandModel, ObjectBox, ObjectState, ResetState, Scene,
};

#[derive(clap::Args)]
pub struct Args {
    /// Output file (.safetensors).
    #[arg(long)]
    pub out: PathBuf,
    /// Number of environments.
    #[arg(long, default_value_t = 3)]
    pub envs: usize,
    /// Policy steps (each = the character's physics sub-steps).
    #[arg(long, default_value_t = 500)]
    pub steps: usize,
    /// Random seed of the actions.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Amplitude of the uniform random actions.
    #[arg(long, default_value_t = 0.5)]
    pub amplitude: f32,
    /// Hand model of the SkillMimic humanoid: full or box.
    #[arg(long, default_value = "full")]
    pub hands: String,
    /// Start every environment from a frame of this BallPlay-M clip (SkillMimic humanoid only;
    /// default: upright zero pose).
    #[arg(long)]
    pub clip: Option<PathBuf>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Character: `skillmimic` (the humanoid + ball scene), `tokenhsi` (the 32-DoF TokenHSI
    /// character with a carry box on two supports) or `smpl` (the 69-DoF SMPL humanoid).
    #[arg(long, default_value = "skillmimic")]
    pub character: String,
}

pub fn parse_hands(s: &str) -> anyhow::Result<HandModel> {
    match s {
        "full" => Ok(HandModel::Full),
        "box" | "boxhand" => Ok(HandModel::Box),
        other => anyhow::bail!("unknown hand model '{other}', expected 'full' or 'box'"),
    }
}

/// A carry scene: a 0.4 × 0.3 × 0.3 m box of 5 kg on a thin support, a second support.
fn carry_objects() -> Vec<BoxObject> {
    let slab = |name: &str| BoxObject {
        name: name.into(),
        mass: None,
        boxes: vec![ObjectBox { center: [0.0; 3], half: [0.3, 0.3, 0.01] }],
        rgba: [0.5, 0.5, 0.5, 1.0],
    };
    vec![
        BoxObject {
            name: "box".into(),
            mass: Some(5.0),
            boxes: vec![ObjectBox { center: [0.0; 3], half: [0.2, 0.15, 0.15] }],
            rgba: [0.7, 0.5, 0.3, 1.0],
        },
        slab("support_start"),
        slab("support_target"),
    ]
}

/// Turned, lifted, moving starts with random joint angles (the TokenHSI and SMPL traces).
fn varied_starts(scene: &Scene, n: usize, rng: &mut ChaCha8Rng) -> Vec<ResetState> {
    (0..n)
        .map(|i| {
            let mut s = ResetState::rest(scene);
            s.root_quat = Quat::about_z(0.7 * i as f64).mul(s.root_quat);
            s.root_pos = [0.1 * i as f64, 0.0, s.root_pos[2] + 0.02];
            s.root_linvel = [0.3, -0.2, 0.1];
            s.root_angvel_local = [0.2, 0.5, -0.1];
            for d in s.dof_pos.iter_mut() {
                *d = rng.random_range(-0.3..0.3);
            }
            if s.objects.len() == 3 {
                let h = 0.4 + 0.1 * i as f64;
                let q = Quat::about_z(0.3);
                s.objects[0] =
                    ObjectState { pos: [0.8, 0.0, h + 0.16], quat: q, ..Default::default() };
                s.objects[1] = ObjectState { pos: [0.8, 0.0, h], ..Default::default() };
                let q = Quat::about_z(-0.4);
                s.objects[2] = ObjectState { pos: [-1.5, 2.0, 0.6], quat: q, ..Default::default() };
            }
            s
        })
        .collect()
}

/// Frames of a BallPlay-M clip, with a little motion so that velocities matter from the first
/// step.
fn clip_starts(path: &std::path::Path, n: usize) -> anyhow::Result<Vec<ResetState>> {
    let clip = Clip::from_pt(path)?;
    Ok((0..n)
        .map(|i| {
            let mut s = ResetState::default();
            let t = (2 + 17 * i) % clip.num_frames;
            s.root_pos = clip.root_pos_at(t);
            s.root_quat = clip.root_quat_at(t);
            for (d, &v) in s.dof_pos.iter_mut().zip(clip.dof_at(t)) {
                *d = v as f64;
            }
            s.ball_mut().pos = clip.ball_pos_at(t);
            s.root_linvel = [0.3, -0.2, 0.1];
            s.root_angvel_local = [0.2, 0.5, -0.1];
            s.ball_mut().linvel = [0.5, 0.0, 1.0];
            s
        })
        .collect())
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let hands = parse_hands(&a.hands)?;
    let Some(character) = Character::by_name(&a.character, hands) else {
        anyhow::bail!(
            "unknown --character '{}', expected one of {}",
            a.character,
            Character::NAMES.join(", ")
        );
    };
    if a.clip.is_some() && !character.plays_ballplay() {
        anyhow::bail!(
            "--clip starts the SkillMimic humanoid from a BallPlay-M clip; it does not apply to \
                --character {}",
            a.character
        );
    }
    let mut options = default_scene(character);
    if character == tokenhsi::CHARACTER {
        options.objects = carry_objects();
    }
    let scene = Arc::new(Scene::new(options)?);
    let (nq, nv, _) = scene.sizes();
    let nd = scene.num_dofs();
    let mut sim = BatchSim::new(scene.clone(), a.envs, a.threads)?;
    // the TokenHSI trace keeps the stream of its earlier dedicated command
    let mut rng = ChaCha8Rng::seed_from_u64(if character == tokenhsi::CHARACTER {
        a.seed ^ 0x5eed
    } else {
        a.seed
    });
    let states = match &a.clip {
        Some(path) => clip_starts(path, a.envs)?,
        None if character.plays_ballplay() => vec![ResetState::default(); a.envs],
        None => varied_starts(&scene, a.envs, &mut rng),
    };
    sim.reset(&vec![true; a.envs], &states)?;
    let grab = |sim: &BatchSim, q: &mut Vec<f64>, v: &mut Vec<f64>| {
        for i in 0..a.envs {
            q.extend_from_slice(sim.qpos(i));
            v.extend_from_slice(sim.qvel(i));
        }
    };
    let (mut qpos0, mut qvel0) = (Vec::new(), Vec::new());
    grab(&sim, &mut qpos0, &mut qvel0);
    let (mut mpos, mut mquat) = (Vec::new(), Vec::new());
    for i in 0..a.envs {
        mpos.extend(sim.data(i).mocap_pos().iter().flatten());
        mquat.extend(sim.data(i).mocap_quat().iter().flatten());
    }
    let nmocap = mpos.len() / (3 * a.envs);
    let mut all_actions = Vec::with_capacity(a.steps * a.envs * nd);
    let (mut qpos, mut qvel) = (Vec::new(), Vec::new());
    let mut unstable = 0usize;
    for _ in 0..a.steps {
        let actions: Vec<f32> =
            (0..a.envs * nd).map(|_| a.amplitude * rng.random_range(-1.0f32..=1.0)).collect();
        sim.step(&actions)?;
        unstable += sim.state().unstable.iter().filter(|&&u| u != 0).count();
        all_actions.extend_from_slice(&actions);
        grab(&sim, &mut qpos, &mut qvel);
    }
    let mut meta = BTreeMap::new();
    meta.insert("xml".to_string(), scene.xml().to_string());
    meta.insert("substeps".to_string(), sim.substeps().to_string());
    meta.insert("character".to_string(), character.name().to_string());
    if let Some(hands) = character.hands() {
        meta.insert("hands".to_string(), hands.name().to_string());
    }
    meta.insert("unstable_steps".to_string(), unstable.to_string());
    let mut tensors = vec![
        OwnedTensor::f64("qpos0", &[a.envs, nq], &qpos0),
        OwnedTensor::f64("qvel0", &[a.envs, nv], &qvel0),
        OwnedTensor::f32("actions", &[a.steps, a.envs, nd], &all_actions),
        OwnedTensor::f64("qpos", &[a.steps, a.envs, nq], &qpos),
        OwnedTensor::f64("qvel", &[a.steps, a.envs, nv], &qvel),
    ];
    if nmocap > 0 {
        tensors.push(OwnedTensor::f64("mocap_pos", &[a.envs, nmocap, 3], &mpos));
        tensors.push(OwnedTensor::f64("mocap_quat", &[a.envs, nmocap, 4], &mquat));
    }
    write_atomic(&a.out, &tensors, &meta)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    tracing::info!(
        "wrote {} ({} {} envs x {} policy steps, {} unstable env-steps)",
        a.out.display(),
        character.name(),
        a.envs,
        a.steps,
        unstable
    );
    Ok(())
}
