//! Dump states of SkillMimic's high-level tasks (heading, circling, throwing, scoring) for golden
//! fixtures: the inputs of `tests/fixtures/skillmimic_hlc_golden.json` (see its note), which the
//! released SkillMimic functions are then run on outside this repository.
//!
//! `cargo run --release -p skillmimic-env --example hlc_states -- OUT.json`
//!
//! Per task, four environments start like the task's episodes (frame 2 of a clip of the shipped
//! `motions/` folder, the goal drawn by the task's own rule from the start root) and are rolled
//! out for 60 low-level steps with random PD targets — gentle ones (envs 0, 1) and strong ones
//! (envs 2, 3); each environment's steps form one chain (the released code carries its latches
//! from step to step). Staged chains built from a rolled-out state then reach every branch of
//! the released rules: the ball passing the heading target (its 0.5 m latch), the circling ring,
//! latch radius and speed gate at exactly 0.5 m/s, goals in every direction from a turned root, a
//! goal exactly at the root, the fall rule (its grace step and the 0.25 m boundary) and the time
//! limit, the scoring "reached" condition (predicted crossing 0.29 / 0.31 m from the basket,
//! contact forces at and above 0.1 N, the ball just below and above 2 m, rising and falling
//! balls, an apex below the rim height, a far landing), its root-speed gate and a latch carried
//! in from earlier. Eight states are also written whole (every body) for the full observation.
//!
//! Units: metres, seconds, radians, newtons; world frame, z up. Quaternions are written x, y, z, w
//! (Isaac Gym's order); every value to 9 significant digits, which the released code and the
//! test then read alike.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use skillmimic_core::characters::skillmimic::{BODIES, FINGERTIPS, NUM_DOFS};
use skillmimic_core::math::Quat;
use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::episode::{BALL_FREE_SKILLS, fill_from_clip, random_ball};
use skillmimic_env::tasks::hlc::circling::{Circling, CirclingGoal};
use skillmimic_env::tasks::hlc::config::{
    CirclingConfig, HeadingConfig, HlcConfig, Prediction, ScoringConfig,
};
use skillmimic_env::tasks::hlc::heading::{Heading, HeadingGoal};
use skillmimic_env::tasks::hlc::scoring::{Scoring, ScoringGoal, predict_crossing};
use skillmimic_env::tasks::hlc::{Rule, norm};
use skillmimic_env::{EnvConfig, load_motion_library};
use skillmimic_sim::{BALL, BatchSim, EnvState, NUM_STATE_BODIES, ResetState, Scene};

type Error = Box<dyn std::error::Error>;

/// `x` to 9 significant digits.
fn r(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}

fn rs(v: &[f64]) -> Vec<f64> {
    v.iter().copied().map(r).collect()
}

/// The part of a state the task rules read: root and ball (world; velocities of the centre of
/// mass, m/s and rad/s), the ball's net contact force (N) and the low-level step of the episode.
#[derive(Clone)]
struct Step {
    progress: u32,
    root_pos: [f64; 3],
    root_quat: Quat,
    root_vel: [f64; 3],
    root_angvel: [f64; 3],
    ball_pos: [f64; 3],
    ball_quat: Quat,
    ball_vel: [f64; 3],
    ball_angvel: [f64; 3],
    force: [f64; 3],
}

impl Step {
    fn of(st: &EnvState<'_>, progress: u32) -> Self {
        Self {
            progress,
            root_pos: st.pos(0),
            root_quat: st.quat(0),
            root_vel: st.linvel(0),
            root_angvel: st.angvel(0),
            ball_pos: st.pos(BALL),
            ball_quat: st.quat(BALL),
            ball_vel: st.linvel(BALL),
            ball_angvel: st.angvel(BALL),
            force: st.contact_force(BALL),
        }
    }
    /// `root`, `ball`: position, quaternion x y z w, linear and angular velocity (13 each).
    fn json(&self) -> Value {
        let row = |p: [f64; 3], q: Quat, v: [f64; 3], w: [f64; 3]| -> Vec<f64> {
            rs(&[p.as_slice(), &q.to_xyzw(), &v, &w].concat())
        };
        json!({
            "progress": self.progress,
            "root": row(self.root_pos, self.root_quat, self.root_vel, self.root_angvel),
            "ball": row(self.ball_pos, self.ball_quat, self.ball_vel, self.ball_angvel),
            "force": rs(&self.force),
        })
    }
    fn at(mut self, progress: u32) -> Self {
        self.progress = progress;
        self
    }
    fn ball(mut self, pos: [f64; 3], vel: [f64; 3], force: [f64; 3]) -> Self {
        (self.ball_pos, self.ball_vel, self.force) = (pos, vel, force);
        self
    }
    fn root_z(mut self, z: f64) -> Self {
        self.root_pos[2] = z;
        self
    }
    fn root_vel(mut self, v: [f64; 3]) -> Self {
        self.root_vel = v;
        self
    }
    /// The root turned about world +z by `yaw` (rad).
    fn turned(mut self, yaw: f64) -> Self {
        self.root_quat = Quat::about_z(yaw).mul(self.root_quat);
        self
    }
}

/// One chain: consecutive steps of one episode with its goal and the latch it starts with.
fn chain(
    task: &str,
    case: &str,
    goal: [f64; 2],
    radius: f64,
    reached: bool,
    steps: &[Step],
) -> Value {
    json!({
        "task": task,
        "case": case,
        "goal": rs(&goal),
        "radius": r(radius),
        "reached": reached,
        "steps": steps.iter().map(Step::json).collect::<Vec<_>>(),
    })
}

/// A whole state (every body, its contact force) for the full observation.
fn whole(task: &str, goal: [f64; 2], radius: f64, st: &EnvState<'_>, progress: u32) -> Value {
    let n = NUM_STATE_BODIES;
    let rows = |v: &[f64]| -> Vec<Vec<f64>> { v[..3 * n].chunks(3).map(rs).collect() };
    let xyzw: Vec<Vec<f64>> =
        st.body_quat[..4 * n].chunks(4).map(|q| rs(&[q[1], q[2], q[3], q[0]])).collect();
    json!({
        "task": task,
        "goal": rs(&goal),
        "radius": r(radius),
        "reached": false,
        "progress": progress,
        "body_pos": rows(st.body_pos),
        "body_rot": xyzw,
        "body_vel": rows(st.body_linvel),
        "body_ang_vel": rows(st.body_angvel),
        "contact_force": rows(st.contact_force),
    })
}

/// A task's goal as (xy, radius) whatever its rule.
fn goal_of(task: &str, root: [f64; 3], rng: &mut ChaCha8Rng) -> ([f64; 2], f64) {
    match task {
        "heading" => {
            let g: HeadingGoal = Heading(HeadingConfig::default()).sample_goal(root, rng);
            (g.xy, 0.0)
        }
        "circling" => {
            let g: CirclingGoal = Circling(CirclingConfig::default()).sample_goal(root, rng);
            (g.xy, g.radius)
        }
        "scoring" => {
            let g: ScoringGoal = Scoring(ScoringConfig::default()).sample_goal(root, rng);
            (g.xy, 0.0)
        }
        _ => ([0.0; 2], 0.0),
    }
}

/// Unit vector along `v`.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = norm(v);
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Staged chains of `task` from the rolled-out state `base` of an episode with goal `goal`.
fn staged(task: &str, base: &Step, goal: [f64; 2], radius: f64) -> Vec<Value> {
    let mut out = Vec::new();
    let still = [0.0; 3];
    // every task: the fall rule (grace step, 0.25 m boundary) and the time limit
    let ends: Vec<Step> = [
        (1, 0.2),
        (2, 0.2),
        (5, 0.25),
        (5, 0.2499),
        (798, 0.9),
        (799, 0.9),
        (800, 0.9),
        (799, 0.1),
    ]
    .iter()
    .map(|&(k, z)| base.clone().at(k).root_z(z))
    .collect();
    out.push(chain(task, "staged: fall rule and time limit", goal, radius, false, &ends));
    let p = base.progress;
    match task {
        "heading" => {
            // the ball passes the target point (goal, 1 m): latch at < 0.5 m, kept afterwards
            let u = unit([1.0, -2.0, 0.5]);
            let t = [goal[0], goal[1], 1.0];
            let steps: Vec<Step> = [1.5, 0.51, 0.49, 0.2, 1.0]
                .iter()
                .enumerate()
                .map(|(k, &d)| {
                    let b = [t[0] + d * u[0], t[1] + d * u[1], t[2] + d * u[2]];
                    base.clone().at(p + k as u32).ball(b, [0.5, 0.2, -0.1], still)
                })
                .collect();
            out.push(chain(task, "staged: ball through the target", goal, radius, false, &steps));
            // goals in every direction from a root turned by several yaws
            let root = base.root_pos;
            for (yaw, off) in
                [(0.0, [-3.0, 2.0]), (1.0, [-2.0, -5.0]), (2.5, [4.0, -1.0]), (-2.0, [0.3, 6.0])]
            {
                let g = [root[0] + off[0], root[1] + off[1]];
                let s = base.clone().turned(yaw);
                out.push(chain(
                    task,
                    "staged: goal direction, turned root",
                    g,
                    radius,
                    false,
                    &[s],
                ));
            }
            // an episode that starts with the latch already set keeps it
            out.push(chain(
                task,
                "staged: latch carried in",
                goal,
                radius,
                true,
                std::slice::from_ref(base),
            ));
        }
        "circling" => {
            // ball at horizontal distances around the ring and inside the 0.3 m latch, speeds at
            // the 0.5 m/s gate
            let cases = [
                (radius - 0.4, [0.5, 0.0, 0.0]),
                (radius, [0.4999999, 0.0, 0.0]),
                (radius + 0.6, [1.0, -2.0, 0.5]),
                (0.31, [0.0, 0.0, 0.0]),
                (0.29, [0.3, 0.3, 0.2]),
                (1.2, [0.0, 0.5, 0.0]),
            ];
            let steps: Vec<Step> = cases
                .iter()
                .enumerate()
                .map(|(k, &(d, v))| {
                    let a = 0.9 * k as f64;
                    let b = [goal[0] + d * a.cos(), goal[1] + d * a.sin(), 0.3];
                    base.clone().at(p + k as u32).ball(b, v, still)
                })
                .collect();
            out.push(chain(
                task,
                "staged: ring, latch and speed gate",
                goal,
                radius,
                false,
                &steps,
            ));
            // the centre exactly at the root (the start of an episode)
            let g = [base.root_pos[0], base.root_pos[1]];
            out.push(chain(
                task,
                "staged: centre at the root",
                g,
                radius,
                false,
                std::slice::from_ref(base),
            ));
        }
        "throwing" => {
            let steps: Vec<Step> = [0.12, 1.3, 2.5, 3.7]
                .iter()
                .enumerate()
                .map(|(k, &z)| {
                    let b = [base.ball_pos[0], base.ball_pos[1], z];
                    base.clone().at(p + k as u32).ball(b, [0.0, 0.0, 1.0], still)
                })
                .collect();
            out.push(chain(task, "staged: ball heights", goal, radius, false, &steps));
        }
        "scoring" => out.extend(scoring_cases(base, goal)),
        _ => {}
    }
    out
}

/// A staged scoring step: case, ball position (m), velocity (m/s), net contact force (N) and the
/// goal's distance (m) from the predicted crossing.
type Single = (&'static str, [f64; 3], [f64; 3], [f64; 3], f64);

/// The scoring task's "reached" branches; each goal is placed at a distance from the released
/// formula's predicted crossing of 2 m (this project's `predict_crossing`, prediction "code").
fn scoring_cases(base: &Step, goal: [f64; 2]) -> Vec<Value> {
    let p = base.progress;
    let at_offset = |s: &Step, d: f64| -> [f64; 2] {
        let xy =
            predict_crossing(s.ball_pos, s.ball_vel, 2.0, Prediction::Code).unwrap_or([0.0; 2]);
        [xy[0] + d * 0.6, xy[1] - d * 0.8]
    };
    let above = [base.root_pos[0] + 0.4, base.root_pos[1] - 0.2, 2.3];
    let mut out = Vec::new();
    // a layup: in the hand, released towards the basket (reached: the observation shows it one
    // step later), then falling far away (the latch stays)
    let flight = base.clone().at(p + 1).ball(above, [1.2, -0.8, 1.5], [0.0; 3]);
    let g = at_offset(&flight, 0.2);
    let steps = [
        base.clone().at(p).ball([above[0], above[1], 1.4], [0.5, 0.0, 2.0], [12.0, -3.0, 25.0]),
        flight.clone(),
        flight.clone().at(p + 2).ball(
            [above[0] + 0.2, above[1] - 0.15, 2.6],
            [1.2, -0.8, 0.3],
            [0.0; 3],
        ),
        base.clone().at(p + 3).ball(
            [above[0] + 3.0, above[1], 0.5],
            [2.0, 0.0, -4.0],
            [0.0, 0.0, 40.0],
        ),
    ];
    out.push(chain("scoring", "staged: layup reaches the basket", g, 0.0, false, &steps));
    // single steps: (case, ball position, velocity, contact force, goal offset from the crossing)
    let z = |h: f64| [above[0], above[1], h];
    let singles: [Single; 11] = [
        ("crossing 0.29 m from the basket", above, [1.0, 0.5, 1.0], [0.0; 3], 0.29),
        ("crossing 0.31 m from the basket", above, [1.0, 0.5, 1.0], [0.0; 3], 0.31),
        ("contact force 0.2 N", above, [1.0, 0.5, 1.0], [0.2, 0.0, 0.0], 0.1),
        ("contact force at 0.1 N", above, [1.0, 0.5, 1.0], [0.1, -0.1, 0.1], 0.1),
        ("contact force -0.15 N", above, [1.0, 0.5, 1.0], [0.0, 0.0, -0.15], 0.1),
        ("ball at 1.99 m", z(1.99), [1.0, 0.5, 1.0], [0.0; 3], 0.1),
        ("ball at 2.01 m", z(2.01), [1.0, 0.5, 1.0], [0.0; 3], 0.1),
        ("falling ball", z(2.4), [-0.7, 1.1, -3.0], [0.0; 3], 0.1),
        ("apex below the rim height", z(1.5), [0.8, 0.2, 1.0], [0.0; 3], 0.1),
        ("far landing", above, [3.0, -1.0, 4.0], [0.0; 3], 5.0),
        ("ball at rest on the floor", z(0.12), [0.0; 3], [0.0, 0.0, 70.6], 0.1),
    ];
    for (case, b, v, f, d) in singles {
        let s = base.clone().ball(b, v, f);
        let g = at_offset(&s, d);
        out.push(chain("scoring", &format!("staged: {case}"), g, 0.0, false, &[s]));
    }
    // the root-speed gate at exactly 0.5 m/s and just below
    for v in [[0.5, 0.0, 0.0], [0.0, -0.4999999, 0.0]] {
        let s = base.clone().root_vel(v);
        out.push(chain("scoring", "staged: root speed gate", goal, 0.0, false, &[s]));
    }
    out.push(chain(
        "scoring",
        "staged: latch carried in",
        goal,
        0.0,
        true,
        std::slice::from_ref(base),
    ));
    out
}

fn main() -> Result<(), Error> {
    let out = std::env::args().nth(1).ok_or("usage: hlc_states OUT.json")?;
    let cfg = EnvConfig::default();
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&cfg)?)?);
    let ball_radius = scene.options().ball.map_or(0.12, |b| b.radius);
    let lib = load_motion_library(&[workspace_root().join("motions")])?;
    let hlc = HlcConfig::default();
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let (n, steps) = (4, 60u32);
    let mut chains = Vec::new();
    let mut wholes = Vec::new();
    for task in ["heading", "circling", "throwing", "scoring"] {
        let mut sim = BatchSim::new(scene.clone(), n, 1)?;
        let mut resets = vec![ResetState::rest(&scene); n];
        let mut goals = Vec::new();
        for s in &mut resets {
            let m = lib.get(lib.sample_clip(&mut rng));
            fill_from_clip(s, m, hlc.start_frame.min(m.clip.num_frames - 2));
            if BALL_FREE_SKILLS.contains(&m.clip.skill) {
                random_ball(s, ball_radius, &mut rng);
            }
            goals.push(goal_of(task, s.root_pos, &mut rng));
        }
        sim.reset(&vec![true; n], &resets)?;
        let mut rolled: Vec<Vec<Step>> = vec![Vec::new(); n];
        let mut actions = vec![0.0f32; n * NUM_DOFS];
        for step in 1..=steps {
            for (i, a) in actions.iter_mut().enumerate() {
                let amplitude = if i / NUM_DOFS < 2 { 0.1 } else { 0.8 };
                *a = amplitude * rng.random_range(-1.0f32..1.0);
            }
            sim.step(&actions)?;
            for (i, c) in rolled.iter_mut().enumerate() {
                let st = sim.state().env(i);
                c.push(Step::of(&st, step));
                if (i == 0 && step == 30) || (i == 3 && step == steps) {
                    wholes.push(whole(task, goals[i].0, goals[i].1, &st, step));
                }
            }
        }
        for (i, c) in rolled.iter().enumerate() {
            let (g, radius) = goals[i];
            chains.push(chain(task, &format!("rollout, env {i}"), g, radius, false, c));
        }
        let (g, radius) = goals[0];
        chains.extend(staged(task, &rolled[0][29], g, radius));
    }
    let doc = json!({
        "params": {
            "episode_length": hlc.episode_length,
            "termination_height": hlc.termination_height,
            "body_names": BODIES.iter().map(|b| b.name).collect::<Vec<_>>(),
            "fingertips": FINGERTIPS,
        },
        "chains": chains,
        "whole_states": wholes,
    });
    std::fs::write(&out, serde_json::to_string(&doc)?)?;
    let count = |k: &str| doc[k].as_array().map_or(0, Vec::len);
    println!("{} chains, {} whole states -> {out}", count("chains"), count("whole_states"));
    Ok(())
}
