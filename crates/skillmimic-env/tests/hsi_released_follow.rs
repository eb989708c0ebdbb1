//! `hsi_follow` against the released TokenHSI code's own functions: the golden values of
//! `tests/fixtures/tokenhsi_follow_golden.json` (see its note: the released observation, path
//! reward, power penalty, fall and path terminations, time limit, success rule, trajectory
//! interpolation and discriminator features, run on states this project dumped) — every one to
//! 1e-5.

mod common;

use common::{Arrays, TOL, check, fixture, flag, floats};
use skillmimic_env::tasks::hsi::config::{FollowConfig, HsiForm};
use skillmimic_env::tasks::hsi::follow::{Follow, Goal, path_reward};
use skillmimic_env::tasks::hsi::proprio::{PROPRIO_DIM, write_proprio};
use skillmimic_env::tasks::hsi::style::{RELEASED_STYLE_DIM, released_features};
use skillmimic_env::tasks::hsi::{
    Ctx, DT, FallHeights, Rule, TaskOut, fallen, power, time_limit_reached,
};

#[test]
fn follow_matches_the_released_functions() {
    let fx = fixture("tokenhsi_follow_golden.json");
    let p = &fx["params"];
    let cfg = FollowConfig::default();
    // the fixture was made with the released defaults that this project ships
    assert_eq!(p["max_episode_length"].as_u64(), Some(cfg.episode_length as u64));
    assert_eq!(p["traj_sample_timestep"].as_f64(), Some(cfg.point_dt));
    assert_eq!(p["fail_dist"].as_f64(), Some(cfg.fail_distance));
    assert_eq!(p["success_threshold"].as_f64(), Some(cfg.success_distance));
    let defaults = skillmimic_env::tasks::hsi::config::HsiConfig::default();
    assert_eq!(p["power_coefficient"].as_f64(), Some(defaults.power_coefficient));
    assert_eq!(p["termination_height"].as_f64(), Some(defaults.termination_height));
    assert_eq!(p["head_termination_height"].as_f64(), Some(defaults.head_termination_height));
    let heights =
        FallHeights { body: defaults.termination_height, head: defaults.head_termination_height };
    let rule = Follow::new(&cfg, true, HsiForm::Released);
    let trajectories: Vec<Vec<[f64; 2]>> = fx["trajectories"]
        .as_array()
        .expect("trajectories")
        .iter()
        .map(|t| floats(t).chunks(2).map(|v| [v[0], v[1]]).collect())
        .collect();
    let times = floats(&p["calc_pos_times"]);
    let states = fx["states"].as_array().expect("states");
    let mut worst = 0.0f64;
    let mut branches = [0usize; 5]; // falls, path failures, grace steps, successes, time limits
    for (i, s) in states.iter().enumerate() {
        let arrays = Arrays::of(s);
        let st = arrays.state();
        let e = &s["expected"];
        let steps = s["progress"].as_u64().expect("progress") as usize;
        let traj = s["traj"].as_u64().expect("traj") as usize;
        let mut goal = Goal::with_vertices(trajectories[traj].clone(), &cfg);

        // proprioception: the released 223 columns are a zero root height then our 222
        let released = floats(&e["humanoid_obs"]);
        assert_eq!(released[0], 0.0);
        let mut obs = vec![0.0f32; PROPRIO_DIM];
        write_proprio(&st, &mut obs);
        let obs: Vec<f64> = obs.iter().map(|&x| f64::from(x)).collect();
        // our observation is float32: compare at float32 resolution of its magnitude
        for (k, (a, b)) in obs.iter().zip(&released[1..]).enumerate() {
            let tol = TOL.max(2e-7 * b.abs());
            assert!((a - b).abs() <= tol, "proprio[{k}] state {i}: {a} vs {b}");
        }
        let mut task = vec![0.0f32; 20];
        rule.observe(&goal, &st, steps, &mut task);
        let task: Vec<f64> = task.iter().map(|&x| f64::from(x)).collect();
        for (k, (a, b)) in task.iter().zip(floats(&e["task_obs"])).enumerate() {
            let tol = TOL.max(2e-7 * b.abs());
            assert!((a - b).abs() <= tol, "task_obs[{k}] state {i}: {a} vs {b}");
        }

        let root = st.pos(0);
        let reward = path_reward(root, goal.at(steps as f64 * DT));
        check("traj_reward", i, &[reward], &floats(&e["traj_reward"]), &mut worst);
        let penalty = -defaults.power_coefficient * power(&st);
        check("power_reward", i, &[penalty], &floats(&e["power_reward"]), &mut worst);
        check("reward", i, &[reward + penalty], &floats(&e["reward"]), &mut worst);

        // the rule's own step: reward term, path failure, success
        let fell = fallen(&st, steps, heights);
        let ctx = Ctx {
            st: &st,
            prev_root: root,
            prev_root_quat: st.quat(0),
            prev_obj: [0.0; 3],
            steps,
            fallen: fell,
        };
        let (mut terms, mut metrics) = ([0.0f32; 1], [0.0f32; 2]);
        let mut out =
            TaskOut { terms: &mut terms, metrics: &mut metrics, fail: false, finish: false };
        rule.step(&mut goal, &ctx, &mut out);
        let fail = out.fail;
        assert!((f64::from(terms[0]) - reward).abs() < 1e-6, "the rule's term is Eq. 1");
        assert_eq!(fell, flag(&e["terminated_base"]), "fall rule, state {i}");
        assert_eq!(fell || fail, flag(&e["terminated"]), "termination, state {i}");
        let reset = fell || fail || time_limit_reached(steps, cfg.episode_length);
        assert_eq!(reset, flag(&e["reset"]), "reset, state {i}");
        assert_eq!(metrics[1] == 1.0, flag(&e["success_step"]), "success, state {i}");
        branches[0] += usize::from(fell);
        branches[1] += usize::from(fail && !fell);
        branches[2] += usize::from(steps == 1);
        branches[3] += usize::from(metrics[1] == 1.0);
        branches[4] += usize::from(reset && !fell && !fail);

        // the released discriminator features (ASE's build_amp_observations)
        let mut amp = vec![0.0f32; RELEASED_STYLE_DIM];
        released_features(&st, &mut amp);
        for (k, (a, b)) in amp.iter().zip(floats(&e["amp_obs"])).enumerate() {
            let (a, tol) = (f64::from(*a), TOL.max(2e-7 * b.abs()));
            assert!((a - b).abs() <= tol, "amp_obs[{k}] state {i}: {a} vs {b}");
        }

        if let Some(expected) = e.get("calc_pos") {
            let ours: Vec<f64> = times
                .iter()
                .flat_map(|&t| {
                    let p = goal.at(t);
                    [p[0], p[1], 0.0]
                })
                .collect();
            check("calc_pos", i, &ours, &floats(expected), &mut worst);
        }
    }
    println!(
        "{} states; falls {}, path failures {}, grace steps {}, successes {}, time limits {}; \
         largest |ours - released| of the float64 values {worst:.2e}",
        states.len(),
        branches[0],
        branches[1],
        branches[2],
        branches[3],
        branches[4]
    );
    assert!(branches.iter().all(|&n| n > 0), "every branch is reached: {branches:?}");
}
