//! `skillmimic bench solver`: the constraint solvers on the same raw `mj_step` workload.
//!
//! One scene per solver (Newton = the shipped default, PGS, CG; MuJoCo's default iteration
//! budget and tolerance), the same environments started in the same state and driven by the same
//! random PD targets, run interleaved in chunks on 2 threads so machine drift cancels in the
//! ratios. Printed per hand model: policy steps/s of each solver, the ratio to Newton, and how far
//! each trajectory ends from Newton's (largest root and ball position difference, m, after the
//! whole run) — a solver is only a candidate default if the fidelity checks of issue 21 hold.

use std::sync::Arc;
use std::time::Instant;

use skillmimic_sim::{BatchSim, Scene, SceneOptions, Solver, SolverOptions};

use crate::bench_raw::{RawLoop, SimArgs, Workload};

const SOLVERS: [Solver; 3] = [Solver::Newton, Solver::Pgs, Solver::Cg];

pub fn run(a: SimArgs) -> anyhow::Result<()> {
    let hands = a.hand_models()?;
    let w = Workload::new(a.envs, a.steps);
    println!(
        "bench solver: {} envs on 2 threads, {} policy steps (2 x mj_step each) x {} rounds, \
            solvers interleaved every {} steps; unit: policy steps/s",
        a.envs, a.steps, a.rounds, a.chunk
    );
    println!(
        "{:<8} {:<7} {:>12} {:>10} {:>16} {:>16}",
        "hands", "solver", "steps/s", "/ Newton", "root drift (m)", "ball drift (m)"
    );
    for h in hands {
        let scenes: Vec<Arc<Scene>> = SOLVERS
            .iter()
            .map(|&solver| {
                Scene::new(SceneOptions {
                    character: skillmimic_core::characters::skillmimic::humanoid(h),
                    solver: SolverOptions { solver, ..Default::default() },
                    ..Default::default()
                })
                .map(Arc::new)
            })
            .collect::<Result<_, _>>()?;
        // the same initial state for every solver (a freshly reset batch of the Newton scene;
        // the state layout is the same in every variant)
        let init = BatchSim::new(Arc::clone(&scenes[0]), a.envs, 1)?;
        let mut loops: Vec<RawLoop> =
            scenes.iter().map(|s| RawLoop::new(s, a.envs, Some(2))).collect::<Result<_, _>>()?;
        let mut secs = [0.0f64; SOLVERS.len()];
        for round in 0..=a.rounds {
            loops.iter_mut().for_each(|l| l.reset_from(&init));
            for c0 in (0..w.steps()).step_by(a.chunk) {
                for (v, l) in loops.iter_mut().enumerate() {
                    let t0 = Instant::now();
                    (c0..(c0 + a.chunk).min(w.steps()))
                        .for_each(|k| l.step(&scenes[v], w.step_actions(k)));
                    if round > 0 {
                        secs[v] += t0.elapsed().as_secs_f64();
                    }
                }
            }
        }
        let n = (a.rounds * w.steps() * a.envs) as f64;
        let scene = &scenes[0];
        let (root, ball) = (scene.root_qpos.unwrap_or(0), scene.ball_qpos().unwrap_or(0));
        let drift = |l: &RawLoop, at: usize| {
            l.datas
                .iter()
                .zip(&loops[0].datas)
                .map(|(d, r)| {
                    (0..3).map(|k| (d.qpos()[at + k] - r.qpos()[at + k]).abs()).fold(0.0, f64::max)
                })
                .fold(0.0, f64::max)
        };
        for (v, s) in SOLVERS.iter().enumerate() {
            println!(
                "{:<8} {:<7} {:>12.0} {:>10.3} {:>16.2e} {:>16.2e}",
                h.name(),
                s.mjcf_name(),
                n / secs[v],
                secs[0] / secs[v],
                drift(&loops[v], root),
                drift(&loops[v], ball)
            );
        }
    }
    println!(
        "drift: largest |Δ position| from the Newton trajectory after the run; chaotic contact \
            dynamics make any change of solver drift over time, so the fidelity checks (replay, \
            restitution, PD tracking, a training curve) decide, not this number"
    );
    Ok(())
}
