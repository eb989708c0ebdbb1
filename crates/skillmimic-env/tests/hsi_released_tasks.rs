//! `hsi_sit`, `hsi_climb` and `hsi_carry` against the released TokenHSI code's own functions: the
//! golden values of `tests/fixtures/tokenhsi_{sit,climb,carry}_golden.json` (see their notes: the
//! released task observations, bounding-box points, rewards and their penalties, power penalty,
//! interaction early termination, fall rules, time limit and success, run on states this project
//! dumped) — every one to 1e-5; and the carry task's box sizes and height regulation.

mod common;

use common::{Arrays, TOL, check, check_f32, fixture, flag, floats, vec3};
use serde_json::Value;
use skillmimic_core::math::{Quat, sub};
use skillmimic_env::tasks::hsi::carry::{self, Carry, draw_box, regulate_height};
use skillmimic_env::tasks::hsi::climb::{Climb, gate_radius};
use skillmimic_env::tasks::hsi::config::{HsiConfig, HsiForm};
use skillmimic_env::tasks::hsi::geometry::corners;
use skillmimic_env::tasks::hsi::sit::{self, Sit};
use skillmimic_env::tasks::hsi::{
    Ctx, FallHeights, FallRule, Rule, TaskOut, power, time_limit_reached,
};
use skillmimic_sim::EnvState;

fn heights(h: &HsiConfig) -> FallHeights {
    FallHeights { body: h.termination_height, head: h.head_termination_height }
}

/// The fixture's shared parameters are the defaults this project ships.
fn check_params(p: &Value, h: &HsiConfig, episode_length: usize) {
    assert_eq!(p["max_episode_length"].as_u64(), Some(episode_length as u64));
    assert_eq!(p["power_coefficient"].as_f64(), Some(h.power_coefficient));
    assert_eq!(p["termination_height"].as_f64(), Some(h.termination_height));
    assert_eq!(p["head_termination_height"].as_f64(), Some(h.head_termination_height));
}

/// The sit / climb goal of a fixture state (`goal`: this project's object frame; `iet_steps`).
fn target_goal(s: &Value) -> sit::Goal {
    let g = &s["goal"];
    let q = floats(&g["obj_quat"]);
    sit::Goal {
        target: vec3(&g["target"]),
        obj_pos: vec3(&g["obj_pos"]),
        obj_quat: Quat::from_wxyz([q[0], q[1], q[2], q[3]]),
        lo: vec3(&g["lo"]),
        hi: vec3(&g["hi"]),
        near_steps: s["iet_steps"].as_u64().expect("iet_steps") as usize,
        reached: false,
        gate: 0.0,
    }
}

/// One step of `rule` on a fixture state: the terms, metrics and ends, and the fall.
struct Stepped {
    terms: Vec<f64>,
    metrics: [f32; 2],
    finish: bool,
    fail: bool,
    fallen: bool,
}

fn step<R: Rule>(
    rule: &R,
    goal: &mut R::Goal,
    st: &EnvState<'_>,
    s: &Value,
    prev_obj: [f64; 3],
    h: FallHeights,
) -> Stepped {
    let steps = s["progress"].as_u64().expect("progress") as usize;
    let fallen = rule.fall_rule().fallen(st, steps, h);
    let q = floats(&s["prev_root_rot"]);
    let ctx = Ctx {
        st,
        prev_root: vec3(&s["prev_root_pos"]),
        prev_root_quat: Quat::from_xyzw([q[0], q[1], q[2], q[3]]),
        prev_obj,
        steps,
        fallen,
    };
    let mut terms = vec![0.0f32; rule.spec().term_names.len()];
    let mut metrics = [0.0f32; 2];
    let mut out = TaskOut { terms: &mut terms, metrics: &mut metrics, fail: false, finish: false };
    rule.step(goal, &ctx, &mut out);
    let (finish, fail) = (out.finish, out.fail);
    Stepped { terms: terms.iter().map(|&x| f64::from(x)).collect(), metrics, finish, fail, fallen }
}

/// Compare a float32 reward term with a float64 released value.
fn check_term(what: &str, i: usize, ours: f64, theirs: &Value, worst: &mut f64) {
    let b = floats(theirs)[0];
    let tol = TOL.max(2e-7 * b.abs());
    assert!((ours - b).abs() <= tol, "{what} of state {i} ({ours} vs released {b})");
    *worst = worst.max((ours - b).abs());
}

/// Sit and climb: everything but the reward terms, which the callers check.
#[allow(clippy::too_many_arguments)]
fn check_target_task<R: Rule<Goal = sit::Goal>>(
    name: &str,
    rule: &R,
    fx: &Value,
    h: &HsiConfig,
    episode_length: usize,
    eval_from: usize,
    mut extra: impl FnMut(usize, &Value, &sit::Goal, &Stepped, &EnvState<'_>, &mut f64),
) -> [usize; 6] {
    let chars = fx["characters"].as_array().expect("characters");
    let states = fx["states"].as_array().expect("states");
    let mut worst = 0.0f64;
    // falls, IET ends, successes, time limits, first-step falls, states
    let mut seen = [0usize; 6];
    for (i, s) in states.iter().enumerate() {
        let e = &s["expected"];
        let arrays = Arrays::of(&chars[s["char"].as_u64().expect("char") as usize]);
        let st = arrays.state();
        let mut goal = target_goal(s);
        goal.gate = rule_gate(name, &goal, h);
        let mut obs = vec![0.0f32; floats(&e["task_obs"]).len()];
        rule.observe(&goal, &st, 0, &mut obs);
        check_f32("task_obs", i, &obs, &floats(&e["task_obs"]));
        // the released points are in the object frame, about the bounding-box centre
        let mid: [f64; 3] = std::array::from_fn(|k| 0.5 * (goal.lo[k] + goal.hi[k]));
        let (lo, hi) = (sub(goal.lo, mid), sub(goal.hi, mid));
        let bps: Vec<f64> =
            corners([0.0; 3], Quat::IDENTITY, lo, hi).iter().flatten().copied().collect();
        check("object_bps", i, &bps, &floats(&e["object_bps"]), &mut worst);

        let r = step(rule, &mut goal, &st, s, [0.0; 3], heights(h));
        let total = *r.terms.last().expect("terms");
        let pw = -h.power_coefficient * power(&st);
        check("power_reward", i, &[pw], &floats(&e["power_reward"]), &mut worst);
        check_term("reward", i, total + pw, &e["reward"], &mut worst);
        extra(i, e, &goal, &r, &st, &mut worst);

        let steps = s["progress"].as_u64().expect("progress") as usize;
        assert_eq!(r.fallen, flag(&e["terminated"]), "{name} fall rule (training), state {i}");
        let eval_fall = FallRule::Low { from_step: eval_from }.fallen(&st, steps, heights(h));
        assert_eq!(
            eval_fall,
            flag(&e["terminated_eval"]),
            "{name} fall rule (evaluation), state {i}"
        );
        let base = FallRule::ContactAndLow.fallen(&st, steps, heights(h));
        assert_eq!(base, flag(&e["terminated_base"]), "humanoid.py's rule, state {i}");
        assert!(!r.fail, "sit and climb have no task failure");
        assert_eq!(r.finish, flag(&e["iet_triggered"]), "{name} IET, state {i}");
        check(
            "iet_steps_after",
            i,
            &[goal.near_steps as f64],
            &floats(&e["iet_steps_after"]),
            &mut worst,
        );
        let limit = time_limit_reached(steps, episode_length);
        assert_eq!(r.fallen || r.finish || limit, flag(&e["reset"]), "{name} reset, state {i}");
        assert_eq!(r.metrics[1] == 1.0, flag(&e["success_step"]), "{name} success, state {i}");
        seen[0] += usize::from(r.fallen);
        seen[1] += usize::from(r.finish);
        seen[2] += usize::from(r.metrics[1] == 1.0);
        seen[3] += usize::from(limit && !r.fallen);
        seen[4] += usize::from(r.fallen && steps == 1);
        seen[5] += 1;
    }
    println!("{name}: {} states; largest |ours - released| {worst:.2e}; {seen:?}", states.len());
    assert!(seen.iter().all(|&n| n > 0), "{name}: every branch is reached: {seen:?}");
    seen
}

fn rule_gate(name: &str, goal: &sit::Goal, h: &HsiConfig) -> f64 {
    if name == "climb" { gate_radius(goal.lo, goal.hi, h.climb.gate_margin) } else { 0.0 }
}

#[test]
fn sit_matches_the_released_functions() {
    let fx = fixture("tokenhsi_sit_golden.json");
    let h = HsiConfig::default();
    let p = &fx["params"];
    check_params(p, &h, h.sit.episode_length);
    assert_eq!(p["sit_vel_pen_coeff"].as_f64(), Some(h.sit.speed_penalty_coefficient));
    assert_eq!(p["sit_vel_pen_threshold"].as_f64(), Some(h.sit.speed_penalty_threshold));
    assert_eq!(p["sit_ang_vel_pen_coeff"].as_f64(), Some(h.sit.turn_penalty_coefficient));
    assert_eq!(p["sit_ang_vel_pen_threshold"].as_f64(), Some(h.sit.turn_penalty_threshold));
    assert_eq!(p["max_IET_steps"].as_u64(), Some(h.sit.iet_steps as u64));
    assert_eq!(p["success_threshold"].as_f64(), Some(h.sit.success_distance));
    let rule = Sit::new(&h.sit, true, HsiForm::Released);
    let mut penalties = [0usize; 2];
    check_target_task("sit", &rule, &fx, &h, h.sit.episode_length, 1, |i, e, _g, r, _st, worst| {
        // terms: near, far, speed, turn, sit
        check_term("speed_penalty", i, r.terms[2], &e["speed_penalty"], worst);
        check_term("turn_penalty", i, r.terms[3], &e["turn_penalty"], worst);
        check_term("location_reward", i, r.terms[4], &e["location_reward"], worst);
        let plain = 0.7 * r.terms[0] + 0.3 * r.terms[1];
        check_term("location_reward_no_penalty", i, plain, &e["location_reward_no_penalty"], worst);
        penalties[0] += usize::from(r.terms[2] < -1e-6);
        penalties[1] += usize::from(r.terms[3] < -1e-6);
    });
    assert!(penalties.iter().all(|&n| n > 0), "both penalties are reached: {penalties:?}");
}

#[test]
fn climb_matches_the_released_functions() {
    let fx = fixture("tokenhsi_climb_golden.json");
    let h = HsiConfig::default();
    let p = &fx["params"];
    check_params(p, &h, h.climb.episode_length);
    assert_eq!(p["char_h"].as_f64(), Some(h.climb.target_above_top));
    assert_eq!(p["climb_vel_pen_coeff"].as_f64(), Some(h.climb.speed_penalty_coefficient));
    assert_eq!(p["climb_vel_pen_threshold"].as_f64(), Some(h.climb.speed_penalty_threshold));
    assert_eq!(p["max_IET_steps"].as_u64(), Some(h.climb.iet_steps as u64));
    let rule = Climb::new(&h.climb, true, HsiForm::Released);
    let mut cases = [0usize; 3]; // penalised, inside the gate, moving away (far term 0)
    check_target_task(
        "climb",
        &rule,
        &fx,
        &h,
        h.climb.episode_length,
        2,
        |i, e, g, r, _st, worst| {
            check("valid_radius", i, &[g.gate], &floats(&e["valid_radius"]), worst);
            // terms: near, far, foot, speed, climb
            check_term("speed_penalty", i, r.terms[3], &e["speed_penalty"], worst);
            check_term("climb_reward", i, r.terms[4], &e["climb_reward"], worst);
            let plain = 0.2 * r.terms[1] + 0.5 * r.terms[0] + 0.3 * r.terms[2];
            check_term("climb_reward_no_penalty", i, plain, &e["climb_reward_no_penalty"], worst);
            cases[0] += usize::from(r.terms[3] < -1e-6);
            cases[1] += usize::from(r.terms[1] == 1.0);
            cases[2] += usize::from(r.terms[1] == 0.0);
        },
    );
    assert!(cases.iter().all(|&n| n > 0), "every climb reward case is reached: {cases:?}");
}

#[test]
fn carry_matches_the_released_functions() {
    let fx = fixture("tokenhsi_carry_golden.json");
    let h = HsiConfig::default();
    let c = &h.carry;
    let p = &fx["params"];
    check_params(p, &h, c.episode_length);
    assert_eq!(p["box_vel_pen_coeff"].as_f64(), Some(c.box_speed_penalty_coefficient));
    assert_eq!(p["box_vel_pen_threshold"].as_f64(), Some(c.box_speed_penalty_threshold));
    assert_eq!(p["eval_success_threshold"].as_f64(), Some(c.success_distance));
    let rule = Carry::new(c, true, HsiForm::Released);
    let chars = fx["characters"].as_array().expect("characters");
    let states = fx["states"].as_array().expect("states");
    let mut worst = 0.0f64;
    // falls, successes, time limits, box-speed penalties, put-downs, low masks, walk = 1, states
    let mut seen = [0usize; 8];
    for (i, s) in states.iter().enumerate() {
        let e = &s["expected"];
        let mut arrays = Arrays::of(&chars[s["char"].as_u64().expect("char") as usize]);
        let pos = vec3(&s["object_pos"]);
        let rot = floats(&s["object_rot"]);
        arrays.push_body(pos, &rot, vec3(&s["object_vel"]), vec3(&s["object_ang_vel"]));
        let st = arrays.state();
        let half = vec3(&s["box_size"]).map(|a| 0.5 * a);
        let mut goal =
            carry::Goal { target: vec3(&s["tar_pos"]), start: [0.0; 3], half, reached: false };
        let mut obs = vec![0.0f32; 42];
        rule.observe(&goal, &st, 0, &mut obs);
        check_f32("task_obs", i, &obs, &floats(&e["task_obs"]));
        let neg = half.map(|a| -a);
        let bps: Vec<f64> =
            corners([0.0; 3], Quat::IDENTITY, neg, half).iter().flatten().copied().collect();
        check("box_bps", i, &bps, &floats(&e["box_bps"]), &mut worst);

        let r = step(&rule, &mut goal, &st, s, vec3(&s["prev_box_pos"]), heights(&h));
        // terms: walk, carry, pick, put, box_speed, total
        let t = &r.terms;
        check_term("walk_reward", i, t[0], &e["walk_reward"], &mut worst);
        check_term("carry_reward_no_penalty", i, t[1], &e["carry_reward_no_penalty"], &mut worst);
        check_term("box_speed_penalty", i, t[4], &e["box_speed_penalty"], &mut worst);
        check_term("carry_reward", i, t[1] + t[4], &e["carry_reward"], &mut worst);
        check_term("handheld_reward", i, t[2], &e["handheld_reward"], &mut worst);
        check_term("putdown_reward", i, t[3], &e["putdown_reward"], &mut worst);
        check_term("carry_box_reward", i, t[5], &e["carry_box_reward"], &mut worst);
        let pw = -h.power_coefficient * power(&st);
        check("power_reward", i, &[pw], &floats(&e["power_reward"]), &mut worst);
        check_term("reward", i, t[5] + pw, &e["reward"], &mut worst);

        let steps = s["progress"].as_u64().expect("progress") as usize;
        assert_eq!(r.fallen, flag(&e["terminated"]), "carry fall rule, state {i}");
        let base = FallRule::ContactAndLow.fallen(&st, steps, heights(&h));
        assert_eq!(base, flag(&e["terminated_base"]), "humanoid.py's rule, state {i}");
        assert!(!r.fail && !r.finish, "no object fall, no IET");
        let limit = time_limit_reached(steps, c.episode_length);
        assert_eq!(r.fallen || limit, flag(&e["reset"]), "carry reset, state {i}");
        assert_eq!(r.metrics[1] == 1.0, flag(&e["success_step"]), "carry success, state {i}");
        let low = pos[2] <= half[2] + c.low_margin;
        seen[0] += usize::from(r.fallen);
        seen[1] += usize::from(r.metrics[1] == 1.0);
        seen[2] += usize::from(limit && !r.fallen);
        seen[3] += usize::from(t[4] < -1e-6);
        seen[4] += usize::from(t[3] > 0.0);
        let off_target = (pos[0] - goal.target[0]).hypot(pos[1] - goal.target[1]) >= 0.5;
        seen[5] += usize::from(low && off_target);
        seen[6] += usize::from((t[0] - 0.2).abs() < 1e-7);
        seen[7] += 1;
    }
    println!("carry: {} states; largest |ours - released| {worst:.2e}; {seen:?}", states.len());
    assert!(seen.iter().all(|&n| n > 0), "carry: every branch is reached: {seen:?}");
}

#[test]
fn carry_boxes_and_heights_match_the_released_setup() {
    let fx = fixture("tokenhsi_carry_golden.json");
    let c = HsiConfig::default().carry;
    // the released training pool: cubes 0.20, 0.25, …, 0.60 m at 100 kg/m³
    let pool = &fx["box_pools"]["train"];
    let want: Vec<f64> = floats(&pool["distinct_box_sizes"]);
    assert_eq!(floats(&pool["densities"]), vec![c.box_density]);
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
    let mut got: Vec<[f64; 3]> = Vec::new();
    for _ in 0..2000 {
        let (half, mass) = draw_box(&mut rng, &c);
        let size = half.map(|a| 2.0 * a);
        assert!((mass - c.box_density * size[0] * size[1] * size[2]).abs() < 1e-12);
        if !got.iter().any(|g| (0..3).all(|k| (g[k] - size[k]).abs() < 1e-9)) {
            got.push(size);
        }
    }
    got.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let got: Vec<f64> = got.iter().flatten().copied().collect();
    assert_eq!(got.len(), want.len(), "the nine sizes: {got:?}");
    for (a, b) in got.iter().zip(&want) {
        assert!((a - b).abs() < 1e-9, "box size {a} vs released {b}");
    }
    for r in fx["regulate_height"].as_array().expect("regulate_height") {
        let (h, z, out) = (r["box_h"].as_f64(), r["z_in"].as_f64(), r["z_out"].as_f64());
        let (h, z, out) = (h.expect("box_h"), z.expect("z_in"), out.expect("z_out"));
        let ours = regulate_height(z, 0.5 * h, c.max_top);
        assert!((ours - out).abs() < 1e-12, "regulate {h} {z}: {ours} vs {out}");
    }
}
