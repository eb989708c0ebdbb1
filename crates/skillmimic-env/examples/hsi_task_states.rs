//! Dump states of the TokenHSI character under `hsi_sit`, `hsi_climb` and `hsi_carry` for golden
//! fixtures: the inputs of `tests/fixtures/tokenhsi_{sit,climb,carry}_golden.json` (see their
//! notes), which the released TokenHSI functions are then run on outside this repository.
//!
//! `cargo run --release -p skillmimic-env --example hsi_task_states -- OUT_DIR`
//! writes `OUT_DIR/{sit,climb,carry}_inputs.json`.
//!
//! Character states (body poses and velocities, contact forces, joint positions, rates and drive
//! torques, the root pose before the step) come from rollouts of the simulated character in each
//! task's scene with random actions — gentle ones (standing, walking off) and strong ones (falls).
//! Each dumped state is written as it is (the episode's planned object or box) and in staged
//! variants that move the goal relative to the character, or set the step count, the root's
//! previous pose or the box's pose and velocity, so that every branch of the released rules is
//! reached: the distance cases of each reward, the penalties (fast, turning, the yaw crossing
//! 0/2π), the interaction early termination counts, success, the fall rule's first steps, the
//! time limit, the "box still low" mask and the put-down tolerance. Every value is written to 9
//! significant digits, which the released code and the tests then read alike.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use skillmimic_core::characters::tokenhsi::{self, HANDS, NUM_BODIES, NUM_DOFS};
use skillmimic_core::math::{Quat, Vec3};
use skillmimic_env::tasks::hsi::carry::{self, Carry};
use skillmimic_env::tasks::hsi::climb::Climb;
use skillmimic_env::tasks::hsi::config::{HsiConfig, HsiForm};
use skillmimic_env::tasks::hsi::geometry::yaw_0_2pi;
use skillmimic_env::tasks::hsi::sit::{self, Sit};
use skillmimic_env::tasks::hsi::{DT, Rule};
use skillmimic_sim::{BatchSim, EnvState, ResetState, Scene, SceneOptions};

type Error = Box<dyn std::error::Error>;

fn r(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}
fn rs(v: &[f64]) -> Vec<f64> {
    v.iter().copied().map(r).collect()
}
fn xyzw(q: Quat) -> Vec<f64> {
    rs(&[q.x, q.y, q.z, q.w])
}

/// One dumped character state (owned), with the root pose before its step.
#[derive(Clone)]
struct Char {
    pos: Vec<f64>,
    quat: Vec<f64>,
    vel: Vec<f64>,
    angvel: Vec<f64>,
    force: Vec<f64>,
    dof: [Vec<f64>; 3],
    prev_root: Vec3,
    prev_quat: Quat,
    progress: usize,
    /// Object 0's state (carry: the box): position, rotation, velocity, angular velocity, and
    /// its position before the step.
    obj: (Vec3, Quat, Vec3, Vec3, Vec3),
}

impl Char {
    fn of(
        st: &EnvState<'_>,
        prev_root: Vec3,
        prev_quat: Quat,
        prev_obj: Vec3,
        steps: usize,
    ) -> Self {
        let b = NUM_BODIES;
        let has_obj = st.body_pos.len() > 3 * b;
        let obj = if has_obj {
            (st.pos(b), st.quat(b), st.linvel(b), st.angvel(b), prev_obj)
        } else {
            ([0.0; 3], Quat::IDENTITY, [0.0; 3], [0.0; 3], [0.0; 3])
        };
        Self {
            pos: st.body_pos[..3 * b].to_vec(),
            quat: st.body_quat[..4 * b].to_vec(),
            vel: st.body_linvel[..3 * b].to_vec(),
            angvel: st.body_angvel[..3 * b].to_vec(),
            force: st.contact_force[..3 * b].to_vec(),
            dof: [
                st.dof_pos[..NUM_DOFS].to_vec(),
                st.dof_vel[..NUM_DOFS].to_vec(),
                st.dof_force[..NUM_DOFS].to_vec(),
            ],
            prev_root,
            prev_quat,
            progress: steps,
            obj,
        }
    }
    fn root(&self) -> Vec3 {
        [self.pos[0], self.pos[1], self.pos[2]]
    }
    fn root_quat(&self) -> Quat {
        Quat::from_wxyz([self.quat[0], self.quat[1], self.quat[2], self.quat[3]])
    }
    /// Root velocity `v` (m/s) over the step: the previous root position moved accordingly.
    fn moving(mut self, v: Vec3) -> Self {
        let p = self.root();
        self.prev_root = [p[0] - v[0] * DT, p[1] - v[1] * DT, p[2]];
        self
    }
    fn steps(mut self, n: usize) -> Self {
        self.progress = n;
        self
    }
    fn json(&self, case: &str) -> Value {
        let b = NUM_BODIES;
        let rows =
            |v: &[f64], w: usize| -> Vec<Vec<f64>> { v[..b * w].chunks(w).map(rs).collect() };
        let rot: Vec<Vec<f64>> =
            self.quat.chunks(4).map(|q| rs(&[q[1], q[2], q[3], q[0]])).collect();
        json!({
            "case": case,
            "body_pos": rows(&self.pos, 3),
            "body_rot": rot,
            "body_vel": rows(&self.vel, 3),
            "body_ang_vel": rows(&self.angvel, 3),
            "contact_force": rows(&self.force, 3),
            "dof_pos": rs(&self.dof[0]),
            "dof_vel": rs(&self.dof[1]),
            "dof_force": rs(&self.dof[2]),
            "progress": self.progress,
            "prev_root_pos": rs(&self.prev_root),
            "prev_root_rot": xyzw(self.prev_quat),
        })
    }
}

fn merge(mut a: Value, b: Value) -> Value {
    if let (Some(a), Value::Object(b)) = (a.as_object_mut(), b) {
        a.extend(b);
    }
    a
}

fn unit2(from: Vec3, to: Vec3) -> [f64; 2] {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    let n = dx.hypot(dy).max(1e-9);
    [dx / n, dy / n]
}

/// Rollouts of `rule` in one scene: 8 environments (0–3 gentle random actions, 4–7 strong ones),
/// states after steps 1, 5, 45 and 80 with their goals.
fn rollouts<R: Rule>(rule: &R, seed: u64) -> Result<Vec<(Char, R::Goal, usize)>, Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let objects = rule.objects(&mut rng);
    let scene =
        Arc::new(Scene::new(SceneOptions { objects, ..SceneOptions::bare(tokenhsi::CHARACTER) })?);
    let n = 8;
    let mut sim = BatchSim::new(scene.clone(), n, 1)?;
    let mut goals = vec![R::Goal::default(); n];
    let mut resets = vec![ResetState::rest(&scene); n];
    for (g, r) in goals.iter_mut().zip(&mut resets) {
        rule.plan(&scene, &mut rng, r, g);
    }
    sim.reset(&vec![true; n], &resets)?;
    let mut out = Vec::new();
    let mut actions = vec![0.0f32; n * NUM_DOFS];
    for step in 1..=80 {
        let before: Vec<(Vec3, Quat, Vec3)> = (0..n)
            .map(|i| {
                let st = sim.state().env(i);
                let obj =
                    if st.body_pos.len() > 3 * NUM_BODIES { st.pos(NUM_BODIES) } else { [0.0; 3] };
                (st.pos(0), st.quat(0), obj)
            })
            .collect();
        for (i, a) in actions.iter_mut().enumerate() {
            let amplitude = if i / NUM_DOFS < 4 { 0.15 } else { 0.9 };
            *a = amplitude * rng.random_range(-1.0f32..1.0);
        }
        sim.step(&actions)?;
        if [1usize, 5, 45, 80].contains(&step) {
            for (i, g) in goals.iter().enumerate() {
                let (pr, pq, po) = before[i];
                out.push((Char::of(&sim.state().env(i), pr, pq, po, step), g.clone(), i));
            }
        }
    }
    Ok(out)
}

/// Sit / climb fields of a state with goal `g` (released object root = bounding-box centre).
fn target_fields(g: &sit::Goal, climb_offset: f64, iet: usize) -> Value {
    let c = g.centre();
    let size = [g.hi[0] - g.lo[0], g.hi[1] - g.lo[1], g.hi[2] - g.lo[2]];
    let local =
        g.obj_quat.conj().rotate([g.target[0] - c[0], g.target[1] - c[1], g.target[2] - c[2]]);
    json!({
        "object_pos": rs(&c),
        "object_rot": xyzw(g.obj_quat),
        "object_bbox": rs(&size),
        "object_center": [0.0, 0.0, 0.0],
        "object_facing": [1.0, 0.0, 0.0],
        "obj_tar_local": rs(&[local[0], local[1], local[2] - climb_offset]),
        "tar_pos": rs(&g.target),
        "iet_steps": iet,
        // this project's goal, to rebuild it in the tests (object frame origin, w x y z, box lo/hi)
        "goal": {
            "obj_pos": rs(&g.obj_pos),
            "obj_quat": rs(&[g.obj_quat.w, g.obj_quat.x, g.obj_quat.y, g.obj_quat.z]),
            "lo": rs(&g.lo), "hi": rs(&g.hi), "target": rs(&g.target),
        },
    })
}

/// `g` moved horizontally by `d` (object and target).
fn shifted(g: &sit::Goal, d: [f64; 2]) -> sit::Goal {
    let mut g = g.clone();
    for p in [&mut g.obj_pos, &mut g.target] {
        p[0] += d[0];
        p[1] += d[1];
    }
    g
}

/// `g` moved so that its object centre is `dist` m (2-D) from `root` along the heading `a`.
fn object_at(g: &sit::Goal, root: Vec3, dist: f64, a: f64) -> sit::Goal {
    let c = g.centre();
    shifted(g, [root[0] + dist * a.cos() - c[0], root[1] + dist * a.sin() - c[1]])
}

fn common(task: &str, episode_length: usize) -> Value {
    let h = HsiConfig::default();
    json!({
        "task": task,
        "dt": DT,
        "max_episode_length": episode_length,
        "termination_height": h.termination_height,
        "head_termination_height": h.head_termination_height,
        "head_body": 2,
        "contact_body_ids": tokenhsi::CONTACT_BODIES,
        "key_body_ids": tokenhsi::KEY_BODIES,
        "power_coefficient": h.power_coefficient,
        "power_reward": true,
    })
}

fn sit_or_climb(climb: bool) -> Result<Value, Box<dyn std::error::Error>> {
    let h = HsiConfig::default();
    let (name, offset, len) = if climb {
        ("climb", h.climb.target_above_top, h.climb.episode_length)
    } else {
        ("sit", 0.0, h.sit.episode_length)
    };
    let states = if climb {
        rollouts(&Climb::new(&h.climb, true, HsiForm::Released), 391)?
    } else {
        rollouts(&Sit::new(&h.sit, true, HsiForm::Released), 381)?
    };
    let mut out = Vec::new();
    let mut push = |case: &str, c: &Char, g: &sit::Goal, iet: usize| {
        out.push(merge(c.json(case), target_fields(g, offset, iet)));
    };
    for (c, g, i) in &states {
        push("rollout", c, g, 0);
        if !(c.progress == 5 || c.progress == 80) || i % 4 >= 2 {
            continue;
        }
        let root = c.root();
        let a = 0.9 * *i as f64;
        let yaw = yaw_0_2pi(c.root_quat());
        // distance cases of the far / near terms and the penalties, moving towards or away
        for (dist, speed) in [
            (3.0, 1.2),
            (3.0, -1.0),
            (1.2, 2.0),
            (1.2, 0.5),
            (1.7, 2.5),
            (0.4, 0.6),
            (0.8, 2.0),
            (1.0, 0.9),
        ] {
            let g2 = object_at(g, root, dist, a);
            let u = unit2(root, g2.centre());
            let mut c2 = c.clone().moving([speed * u[0], speed * u[1], 0.0]);
            // turning: 6 rad/s, or a slow turn across yaw 0 / 2π
            c2.prev_quat = if dist == 1.2 && speed < 1.0 {
                Quat::about_z(-(yaw + 0.005)).mul(c.root_quat())
            } else {
                Quat::about_z(-6.0 * DT).mul(c.root_quat())
            };
            push(&format!("object {dist} m, root speed {speed} m/s"), &c2, &g2, 0);
        }
        // climb: a large object whose gate (2.1 m) lies beyond the 1.5 m penalty radius
        if climb {
            let mut big = g.clone();
            big.lo = [-1.5, -1.0, 0.0];
            big.hi = [1.5, 1.0, g.hi[2]];
            for (dist, speed) in [(1.8, 2.0), (1.3, 2.0), (2.4, 1.0)] {
                let g2 = object_at(&big, root, dist, a);
                let u = unit2(root, g2.centre());
                push(
                    &format!("3 x 2 m object {dist} m away"),
                    &c.clone().moving([speed * u[0], speed * u[1], 0.0]),
                    &g2,
                    0,
                );
            }
        }
        // the target near the root: interaction early termination counts and success
        for (off, iet) in [(0.1, 10), (0.05, 58), (0.05, 57), (0.25, 58), (0.19, 0)] {
            let p = [root[0] + off * a.cos(), root[1] + off * a.sin()];
            let mut g2 = shifted(g, [p[0] - g.target[0], p[1] - g.target[1]]);
            g2.target[2] = root[2];
            push(&format!("target {off} m from the root, {iet} steps near"), c, &g2, iet);
        }
        push("first step", &c.clone().steps(1), g, 0);
        push("second step", &c.clone().steps(2), g, 0);
        push("time limit", &c.clone().steps(len - 1), g, 0);
        push("before the time limit", &c.clone().steps(len - 2), g, 0);
    }
    let mut doc = common(&format!("hsi_{name}"), len);
    let extra = if climb {
        json!({"char_h": offset, "climb_vel_penalty": true, "climb_vel_pen_coeff": h.climb.speed_penalty_coefficient,
               "climb_vel_pen_threshold": h.climb.speed_penalty_threshold,
               "success_threshold": h.climb.success_distance, "max_IET_steps": h.climb.iet_steps,
               "eval_success_threshold": h.climb.success_distance, "states": out})
    } else {
        json!({"sit_vel_penalty": true, "sit_vel_pen_coeff": h.sit.speed_penalty_coefficient,
               "sit_vel_pen_threshold": h.sit.speed_penalty_threshold,
               "sit_ang_vel_pen_coeff": h.sit.turn_penalty_coefficient,
               "sit_ang_vel_pen_threshold": h.sit.turn_penalty_threshold,
               "success_threshold": h.sit.success_distance, "max_IET_steps": h.sit.iet_steps,
               "eval_success_threshold": h.sit.success_distance, "states": out})
    };
    Ok(merge(doc.take(), extra))
}

fn box_fields(c: &Char, g: &carry::Goal) -> Value {
    let (p, q, v, w, prev) = c.obj;
    json!({
        "box_size": rs(&g.half.map(|h| 2.0 * h)),
        "object_pos": rs(&p), "object_rot": xyzw(q), "object_vel": rs(&v), "object_ang_vel": rs(&w),
        "prev_box_pos": rs(&prev), "tar_pos": rs(&g.target),
    })
}

fn carry_states() -> Result<Value, Box<dyn std::error::Error>> {
    let h = HsiConfig::default();
    let c = &h.carry;
    let states = rollouts(&Carry::new(c, true, HsiForm::Released), 401)?;
    let mut out = Vec::new();
    let mut push =
        |case: &str, ch: &Char, g: &carry::Goal| out.push(merge(ch.json(case), box_fields(ch, g)));
    for (ch, g, i) in &states {
        push("rollout", ch, g);
        if !(ch.progress == 5 || ch.progress == 80) || i % 4 >= 2 {
            continue;
        }
        let root = ch.root();
        let a = 0.9 * *i as f64;
        let hz = g.half[2];
        let hands: Vec3 = {
            let (h0, h1) =
                (&ch.pos[3 * HANDS[0]..3 * HANDS[0] + 3], &ch.pos[3 * HANDS[1]..3 * HANDS[1] + 3]);
            [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])]
        };
        // the box placed at `p` moving with velocity `v` over the step
        let with_box = |p: Vec3, v: Vec3| {
            let mut c2 = ch.clone();
            c2.obj.0 = p;
            c2.obj.2 = v;
            c2.obj.4 = [p[0] - v[0] * DT, p[1] - v[1] * DT, p[2] - v[2] * DT];
            c2
        };
        let towards = |from: Vec3, to: Vec3, s: f64| {
            let u = unit2(from, to);
            [s * u[0], s * u[1], 0.0]
        };
        let ahead = [root[0] + 2.0 * a.cos(), root[1] + 2.0 * a.sin(), hz];
        // walking to the box or away; the box 0.4 m away (walk term = 1) or 0.6 m (pick term on)
        push(
            "box 2 m away, walking to it",
            &with_box(ahead, [0.0; 3]).moving(towards(root, ahead, 1.4)),
            g,
        );
        push(
            "box 2 m away, walking away",
            &with_box(ahead, [0.0; 3]).moving(towards(ahead, root, 1.0)),
            g,
        );
        for d in [0.4, 0.6, 0.69, 0.75] {
            let p = [root[0] + d * a.cos(), root[1] + d * a.sin(), hz];
            push(&format!("box {d} m from the root"), &with_box(p, [0.0; 3]), g);
        }
        // held at the hands, moving to the target, away, too fast
        let held = [hands[0] + 0.05, hands[1], hands[2]];
        for (s, what) in [
            (1.5, "to the target"),
            (3.0, "too fast to the target"),
            (-1.0, "away from the target"),
        ] {
            let v = towards(held, g.target, s);
            push(&format!("box at the hands, moving {what}"), &with_box(held, v), g);
        }
        // low on the floor and pushed towards the target; just above the low margin
        for z in [hz, hz + 0.19, hz + 0.21] {
            let p = [ahead[0], ahead[1], z];
            push(
                &format!("box at height {z:.3}, moving to the target"),
                &with_box(p, towards(p, g.target, 1.5)),
                g,
            );
        }
        // near the target: within 0.5 m while low, the put-down tolerance, success
        let t = g.target;
        for (dx, dz) in [
            (0.3, 0.0),
            (0.05, 0.0005),
            (0.0, 0.002),
            (0.11, 0.0),
            (0.09, 0.0009),
            (0.15, 0.12),
            (0.21, 0.0),
        ] {
            let p = [t[0] + dx * a.cos(), t[1] + dx * a.sin(), t[2] + dz];
            push(
                &format!("box {dx} m beside and {dz} m above the target"),
                &with_box(p, [0.0; 3]),
                g,
            );
        }
        push("first step", &ch.clone().steps(1), g);
        push("second step", &ch.clone().steps(2), g);
        push("time limit", &ch.clone().steps(c.episode_length - 1), g);
    }
    let mut doc = common("hsi_carry", c.episode_length);
    Ok(merge(
        doc.take(),
        json!({"only_vel_reward": true, "only_height_handheld_reward": false, "box_vel_penalty": true,
               "box_vel_pen_coeff": c.box_speed_penalty_coefficient,
               "box_vel_pen_threshold": c.box_speed_penalty_threshold, "build_random_density": false,
               "enable_bbox_obs": true, "eval_success_threshold": c.success_distance, "states": out}),
    ))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir =
        std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: hsi_task_states OUT_DIR")?);
    std::fs::create_dir_all(&dir)?;
    for (name, doc) in
        [("sit", sit_or_climb(false)?), ("climb", sit_or_climb(true)?), ("carry", carry_states()?)]
    {
        let path = dir.join(format!("{name}_inputs.json"));
        std::fs::write(&path, serde_json::to_string(&doc)?)?;
        println!(
            "{} {name} states -> {}",
            doc["states"].as_array().map_or(0, Vec::len),
            path.display()
        );
    }
    Ok(())
}
