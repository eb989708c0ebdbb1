//! `tracking` on the SMPL humanoid against the released ModSkill code's own functions: the golden
//! values of `tests/fixtures/modskill_tracking_golden.json` (see its note: the released reward
//! with its power penalty and first-steps rule, the reset rule over the released reset bodies at
//! the training and evaluation distances, the self observation and the v6 reference observation,
//! run on states this project dumped) — every one to 1e-5; and the motion prior's SMPL features
//! against the released `build_amp_observations_smpl` (`tests/fixtures/modskill_prior_golden.json`).

mod common;

use common::{TOL, check, check_f32, fixture, floats};
use serde_json::Value;
use skillmimic_core::math::Quat;
use skillmimic_env::tasks::tracking::config::{ErrorMean, TrackingConfig};
use skillmimic_env::tasks::tracking::formulas::{self, Bodies};
use skillmimic_sim::EnvState;

/// Body states of a fixture entry (`pos`, `rot` x y z w, `vel`, `ang_vel`), world frame.
struct Frame {
    pos: Vec<f64>,
    quat: Vec<f64>,
    vel: Vec<f64>,
    angvel: Vec<f64>,
}

impl Frame {
    fn of(v: &Value) -> Self {
        let xyzw = floats(&v["rot"]);
        Self {
            pos: floats(&v["pos"]),
            quat: common::wxyz(&xyzw),
            vel: floats(&v["vel"]),
            angvel: floats(&v["ang_vel"]),
        }
    }
}

fn at3(v: &[f64], b: usize) -> [f64; 3] {
    [v[3 * b], v[3 * b + 1], v[3 * b + 2]]
}

impl Bodies for Frame {
    fn pos(&self, b: usize) -> [f64; 3] {
        at3(&self.pos, b)
    }
    fn quat(&self, b: usize) -> Quat {
        Quat::from_wxyz([
            self.quat[4 * b],
            self.quat[4 * b + 1],
            self.quat[4 * b + 2],
            self.quat[4 * b + 3],
        ])
    }
    fn linvel(&self, b: usize) -> [f64; 3] {
        at3(&self.vel, b)
    }
    fn angvel(&self, b: usize) -> [f64; 3] {
        at3(&self.angvel, b)
    }
}

fn smpl() -> skillmimic_core::characters::CharacterSpec {
    skillmimic_core::characters::smpl::spec()
}

/// This project's proprioception in the released body-major order: the root height, then each
/// body's own columns ([`skillmimic_env::proprio::body_columns`]: position (not the root's),
/// rotation, velocity, angular velocity) — the comparison below checks that map too.
fn body_major(p: &[f32], spec: &skillmimic_core::characters::CharacterSpec) -> Vec<f32> {
    let n = spec.bodies.len();
    let cols = (0..n).flat_map(|b| skillmimic_env::proprio::body_columns(&spec.proprio, n, b));
    std::iter::once(p[0]).chain(cols.map(|c| p[c])).collect()
}

#[test]
fn tracking_matches_the_released_modskill_functions() {
    let fx = fixture("modskill_tracking_golden.json");
    let spec = smpl();
    let n = spec.bodies.len();
    let names: Vec<&str> = spec.bodies.iter().map(|b| b.name).collect();
    let fx_names: Vec<&str> =
        fx["body_names"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(names, fx_names, "the SMPL body order");
    let cfg = TrackingConfig::default();
    let p = &fx["params"];
    assert_eq!(p["termination_distance"].as_f64(), Some(cfg.termination_distance));
    assert_eq!(p["power_coefficient"].as_f64(), Some(cfg.power_coef));
    assert_eq!(floats(&p["w"]), cfg.weights.to_vec());
    assert_eq!(floats(&p["k"]), cfg.scales.to_vec());
    assert_eq!(cfg.error_mean, ErrorMean::Components);
    // the termination bodies are the released reset bodies
    let tracked = formulas::tracked_bodies(&spec, false);
    assert_eq!(tracked.len(), 24);
    let judged = formulas::termination_bodies(&spec, &tracked, &cfg).unwrap();
    let released: Vec<usize> = fx["released_reset_bodies"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| names.iter().position(|&m| m == v.as_str().unwrap()).unwrap())
        .collect();
    assert_eq!(judged, released);
    let eval = TrackingConfig { termination_distance: cfg.success_distance, ..cfg.clone() };
    let (mut worst, mut ends, mut ends_eval, mut free, mut observed) = (0.0f64, 0, 0, 0, 0);
    let states = fx["states"].as_array().unwrap();
    for (i, s) in states.iter().enumerate() {
        let (sim, now) = (Frame::of(&s["sim"]), Frame::of(&s["ref"]));
        let (force, vel) = (floats(&s["dof_force"]), floats(&s["dof_vel"]));
        let zeros = vec![0.0; 3 * n];
        let st = EnvState {
            body_pos: &sim.pos,
            body_quat: &sim.quat,
            body_linvel: &sim.vel,
            body_angvel: &sim.angvel,
            dof_pos: &force,
            dof_vel: &vel,
            dof_force: &force,
            contact_force: &zeros,
            contact_pairs: &[0; 8],
            touch: &vec![0; n + 1],
            unstable: false,
        };
        let steps = s["progress"].as_u64().unwrap() as usize;
        let e = &s["expected"];
        // reward: the released raw terms are the unweighted exponentials, then the power term
        let err = formulas::errors(&st, &now, &tracked);
        let power = if formulas::power_counts(steps, &cfg) { st.drive_power() } else { 0.0 };
        free += usize::from(!formulas::power_counts(steps, &cfg));
        let t = formulas::reward(&err, power, &cfg);
        let raw: Vec<f64> = (0..4).map(|k| t[k] / cfg.weights[k]).chain([t[4]]).collect();
        check("reward_raw", i, &raw, &floats(&e["reward_raw"]), &mut worst);
        check("reward", i, &[t[5]], &floats(&e["reward"]), &mut worst);
        // termination over the released reset bodies, at the training and evaluation distances
        let dist = formulas::mean_distance(&st, &now, &judged);
        let want = e["terminated"].as_u64().unwrap() == 1;
        assert_eq!(formulas::terminates(dist, steps, &cfg), want, "state {i}: terminated");
        assert_eq!(e["reset"].as_u64().unwrap() == 1, want, "state {i}: reset");
        let want_eval = e["terminated_eval"].as_u64().unwrap() == 1;
        assert_eq!(formulas::terminates(dist, steps, &eval), want_eval, "state {i}: at 0.5 m");
        ends += usize::from(want);
        ends_eval += usize::from(want_eval);
        // observations: the self part (permuted to the released order) and the reference block
        if e.get("self_obs").is_none() {
            continue;
        }
        observed += 1;
        let next = Frame::of(&s["next_ref"]);
        let mut proprio = vec![0f32; spec.proprio_dim()];
        skillmimic_env::proprio::write_for(&spec, &st, &mut proprio);
        check_f32("self_obs", i, &body_major(&proprio, &spec), &floats(&e["self_obs"]));
        let mut task = vec![0f32; formulas::REF_WIDTH * n];
        formulas::write_reference_obs(&st, &next, &tracked, &mut task);
        check_f32("task_obs", i, &task, &floats(&e["task_obs"]));
    }
    println!(
        "{} states: largest reward difference {worst:.1e}; {ends} terminated at 0.25 m, \
            {ends_eval} at 0.5 m; {free} within the power penalty's first 3 steps; {observed} \
            observations",
        states.len()
    );
    assert!(observed >= 8);
    assert!(worst <= TOL);
    // the fixture reaches every branch: both outcomes at both distances, the grace step, the
    // power penalty's free and counted steps
    assert!(ends > 0 && ends < states.len() && ends_eval > 0 && ends_eval < ends);
    assert!(free > 0 && free < states.len());
    // a state beyond both distances at the first step after a reset is not terminated
    let graced = states
        .iter()
        .filter(|s| s["progress"] == 1 && s["expected"]["terminated"] == 0)
        .filter(|s| {
            let (sim, now) = (Frame::of(&s["sim"]), Frame::of(&s["ref"]));
            formulas::mean_distance(&sim, &now, &judged) > cfg.success_distance
        })
        .count();
    assert!(graced > 0, "no state tests the grace of the first step");
}

#[test]
fn smpl_prior_features_match_the_released_build_amp_observations_smpl() {
    use skillmimic_env::tasks::tracking::prior::{SMPL_PRIOR_DIM, smpl_features};
    let fx = fixture("modskill_prior_golden.json");
    let spec = smpl();
    let n = spec.bodies.len();
    let fx_names: Vec<&str> =
        fx["body_names"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(spec.bodies.iter().map(|b| b.name).collect::<Vec<_>>(), fx_names);
    // the features read body b's hinges at 3 (b − 1)
    assert!((1..n).all(|b| spec.bodies[b].dofs.start == 3 * (b - 1)));
    let states = fx["states"].as_array().unwrap();
    let mut worst = 0.0f64;
    for (i, s) in states.iter().enumerate() {
        let b = Frame::of(&s["bodies"]);
        let (dof_pos, dof_vel) = (floats(&s["dof_pos"]), floats(&s["dof_vel"]));
        let zeros = vec![0.0; 3 * n];
        let st = EnvState {
            body_pos: &b.pos,
            body_quat: &b.quat,
            body_linvel: &b.vel,
            body_angvel: &b.angvel,
            dof_pos: &dof_pos,
            dof_vel: &dof_vel,
            dof_force: &zeros,
            contact_force: &zeros,
            contact_pairs: &[0; 8],
            touch: &vec![0; n + 1],
            unstable: false,
        };
        let mut ours = vec![0f32; SMPL_PRIOR_DIM];
        smpl_features(&st, &mut ours);
        let theirs = floats(&s["released"]);
        common::check_f32("prior features", i, &ours, &theirs);
        for (a, t) in ours.iter().zip(&theirs) {
            worst = worst.max((f64::from(*a) - t).abs());
        }
    }
    println!(
        "{} states × {SMPL_PRIOR_DIM} prior features within {worst:.1e} of the released function",
        states.len()
    );
}
