//! Dump states of the SMPL humanoid under `tracking` for golden fixtures: the inputs of
//! `tests/fixtures/modskill_tracking_golden.json` (see its note), which the released ModSkill
//! functions are then run on outside this repository.
//!
//! `cargo run --release -p skillmimic-env --example tracking_states -- OUT_DIR`
//! writes `OUT_DIR/tracking_inputs.json`; with `-- OUT_DIR sequences` it writes
//! `OUT_DIR/metrics_inputs.json` instead, the inputs of `tests/fixtures/phc_metrics_golden.json`
//! (see [`sequences`]); with `-- OUT_DIR prior`, `OUT_DIR/prior_inputs.json`, the inputs of
//! `tests/fixtures/modskill_prior_golden.json` (see [`prior_states`]).
//!
//! Each state is one step of a rollout of the SMPL humanoid started in a reference state of a
//! shipped demo clip (retargeted to SMPL by joint name) and driven by random PD targets: gentle
//! ones (the body follows the reference for a while) and strong ones (it drifts past the 0.25 m
//! and 0.5 m distances and falls), at steps 1 to 40 after the reset, so that the reward's range,
//! the power penalty's first-3-steps rule, the termination grace of the first step and both
//! distance thresholds are all reached; the drifted state at step 20 of each strong rollout is
//! also written staged as step 1 and step 3 (`case` = "staged"). Written per state: the simulated bodies (positions,
//! x y z w quaternions, centre-of-mass velocities, angular velocities; world frame, m, m/s,
//! rad/s), the reference bodies of the compared frame and of the next frame (the observation's),
//! the read-out's drive forces and joint rates (N·m, rad/s), the step count since the reset, and
//! this project's values (reward terms, termination, observation) for the record. Values to 9
//! significant digits.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use skillmimic_core::math::Quat;
use skillmimic_env::EnvConfig;
use skillmimic_env::tasks::tracking::Tracking;
use skillmimic_env::tasks::tracking::config::TrackingConfig;
use skillmimic_env::tasks::tracking::formulas::{self, Bodies};
use skillmimic_env::tasks::tracking::motion::Motion;
use skillmimic_sim::{BatchSim, ResetState, Scene};

type Error = Box<dyn std::error::Error>;

fn r(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}

/// Positions, x y z w quaternions, linear and angular velocities of `n` bodies.
fn bodies(b: &impl Bodies, n: usize) -> Value {
    let (mut p, mut q, mut v, mut w) = (vec![], vec![], vec![], vec![]);
    for k in 0..n {
        p.push(b.pos(k).map(r).to_vec());
        let qq: Quat = b.quat(k);
        q.push(vec![r(qq.x), r(qq.y), r(qq.z), r(qq.w)]);
        v.push(b.linvel(k).map(r).to_vec());
        w.push(b.angvel(k).map(r).to_vec());
    }
    json!({"pos": p, "rot": q, "vel": v, "ang_vel": w})
}

/// The tracking task on the SMPL humanoid over the shipped demo clips (retargeted by joint name).
fn smpl_tracking() -> Result<EnvConfig, Error> {
    let mut c = EnvConfig {
        task: "tracking".into(),
        num_envs: 1,
        threads: 1,
        character: "smpl".into(),
        ..Default::default()
    };
    c.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    Ok(c)
}

fn main() -> Result<(), Error> {
    let mut args = std::env::args().skip(1);
    let out = args.next().ok_or("usage: tracking_states OUT_DIR [sequences]")?;
    match args.next().as_deref() {
        Some("sequences") => return sequences(&out),
        Some("prior") => return prior_states(&out),
        _ => {}
    }
    let c = smpl_tracking()?;
    let t = c.table::<TrackingConfig>().clone();
    let ch = skillmimic_env::registry::character(&c)?;
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c)?)?);
    let spec = scene.character().clone();
    let task = Tracking::new(&c, Motion::load(&c.motion, ch)?, scene.clone())?;
    let motion = Motion::load(&c.motion, ch)?;
    let n = spec.bodies.len();
    let nd = spec.num_dofs;
    let mut sim = BatchSim::new(scene.clone(), 1, 1)?;
    let mut state = ResetState::rest(&scene);
    let mut rng = ChaCha8Rng::seed_from_u64(39);
    let mut states = Vec::new();
    let judged = formulas::termination_bodies(&spec, task.tracked_bodies(), &t)?;
    // (strength of the random targets, steps): gentle rollouts follow the clip for a while,
    // strong ones cross both distances
    for (k, strength) in [0.05, 0.2, 0.6, 1.0].into_iter().cycle().take(8).enumerate() {
        let clip = k % motion.len();
        let frames = task.reference(clip).frames;
        let steps = 40.min(frames - 2);
        let t0 = rng.random_range(0..frames - steps - 1);
        motion.fill_state(&spec, clip, t0, &mut state);
        sim.reset(&[true], std::slice::from_ref(&state))?;
        for step in 1..=steps {
            let a: Vec<f32> = (0..nd).map(|_| strength * rng.random_range(-1.0f32..1.0)).collect();
            sim.step(&a)?;
            let st = sim.state().env(0);
            let (refs, frame) = (task.reference(clip), t0 + step);
            let (now, next) = (refs.frame(frame), refs.frame(frame + 1));
            // the first rollouts at their first steps (the grace and power rules) and a few
            // later ones; the others later on (the drift past both distances)
            let kept = match k < 2 {
                true => [1, 2, 3, 4, 12, 24, 36].contains(&step),
                false => [8, 20, 32, 40].contains(&step),
            };
            if !kept {
                continue;
            }
            // the observations of a subset (they are most of a state's size)
            let observed = [1, 4, 20, 36].contains(&step);
            // a drifted state also staged as the first and the third step after a reset (the
            // termination grace and the power penalty's free steps)
            let staged: &[usize] = if k >= 2 && step == 20 { &[1, 3] } else { &[] };
            for (case, progress) in
                std::iter::once(("rollout", step)).chain(staged.iter().map(|&p| ("staged", p)))
            {
                let e = formulas::errors(&st, &now, task.tracked_bodies());
                let power =
                    if formulas::power_counts(progress, &t) { st.drive_power() } else { 0.0 };
                let terms = formulas::reward(&e, power, &t);
                let dist = formulas::mean_distance(&st, &now, &judged);
                let mut ours = json!({
                    "terms": terms.map(r).to_vec(),
                    "judged_distance": r(dist),
                    "terminated": formulas::terminates(dist, progress, &t),
                });
                let observed = observed && case == "rollout";
                if observed {
                    let mut reference = vec![0f32; formulas::REF_WIDTH * n];
                    formulas::write_reference_obs(
                        &st,
                        &next,
                        task.tracked_bodies(),
                        &mut reference,
                    );
                    let mut proprio = vec![0f32; spec.proprio_dim()];
                    skillmimic_env::proprio::write_for(&spec, &st, &mut proprio);
                    ours["self_obs"] = proprio.iter().map(|&x| r(x as f64)).collect();
                    ours["task_obs"] = reference.iter().map(|&x| r(x as f64)).collect();
                }
                states.push(json!({
                    "rollout": k,
                    "case": case,
                    "strength": strength,
                    "progress": progress,
                    "sim": bodies(&st, n),
                    "ref": bodies(&now, n),
                    "next_ref": bodies(&next, n),
                    "dof_force": st.dof_force.iter().map(|&x| r(x)).collect::<Vec<_>>(),
                    "dof_vel": st.dof_vel.iter().map(|&x| r(x)).collect::<Vec<_>>(),
                    "observed": observed,
                    "ours": ours,
                }));
            }
        }
    }
    let names: Vec<&str> = spec.bodies.iter().map(|b| b.name).collect();
    let doc = json!({
        "body_names": names,
        "termination_body_ids": judged,
        "params": {
            "termination_distance": t.termination_distance,
            "success_distance": t.success_distance,
            "power_coefficient": t.power_coef,
            "w": t.weights, "k": t.scales,
        },
        "states": states,
    });
    std::fs::create_dir_all(&out)?;
    let path = std::path::Path::new(&out).join("tracking_inputs.json");
    std::fs::write(&path, serde_json::to_string(&doc)?)?;
    println!("{}: {} states", path.display(), doc["states"].as_array().map_or(0, Vec::len));
    Ok(())
}

/// The inputs of the metrics fixture: four rollouts of the SMPL humanoid, each started in a
/// reference state of a demo clip and driven by random PD targets of one strength (gentle to
/// strong, so that the errors range from millimetres to metres), of different lengths. Per policy
/// step: the simulated body positions after the step (`pred`) and the compared reference frame's
/// (`gt`), world frame, m, the character's body order; values to 9 significant digits.
fn sequences(out: &str) -> Result<(), Error> {
    let c = smpl_tracking()?;
    let ch = skillmimic_env::registry::character(&c)?;
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c)?)?);
    let spec = scene.character().clone();
    let motion = Motion::load(&c.motion, ch)?;
    let task = Tracking::new(&c, Motion::load(&c.motion, ch)?, scene.clone())?;
    let (n, nd) = (spec.bodies.len(), spec.num_dofs);
    let mut sim = BatchSim::new(scene.clone(), 1, 1)?;
    let mut state = ResetState::rest(&scene);
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let positions = |b: &dyn Fn(usize) -> [f64; 3]| -> Vec<Vec<f64>> {
        (0..n).map(|k| b(k).map(r).to_vec()).collect()
    };
    let mut seqs = Vec::new();
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
            let st = sim.state().env(0);
            pred.push(positions(&|b| st.pos(b)));
            let refs = task.reference(clip);
            let now = refs.frame(t0 + step);
            gt.push(positions(&|b| now.pos(b)));
        }
        seqs.push(json!({"clip": motion.name(clip), "start_frame": t0, "strength": strength,
            "pred": pred, "gt": gt}));
    }
    let names: Vec<&str> = spec.bodies.iter().map(|b| b.name).collect();
    let count = seqs.len();
    let doc = json!({"body_names": names, "sequences": seqs});
    std::fs::create_dir_all(out)?;
    let path = std::path::Path::new(out).join("metrics_inputs.json");
    std::fs::write(&path, serde_json::to_string(&doc)?)?;
    println!("{}: {count} sequences", path.display());
    Ok(())
}

/// The inputs of the motion-prior fixture: states of SMPL rollouts (as [`sequences`]: demo-clip
/// starts, random PD targets of four strengths, steps 1, 5, 10, 20 after the reset) with the
/// dof angles and rates (rad, rad/s, the humanoid's hinge order) and this project's features
/// (`skillmimic_env::tasks::tracking::prior`) for the record.
fn prior_states(out: &str) -> Result<(), Error> {
    use skillmimic_env::tasks::tracking::prior::{SMPL_PRIOR_DIM, smpl_features};
    let c = smpl_tracking()?;
    let ch = skillmimic_env::registry::character(&c)?;
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c)?)?);
    let spec = scene.character().clone();
    let motion = Motion::load(&c.motion, ch)?;
    let (n, nd) = (spec.bodies.len(), spec.num_dofs);
    let mut sim = BatchSim::new(scene.clone(), 1, 1)?;
    let mut state = ResetState::rest(&scene);
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let mut states = Vec::new();
    for (k, strength) in [0.02f32, 0.1, 0.4, 1.0].into_iter().enumerate() {
        let clip = k % motion.len();
        let frames = motion.frames(clip);
        let t0 = rng.random_range(0..frames - 22);
        motion.fill_state(&spec, clip, t0, &mut state);
        sim.reset(&[true], std::slice::from_ref(&state))?;
        for step in 1..=20 {
            let a: Vec<f32> = (0..nd).map(|_| strength * rng.random_range(-1.0f32..1.0)).collect();
            sim.step(&a)?;
            if ![1, 5, 10, 20].contains(&step) {
                continue;
            }
            let st = sim.state().env(0);
            let mut f = vec![0f32; SMPL_PRIOR_DIM];
            smpl_features(&st, &mut f);
            states.push(json!({
                "strength": strength,
                "step": step,
                "bodies": bodies(&st, n),
                "dof_pos": st.dof_pos.iter().map(|&x| r(x)).collect::<Vec<_>>(),
                "dof_vel": st.dof_vel.iter().map(|&x| r(x)).collect::<Vec<_>>(),
                "ours": f.iter().map(|&x| r(x as f64)).collect::<Vec<_>>(),
            }));
        }
    }
    let names: Vec<&str> = spec.bodies.iter().map(|b| b.name).collect();
    let doc = json!({"body_names": names, "states": states});
    std::fs::create_dir_all(out)?;
    let path = std::path::Path::new(out).join("prior_inputs.json");
    std::fs::write(&path, serde_json::to_string(&doc)?)?;
    println!("{}: {} states", path.display(), doc["states"].as_array().map_or(0, Vec::len));
    Ok(())
}
