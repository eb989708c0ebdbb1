//! `skillmimic trace`: record a physics trace of the batched core for the cross-check with the
//! official `mujoco` Python package (`tests/test_physics_crosscheck.py`).
//!
//! The file (safetensors) holds the MJCF text in its metadata, the state right after reset
//! (`qpos0`, `qvel0`), the action sequence (`actions`, steps × envs × 156, float32) and the raw
//! state after every policy step (`qpos`, `qvel`, steps × envs × nq/nv).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use rand::{Rng, SeedableRng};
use skillmimic_core::skeleton::NUM_DOFS;
use skillmimic_core::tensorfile::{OwnedTensor, write_atomic};
use skillmimic_motion::Clip;
use skillmimic_sim::{BatchSim, HandModel, ResetState, Scene};

#[derive(clap::Args)]
pub struct Args {
    /// Output file (.safetensors).
    #[arg(long)]
    pub out: PathBuf,
    /// Number of environments.
    #[arg(long, default_value_t = 3)]
    pub envs: usize,
    /// Policy steps (each = 2 physics steps).
    #[arg(long, default_value_t = 500)]
    pub steps: usize,
    /// Random seed of the actions.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Amplitude of the uniform random actions.
    #[arg(long, default_value_t = 0.5)]
    pub amplitude: f32,
    /// Hand model: full or box.
    #[arg(long, default_value = "full")]
    pub hands: String,
    /// Start every environment from a frame of this BallPlay-M clip (default: upright zero pose).
    #[arg(long)]
    pub clip: Option<PathBuf>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Character: `skillmimic` (the humanoid + ball scene) or `tokenhsi` (the 32-DoF TokenHSI
    /// character with a carry box on two supports; `--hands` and `--clip` do not apply).
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

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.character.as_str() {
        "skillmimic" => {}
        "tokenhsi" => {
            let hsi = crate::cmd_trace_hsi::Args {
                out: &a.out,
                envs: a.envs,
                steps: a.steps,
                seed: a.seed,
                amplitude: a.amplitude,
                threads: a.threads,
            };
            return crate::cmd_trace_hsi::run(&hsi);
        }
        other => {
            anyhow::bail!("unknown --character '{other}', expected 'skillmimic' or 'tokenhsi'")
        }
    }
    let hands = parse_hands(&a.hands)?;
    let scene = Arc::new(Scene::default_for(hands)?);
    let (nq, nv, _) = scene.sizes();
    let mut sim = BatchSim::new(scene.clone(), a.envs, a.threads)?;
    let mut states = vec![ResetState::default(); a.envs];
    if let Some(path) = &a.clip {
        let clip = Clip::from_pt(path)?;
        for (i, s) in states.iter_mut().enumerate() {
            let t = (2 + 17 * i) % clip.num_frames;
            s.root_pos = clip.root_pos_at(t);
            s.root_quat = clip.root_quat_at(t);
            for (d, &v) in s.dof_pos.iter_mut().zip(clip.dof_at(t)) {
                *d = v as f64;
            }
            s.ball_pos = clip.ball_pos_at(t);
            // a little motion so that velocities matter from the first step
            s.root_linvel = [0.3, -0.2, 0.1];
            s.root_angvel_local = [0.2, 0.5, -0.1];
            s.ball_linvel = [0.5, 0.0, 1.0];
        }
    }
    sim.reset(&vec![true; a.envs], &states)?;
    let grab = |sim: &BatchSim, q: &mut Vec<f64>, v: &mut Vec<f64>| {
        for i in 0..a.envs {
            q.extend_from_slice(sim.qpos(i));
            v.extend_from_slice(sim.qvel(i));
        }
    };
    let (mut qpos0, mut qvel0) = (Vec::new(), Vec::new());
    grab(&sim, &mut qpos0, &mut qvel0);

    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(a.seed);
    let mut all_actions = Vec::with_capacity(a.steps * a.envs * NUM_DOFS);
    let (mut qpos, mut qvel) = (Vec::new(), Vec::new());
    let mut unstable = 0usize;
    for _ in 0..a.steps {
        let actions: Vec<f32> =
            (0..a.envs * NUM_DOFS).map(|_| a.amplitude * rng.random_range(-1.0f32..=1.0)).collect();
        sim.step(&actions)?;
        unstable += sim.state().unstable.iter().filter(|&&u| u != 0).count();
        all_actions.extend_from_slice(&actions);
        grab(&sim, &mut qpos, &mut qvel);
    }
    let mut meta = BTreeMap::new();
    meta.insert("xml".to_string(), scene.xml().to_string());
    meta.insert("substeps".to_string(), sim.substeps().to_string());
    meta.insert("hands".to_string(), hands.name().to_string());
    meta.insert("unstable_steps".to_string(), unstable.to_string());
    let tensors = [
        OwnedTensor::f64("qpos0", &[a.envs, nq], &qpos0),
        OwnedTensor::f64("qvel0", &[a.envs, nv], &qvel0),
        OwnedTensor::f32("actions", &[a.steps, a.envs, NUM_DOFS], &all_actions),
        OwnedTensor::f64("qpos", &[a.steps, a.envs, nq], &qpos),
        OwnedTensor::f64("qvel", &[a.steps, a.envs, nv], &qvel),
    ];
    write_atomic(&a.out, &tensors, &meta)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    tracing::info!(
        "wrote {} ({} envs x {} policy steps, {} unstable env-steps)",
        a.out.display(),
        a.envs,
        a.steps,
        unstable
    );
    Ok(())
}
