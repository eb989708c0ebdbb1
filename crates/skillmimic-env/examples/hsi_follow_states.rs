//! Dump states of the TokenHSI character under `hsi_follow` for golden fixtures: the inputs of
//! `tests/fixtures/tokenhsi_follow_golden.json` (see its note), which the released TokenHSI
//! functions are then run on outside this repository.
//!
//! `cargo run --release -p skillmimic-env --example hsi_follow_states -- OUT.json`
//!
//! States (body poses and velocities, contact forces, joint positions, rates and drive torques,
//! the episode's trajectory and step count) come from rollouts of the simulated character with
//! random actions — gentle ones (standing, walking off) and strong ones (falls) — plus staged
//! variants (of envs 0, 1, 4 and 5 after 5 steps, standing, and after 80, mostly fallen) that reach
//! every branch of the reward, termination and success rules: the path
//! moved 4.2 m away (path failure), the step count set to 1 (the fall rule's grace step), 293,
//! 294 and 299 (success window and time limit) with the trajectory moved so that its point at
//! 9.8 s lies 0.1 m or 0.4 m from the root.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use skillmimic_core::characters::tokenhsi::{self, NUM_BODIES, NUM_DOFS};
use skillmimic_env::tasks::hsi::config::{FollowConfig, HsiForm};
use skillmimic_env::tasks::hsi::follow::{Follow, Goal, draw_trajectory};
use skillmimic_env::tasks::hsi::{DT, Rule};
use skillmimic_sim::{BatchSim, EnvState, ResetState, Scene, SceneOptions};

/// `x` to 9 significant digits: the fixture's inputs are these decimals, read alike by the
/// released code and by the tests.
fn r(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}

fn rs(v: &[f64]) -> Vec<f64> {
    v.iter().copied().map(r).collect()
}

fn state_json(st: &EnvState<'_>, goal: &Goal, steps: usize) -> Value {
    let b = NUM_BODIES;
    let rows = |v: &[f64], w: usize| -> Vec<Vec<f64>> { v[..b * w].chunks(w).map(rs).collect() };
    // released quaternions are x, y, z, w
    let xyzw: Vec<Vec<f64>> =
        st.body_quat[..4 * b].chunks(4).map(|q| rs(&[q[1], q[2], q[3], q[0]])).collect();
    json!({
        "body_pos": rows(st.body_pos, 3),
        "body_rot": xyzw,
        "body_vel": rows(st.body_linvel, 3),
        "body_ang_vel": rows(st.body_angvel, 3),
        "contact_force": rows(st.contact_force, 3),
        "dof_pos": rs(&st.dof_pos[..NUM_DOFS]),
        "dof_vel": rs(&st.dof_vel[..NUM_DOFS]),
        "dof_force": rs(&st.dof_force[..NUM_DOFS]),
        "progress": steps,
        "traj_verts": goal.verts.iter().map(|v| vec![r(v[0]), r(v[1]), 0.0]).collect::<Vec<_>>(),
    })
}

/// The trajectory translated so that its point at time `t` is `p` (world x, y).
fn moved_to(goal: &Goal, t: f64, p: [f64; 2]) -> Goal {
    let at = goal.at(t);
    let mut g = goal.clone();
    for v in &mut g.verts {
        *v = [v[0] + p[0] - at[0], v[1] + p[1] - at[1]];
    }
    g
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).ok_or("usage: hsi_follow_states OUT.json")?;
    let cfg = FollowConfig::default();
    let rule = Follow::new(&cfg, true, HsiForm::Released);
    let scene = Arc::new(Scene::new(SceneOptions::bare(tokenhsi::CHARACTER))?);
    // envs 0-3 gentle actions, 4-7 strong ones
    let n = 8;
    let mut sim = BatchSim::new(scene.clone(), n, 1)?;
    let mut rng = ChaCha8Rng::seed_from_u64(38);
    let mut goals = vec![Goal::default(); n];
    let mut resets = vec![ResetState::rest(&scene); n];
    for (g, r) in goals.iter_mut().zip(&mut resets) {
        rule.plan(&scene, &mut rng, r, g);
    }
    sim.reset(&vec![true; n], &resets)?;
    let mut states = Vec::new();
    let mut actions = vec![0.0f32; n * NUM_DOFS];
    let dump_at = [1usize, 5, 45, 80];
    for step in 1..=80 {
        for (i, a) in actions.iter_mut().enumerate() {
            let amplitude = if i / NUM_DOFS < 4 { 0.15 } else { 0.9 };
            *a = amplitude * rng.random_range(-1.0f32..1.0);
        }
        sim.step(&actions)?;
        if !dump_at.contains(&step) {
            continue;
        }
        for (i, goal) in goals.iter().enumerate() {
            let st = sim.state().env(i);
            states.push(state_json(&st, goal, step));
            if (step == 5 || step == 80) && i % 4 < 2 {
                let root = st.pos(0);
                // staged: path failure, the fall rule's grace step, the success window and the
                // time limit
                let mut far = goal.clone();
                far.verts.iter_mut().for_each(|v| v[0] += 4.2);
                states.push(state_json(&st, &far, step));
                states.push(state_json(&st, goal, 1));
                let end = cfg.success_time * cfg.episode_length as f64 * DT;
                for (steps, off) in [(293, 0.1), (294, 0.1), (294, 0.4), (297, 0.25), (299, 0.1)] {
                    let a = 0.7 * i as f64;
                    let p = [root[0] + off * f64::cos(a), root[1] + off * f64::sin(a)];
                    states.push(state_json(&st, &moved_to(goal, end, p), steps));
                }
            }
        }
    }
    // a trajectory of the generator itself, for calc_pos at times before, inside and after it
    let mut g = Goal::default();
    draw_trajectory(&cfg, [0.3, -0.2], &mut rng, &mut g);
    let times: Vec<f64> =
        [-0.5, 0.0, 0.05, 0.1, 1.234, 4.95, 9.8, 9.99, 10.0, 10.05, 10.1, 12.0].to_vec();
    let doc = json!({
        "dt": DT,
        "max_episode_length": cfg.episode_length,
        "num_traj_samples": 10,
        "traj_sample_timestep": cfg.point_dt,
        "fail_dist": cfg.fail_distance,
        "termination_height": 0.15,
        "head_termination_height": 0.3,
        "head_body": 2,
        "contact_body_ids": tokenhsi::CONTACT_BODIES,
        "key_body_ids": tokenhsi::KEY_BODIES,
        "power_coefficient": 0.0005,
        "success_threshold": cfg.success_distance,
        "dof_offsets": [0, 3, 6, 9, 10, 13, 14, 17, 20, 23, 26, 29, 32],
        "dof_obs_size": 72,
        "calc_pos_times": times,
        "generator_verts": g.verts.iter().map(|v| vec![r(v[0]), r(v[1]), 0.0]).collect::<Vec<_>>(),
        "states": states,
    });
    std::fs::write(&out, serde_json::to_string(&doc)?)?;
    println!("{} states -> {out}", doc["states"].as_array().map_or(0, Vec::len));
    Ok(())
}
