//! `skillmimic trace --character tokenhsi`: the physics trace of the TokenHSI batch for the
//! PyPI-mujoco cross-check (`tests/test_hsi_character.py`). Same file layout as `skillmimic
//! trace` (actions are `steps × envs × 32`), plus `mocap_pos` / `mocap_quat` (envs × nmocap × 3/4)
//! of the static objects after reset and the metadata `character = tokenhsi`.

use std::collections::BTreeMap;
use std::sync::Arc;

use anyhow::Context;
use rand::{Rng, SeedableRng};
use skillmimic_core::hsi_character::{NUM_DOFS, STANDING_ROOT_HEIGHT};
use skillmimic_core::math::Quat;
use skillmimic_core::tensorfile::{OwnedTensor, write_atomic};
use skillmimic_sim::{HsiBatch, HsiObject, HsiReset, HsiScene, ObjectBox, ObjectState};

/// What the TokenHSI trace needs of `skillmimic trace`'s arguments (its own type, so that this
/// module does not depend on `cmd_trace`, which dispatches here).
pub struct Args<'a> {
    pub out: &'a std::path::Path,
    pub envs: usize,
    pub steps: usize,
    pub seed: u64,
    pub amplitude: f32,
    pub threads: usize,
}

/// A carry scene: a 0.4 × 0.3 × 0.3 m box of 5 kg on a thin support, a second support.
fn carry_objects() -> Vec<HsiObject> {
    let slab = |name: &str| HsiObject {
        name: name.into(),
        mass: None,
        boxes: vec![ObjectBox { center: [0.0; 3], half: [0.3, 0.3, 0.01] }],
        rgba: [0.5, 0.5, 0.5, 1.0],
    };
    vec![
        HsiObject {
            name: "box".into(),
            mass: Some(5.0),
            boxes: vec![ObjectBox { center: [0.0; 3], half: [0.2, 0.15, 0.15] }],
            rgba: [0.7, 0.5, 0.3, 1.0],
        },
        slab("support_start"),
        slab("support_target"),
    ]
}

pub fn run(a: &Args<'_>) -> anyhow::Result<()> {
    let scene = Arc::new(HsiScene::new(carry_objects())?);
    let (nq, nv, _) = scene.sizes();
    let mut sim = HsiBatch::new(vec![scene.clone()], a.envs, a.threads)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(a.seed ^ 0x5eed);
    let states: Vec<HsiReset> = (0..a.envs)
        .map(|i| {
            let mut s = HsiReset { root_quat: Quat::about_z(0.7 * i as f64), ..Default::default() };
            s.root_pos = [0.1 * i as f64, 0.0, STANDING_ROOT_HEIGHT + 0.02];
            s.root_linvel = [0.3, -0.2, 0.1];
            s.root_angvel_local = [0.2, 0.5, -0.1];
            for d in s.dof_pos.iter_mut() {
                *d = rng.random_range(-0.3..0.3);
            }
            let h = 0.4 + 0.1 * i as f64;
            s.objects[0] = ObjectState {
                pos: [0.8, 0.0, h + 0.16],
                quat: Quat::about_z(0.3),
                ..Default::default()
            };
            s.objects[1] = ObjectState { pos: [0.8, 0.0, h], ..Default::default() };
            s.objects[2] = ObjectState {
                pos: [-1.5, 2.0, 0.6],
                quat: Quat::about_z(-0.4),
                ..Default::default()
            };
            s
        })
        .collect();
    sim.reset(&vec![true; a.envs], &states)?;
    let grab = |sim: &HsiBatch, q: &mut Vec<f64>, v: &mut Vec<f64>| {
        for i in 0..a.envs {
            q.extend_from_slice(sim.data(i).qpos());
            v.extend_from_slice(sim.data(i).qvel());
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
    meta.insert("character".to_string(), "tokenhsi".to_string());
    meta.insert("unstable_steps".to_string(), unstable.to_string());
    let tensors = [
        OwnedTensor::f64("qpos0", &[a.envs, nq], &qpos0),
        OwnedTensor::f64("qvel0", &[a.envs, nv], &qvel0),
        OwnedTensor::f64("mocap_pos", &[a.envs, nmocap, 3], &mpos),
        OwnedTensor::f64("mocap_quat", &[a.envs, nmocap, 4], &mquat),
        OwnedTensor::f32("actions", &[a.steps, a.envs, NUM_DOFS], &all_actions),
        OwnedTensor::f64("qpos", &[a.steps, a.envs, nq], &qpos),
        OwnedTensor::f64("qvel", &[a.steps, a.envs, nv], &qvel),
    ];
    write_atomic(a.out, &tensors, &meta)
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
