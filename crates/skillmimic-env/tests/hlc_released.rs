//! SkillMimic's high-level tasks (heading, circling, throwing, scoring) against the released
//! code's own functions: the golden values of `tests/fixtures/skillmimic_hlc_golden.json` (see
//! its note), computed by the released task classes' observation, reward and reset methods on
//! states this project dumped (`examples/hlc_states.rs`).
//!
//! Each chain is one episode's consecutive low-level steps; the task's goal (with its latch)
//! is carried along it as the released code carries `reached_target`. Per step, in the released
//! order (observation before the reward, as under `env.hlc.timing = "released"`): the task
//! observation (float32 here: to 1e-5 or 2e-7 relative), the reward (float64: 1e-8 relative, the
//! fixture's 9 significant digits), the latch after the step (heading `success`, circling
//! `code_success`, scoring `reached`; the released throwing task keeps none), the episode end
//! ([`episode_end`]: terminated, and terminated or truncated = the released reset) and, for
//! scoring, the predicted crossing of 2 m ([`predict_crossing`], prediction "code") against
//! `calculate_landing_position` (1e-8 relative). Whole states also compare the full observation
//! (838 state entries and the task part). Rewards are the defaults' `reward = "code"`.
//!
//! One documented difference: with the goal exactly at the root (the circling centre at an
//! episode's start) the bearing is undefined; the released formula then gives the root's heading
//! direction (cos h, sin h), this project (1, 0). The released loop never observes that case (an
//! episode's first observation shows the previous goal); `timing = "cut"` does.

mod common;

use common::{TOL, fixture, flag, floats, wxyz};
use serde_json::Value;
use skillmimic_core::characters::skillmimic::{BODIES, FINGERTIPS};
use skillmimic_core::math::heading;
use skillmimic_env::obs::{layout, write_state_obs};
use skillmimic_env::tasks::hlc::circling::{Circling, CirclingGoal};
use skillmimic_env::tasks::hlc::config::{
    CirclingConfig, HeadingConfig, HlcConfig, Prediction, ScoringConfig, ThrowingConfig,
};
use skillmimic_env::tasks::hlc::heading::{Heading, HeadingGoal};
use skillmimic_env::tasks::hlc::scoring::{Scoring, ScoringGoal, predict_crossing};
use skillmimic_env::tasks::hlc::throwing::{ThrowGoal, Throwing};
use skillmimic_env::tasks::hlc::{Rule, episode_end};
use skillmimic_sim::{BALL, EnvState, NUM_STATE_BODIES};

/// Relative tolerance of the float64 values (the fixture holds 9 significant digits).
const REL64: f64 = 1e-8;

/// Body arrays of one state (world; quaternions w, x, y, z): the root (body 0) and the ball from a
/// chain step, every other body at the origin; or every body of a whole state.
struct Bodies {
    pos: Vec<f64>,
    quat: Vec<f64>,
    vel: Vec<f64>,
    angvel: Vec<f64>,
    force: Vec<f64>,
}

impl Bodies {
    /// A chain step: `root` and `ball` rows are position, quaternion x y z w, linear and angular
    /// velocity; `force` the ball's net contact force (N).
    fn of_step(s: &Value) -> Self {
        let n = NUM_STATE_BODIES;
        let mut b = Bodies {
            pos: vec![0.0; 3 * n],
            quat: [1.0, 0.0, 0.0, 0.0].repeat(n),
            vel: vec![0.0; 3 * n],
            angvel: vec![0.0; 3 * n],
            force: vec![0.0; 3 * n],
        };
        for (body, row) in [(0, floats(&s["root"])), (BALL, floats(&s["ball"]))] {
            b.pos[3 * body..3 * body + 3].copy_from_slice(&row[0..3]);
            b.quat[4 * body..4 * body + 4].copy_from_slice(&wxyz(&row[3..7]));
            b.vel[3 * body..3 * body + 3].copy_from_slice(&row[7..10]);
            b.angvel[3 * body..3 * body + 3].copy_from_slice(&row[10..13]);
        }
        b.force[3 * BALL..3 * BALL + 3].copy_from_slice(&floats(&s["force"]));
        b
    }
    /// A whole state: every body's arrays (`body_rot` x y z w).
    fn of_whole(w: &Value) -> Self {
        Bodies {
            pos: floats(&w["body_pos"]),
            quat: wxyz(&floats(&w["body_rot"])),
            vel: floats(&w["body_vel"]),
            angvel: floats(&w["body_ang_vel"]),
            force: floats(&w["contact_force"]),
        }
    }
    fn state(&self) -> EnvState<'_> {
        EnvState {
            body_pos: &self.pos,
            body_quat: &self.quat,
            body_linvel: &self.vel,
            body_angvel: &self.angvel,
            dof_pos: &[],
            dof_vel: &[],
            dof_force: &[],
            contact_force: &self.force,
            contact_pairs: &[],
            touch: &[],
            unstable: false,
        }
    }
}

/// A task rule with the goal of a fixture chain and the latch the released class keeps.
trait Released: Rule {
    /// The goal of `c` (`goal` xy, `radius`, the latch `reached` it starts with).
    fn goal(c: &Value) -> Self::Goal;
    /// The released `reached_target` counterpart (`None`: the released task keeps none).
    fn latch(g: &Self::Goal) -> Option<bool>;
}

fn xy(c: &Value) -> [f64; 2] {
    let g = floats(&c["goal"]);
    [g[0], g[1]]
}

impl Released for Heading {
    fn goal(c: &Value) -> HeadingGoal {
        HeadingGoal { xy: xy(c), success: flag(&c["reached"]) }
    }
    fn latch(g: &HeadingGoal) -> Option<bool> {
        Some(g.success)
    }
}

impl Released for Circling {
    fn goal(c: &Value) -> CirclingGoal {
        let radius = c["radius"].as_f64().expect("radius");
        CirclingGoal { xy: xy(c), radius, code_success: flag(&c["reached"]), ..Default::default() }
    }
    fn latch(g: &CirclingGoal) -> Option<bool> {
        Some(g.code_success)
    }
}

impl Released for Throwing {
    fn goal(_c: &Value) -> ThrowGoal {
        ThrowGoal::default()
    }
    fn latch(_g: &ThrowGoal) -> Option<bool> {
        None
    }
}

impl Released for Scoring {
    fn goal(c: &Value) -> ScoringGoal {
        let reached = flag(&c["reached"]);
        ScoringGoal { xy: xy(c), reached, code_success: reached, ..Default::default() }
    }
    fn latch(g: &ScoringGoal) -> Option<bool> {
        Some(g.reached)
    }
}

/// Branches of the released rules the fixture reaches.
#[derive(Debug, Default)]
struct Tally {
    steps: usize,
    latch_set: usize,
    latch_kept: usize,
    falls: usize,
    grace_steps: usize,
    time_limits: usize,
    gate_closed: usize,
    touching: usize,
    apex_below_rim: usize,
    worst: f64,
}

fn close64(what: &str, at: &str, ours: f64, theirs: f64, worst: &mut f64) {
    let d = (ours - theirs).abs();
    assert!(d <= REL64 * theirs.abs().max(1.0), "{what} at {at}: ours {ours} vs released {theirs}");
    *worst = worst.max(d / theirs.abs().max(1.0));
}

/// Compare a float32 observation: to [`TOL`] or float32 resolution of the value's magnitude.
fn close32(what: &str, at: &str, ours: &[f32], theirs: &[f64]) {
    assert_eq!(ours.len(), theirs.len(), "{what} width at {at}");
    for (k, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let (a, tol) = (f64::from(*a), TOL.max(2e-7 * b.abs()));
        assert!((a - b).abs() <= tol, "{what}[{k}] at {at}: ours {a} vs released {b}");
    }
}

fn run_chain<R: Released>(rule: &R, hlc: &HlcConfig, c: &Value, n: usize, tally: &mut Tally) {
    let case = c["case"].as_str().expect("case");
    let mut goal = R::goal(c);
    let mut terms = vec![0.0f32; rule.term_names().len()];
    let mut metrics = vec![0.0f32; rule.metric_names().len()];
    for (k, s) in c["steps"].as_array().expect("steps").iter().enumerate() {
        let at = format!("chain {n} ({} {case}) step {k}", R::NAME);
        let bodies = Bodies::of_step(s);
        let st = bodies.state();
        let e = &s["expected"];
        let progress = s["progress"].as_u64().expect("progress") as u32;

        // the observation, taken before the reward updates the latch
        let mut obs = vec![0.0f32; rule.task_obs_dim()];
        rule.task_obs(&goal, &st, &mut obs);
        let mut released = floats(&e["task_obs"]);
        if case == "staged: centre at the root" {
            // the documented difference (module doc): the bearing of a zero offset
            let h = heading(st.quat(0));
            assert!((released[2] - h.cos()).abs() < 1e-6 && (released[3] - h.sin()).abs() < 1e-6);
            assert_eq!((obs[2], obs[3]), (1.0, 0.0), "ours: the bearing of a zero offset");
            released[2..4].copy_from_slice(&[1.0, 0.0]);
        }
        close32("task_obs", &at, &obs, &released);

        let before = R::latch(&goal);
        let r = rule.reward(&mut goal, progress, &st, &mut terms, &mut metrics);
        close64("reward", &at, r, e["reward"].as_f64().expect("reward"), &mut tally.worst);
        let after = R::latch(&goal);
        match after {
            Some(l) => assert_eq!(l, flag(&e["reached"]), "latch at {at}"),
            None => assert!(e.get("reached").is_none(), "the released throwing task has no latch"),
        }
        tally.latch_set += usize::from(before == Some(false) && after == Some(true));
        tally.latch_kept += usize::from(before == Some(true));

        let (terminated, truncated) = episode_end(hlc, progress, &st);
        assert_eq!(terminated, flag(&e["terminated"]), "terminated at {at}");
        assert_eq!(terminated || truncated, flag(&e["reset"]), "reset at {at}");
        let low = st.pos(0)[2] < hlc.termination_height;
        tally.falls += usize::from(terminated);
        tally.grace_steps += usize::from(low && progress == 1);
        tally.time_limits += usize::from(truncated);
        tally.steps += 1;

        let names = rule.term_names();
        if let Some(g) = names.iter().position(|&t| t == "speed_gate") {
            tally.gate_closed += usize::from(terms[g] < 1.0);
        }
        if R::NAME == "scoring" {
            let (p, v) = (st.pos(BALL), st.linvel(BALL));
            let ours =
                predict_crossing(p, v, ScoringConfig::default().reach_height, Prediction::Code)
                    .expect("the code's prediction always gives a point");
            let theirs = floats(&e["landing"]);
            close64("landing x", &at, ours[0], theirs[0], &mut tally.worst);
            close64("landing y", &at, ours[1], theirs[1], &mut tally.worst);
            tally.touching += usize::from(st.contact_force(BALL).iter().any(|f| f.abs() > 0.1));
            tally.apex_below_rim += usize::from(p[2] + v[2] * v[2] / (2.0 * 9.8) < 2.0);
        }
    }
}

/// The full observation of a whole state: the 838 state entries and the task part.
fn whole_obs<R: Released>(rule: &R, w: &Value) -> Vec<f32> {
    let bodies = Bodies::of_whole(w);
    let st = bodies.state();
    let mut obs = vec![0.0f32; layout::STATE_DIM + rule.task_obs_dim()];
    write_state_obs(&st, &mut obs[..layout::STATE_DIM]);
    rule.task_obs(&R::goal(w), &st, &mut obs[layout::STATE_DIM..]);
    obs
}

#[test]
fn high_level_tasks_match_the_released_functions() {
    let fx = fixture("skillmimic_hlc_golden.json");
    let p = &fx["params"];
    let hlc = HlcConfig::default();
    // the released settings the fixture was made with are this project's defaults
    assert_eq!(p["episode_length"].as_u64(), Some(hlc.episode_length as u64));
    assert_eq!(p["termination_height"].as_f64(), Some(hlc.termination_height));
    let names: Vec<&str> = BODIES.iter().map(|b| b.name).collect();
    assert_eq!(p["body_names"].as_array().map(Vec::len), Some(names.len()));
    for (a, b) in p["body_names"].as_array().expect("body names").iter().zip(&names) {
        assert_eq!(a.as_str(), Some(*b), "body order");
    }
    assert_eq!(floats(&p["fingertips"]), FINGERTIPS.map(|b| b as f64).to_vec());

    let heading = Heading(HeadingConfig::default());
    let circling = Circling(CirclingConfig::default());
    let throwing = Throwing(ThrowingConfig::default());
    let scoring = Scoring(ScoringConfig::default());
    let mut tally = Tally::default();
    let chains = fx["chains"].as_array().expect("chains");
    for (n, c) in chains.iter().enumerate() {
        match c["task"].as_str() {
            Some("heading") => run_chain(&heading, &hlc, c, n, &mut tally),
            Some("circling") => run_chain(&circling, &hlc, c, n, &mut tally),
            Some("throwing") => run_chain(&throwing, &hlc, c, n, &mut tally),
            Some("scoring") => run_chain(&scoring, &hlc, c, n, &mut tally),
            other => panic!("unknown task {other:?}"),
        }
    }

    let wholes = fx["whole_states"].as_array().expect("whole states");
    for (n, w) in wholes.iter().enumerate() {
        let ours = match w["task"].as_str() {
            Some("heading") => whole_obs(&heading, w),
            Some("circling") => whole_obs(&circling, w),
            Some("throwing") => whole_obs(&throwing, w),
            Some("scoring") => whole_obs(&scoring, w),
            other => panic!("unknown task {other:?}"),
        };
        close32("observation", &format!("whole state {n}"), &ours, &floats(&w["expected"]["obs"]));
    }

    println!(
        "{} chains, {} steps, {} whole observations; {tally:?}; largest relative |ours - released| \
         of the float64 values {:.2e}",
        chains.len(),
        tally.steps,
        wholes.len(),
        tally.worst
    );
    let t = &tally;
    let reached = [
        t.latch_set,
        t.latch_kept,
        t.falls,
        t.grace_steps,
        t.time_limits,
        t.gate_closed,
        t.touching,
        t.apex_below_rim,
    ];
    assert!(reached.iter().all(|&k| k > 0), "every branch is reached: {tally:?}");
    assert_eq!(wholes.len(), 8, "two whole states per task");
}
