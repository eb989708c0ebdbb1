//! Dump body-position sequences of the SMPL humanoid under `tracking` for the metrics golden
//! fixture `tests/fixtures/phc_metrics_golden.json` (see its note): PHC's `compute_metrics_lite`,
//! which the released ModSkill evaluation calls, is then run on them outside this repository.
//!
//! `cargo run --release -p skillmimic-env --example tracking_sequences -- OUT_DIR`
//! writes `OUT_DIR/metrics_inputs.json`.
//!
//! Four rollouts of the SMPL humanoid, each started in a reference state of a shipped demo clip
//! (retargeted to SMPL by joint name) and driven by random PD targets of one strength (gentle to
//! strong, so that the errors range from millimetres to metres), of different lengths. Per policy
//! step: the simulated body positions after the step (`pred`) and the compared reference frame's
//! (`gt`), world frame, m, the character's body order; values to 9 significant digits.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::json;
use skillmimic_env::EnvConfig;
use skillmimic_env::tasks::tracking::Tracking;
use skillmimic_env::tasks::tracking::formulas::Bodies;
use skillmimic_env::tasks::tracking::motion::Motion;
use skillmimic_sim::{BatchSim, ResetState, Scene};

type Error = Box<dyn std::error::Error>;

fn r(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}

fn positions(b: &impl Bodies, n: usize) -> Vec<Vec<f64>> {
    (0..n).map(|k| b.pos(k).map(r).to_vec()).collect()
}

fn main() -> Result<(), Error> {
    let out = std::env::args().nth(1).ok_or("usage: tracking_sequences OUT_DIR")?;
    let mut c = EnvConfig {
        task: "tracking".into(),
        num_envs: 1,
        threads: 1,
        character: "smpl".into(),
        ..Default::default()
    };
    c.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    let ch = c.resolved_character()?;
    let scene = Arc::new(Scene::new(c.scene_options()?)?);
    let spec = scene.character().clone();
    let motion = Motion::load(&c.motion, ch)?;
    let task = Tracking::new(&c, Motion::load(&c.motion, ch)?, scene.clone())?;
    let (n, nd) = (spec.bodies.len(), spec.num_dofs);
    let mut sim = BatchSim::new(scene.clone(), 1, 1)?;
    let mut state = ResetState::rest(&scene);
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let mut sequences = Vec::new();
    for (k, (strength, len)) in
        [(0.02f32, 25), (0.1, 12), (0.4, 30), (1.0, 18)].into_iter().enumerate()
    {
        let clip = k % motion.len();
        let frames = task.reference(clip).frames;
        let steps = len.min(frames - 2);
        let t0 = rng.random_range(0..frames - steps - 1);
        motion.fill_state(&spec, clip, t0, &mut state);
        sim.reset(&[true], std::slice::from_ref(&state))?;
        let (mut pred, mut gt) = (Vec::new(), Vec::new());
        for step in 1..=steps {
            let a: Vec<f32> = (0..nd).map(|_| strength * rng.random_range(-1.0f32..1.0)).collect();
            sim.step(&a)?;
            pred.push(positions(&sim.state().env(0), n));
            gt.push(positions(&task.reference(clip).frame(t0 + step), n));
        }
        sequences.push(json!({"clip": motion.name(clip), "start_frame": t0, "strength": strength,
            "pred": pred, "gt": gt}));
    }
    let names: Vec<&str> = spec.bodies.iter().map(|b| b.name).collect();
    let doc = json!({"body_names": names, "sequences": sequences});
    std::fs::create_dir_all(&out)?;
    let path = std::path::Path::new(&out).join("metrics_inputs.json");
    std::fs::write(&path, serde_json::to_string(&doc)?)?;
    println!("{}: {} sequences", path.display(), sequences_len(&doc));
    Ok(())
}

fn sequences_len(doc: &serde_json::Value) -> usize {
    doc["sequences"].as_array().map_or(0, Vec::len)
}
