//! `skillmimic bench …`: throughput benchmarks that print ratios measured within one run.
//!
//! Variants run the same workload (bit-identical trajectories) interleaved in short chunks of
//! steps, each chunk timed separately, so slow drifts of a noisy machine hit all variants alike
//! and cancel in the ratios.

use std::sync::Arc;
use std::time::Instant;

use skillmimic_sim::{BatchSim, ResetState, Scene};

pub use crate::bench_raw::SimArgs;
use crate::bench_raw::{RawLoop, Workload};

#[derive(clap::Subcommand)]
pub enum BenchCommand {
    /// Simulation throughput: raw mj_step loop vs. the batched core (PD, sub-steps, read-out).
    Sim(SimArgs),
    /// Policy inference (normalisation + actor + critic) vs. PyTorch, same network and threads.
    Infer(crate::bench_learner::NetArgs),
    /// One PPO minibatch update vs. PyTorch, same network and threads.
    Update(crate::bench_learner::NetArgs),
    /// End-to-end training throughput vs. simulation-only throughput of the same environments.
    Train(crate::bench_train::TrainArgs),
    /// Raw mj_step throughput of each constraint solver (Newton, PGS, CG) on the same workload,
    /// interleaved, and how far each trajectory drifts from Newton's.
    Solver(SimArgs),
}

pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Sim(a) => bench_sim(a),
        BenchCommand::Infer(a) => crate::bench_learner::run("infer", a),
        BenchCommand::Update(a) => crate::bench_learner::run("update", a),
        BenchCommand::Train(a) => crate::bench_train::run(a),
        BenchCommand::Solver(a) => crate::bench_solver::run(a),
    }
}

fn bench_sim(a: SimArgs) -> anyhow::Result<()> {
    let hands = a.hand_models()?;
    let w = Workload::new(a.envs, a.steps);
    println!(
        "bench sim: {} envs, {} policy steps (2 x mj_step each) x {} rounds, variants interleaved \
            every {} steps; unit: policy steps/s",
        a.envs, a.steps, a.rounds, a.chunk
    );
    println!(
        "{:<8} {:>12} {:>12} {:>12} {:>12} {:>12} {:>14} {:>14}",
        "hands",
        "(a) raw 1T",
        "(a) raw 2T",
        "(b) core 1T",
        "(b) core 2T",
        "(b)/(a) 1T",
        "(b) 2T/1T",
        "(a) 2T/1T"
    );
    for h in hands {
        let scene = Arc::new(Scene::default_for(h)?);
        // a freshly reset batch provides the identical initial state of the raw loops; all four
        // variants then follow bit-identical trajectories
        let init = BatchSim::new(scene.clone(), a.envs, 1)?;
        let mut raw1 = RawLoop::new(&scene, a.envs, None)?;
        let mut raw2 = RawLoop::new(&scene, a.envs, Some(2))?;
        let mut sim1 = BatchSim::new(scene.clone(), a.envs, 1)?;
        let mut sim2 = BatchSim::new(scene.clone(), a.envs, 2)?;
        let reset = vec![ResetState::default(); a.envs];
        let mask = vec![true; a.envs];
        let mut secs = [0.0f64; 4];
        for round in 0..=a.rounds {
            raw1.reset_from(&init);
            raw2.reset_from(&init);
            sim1.reset(&mask, &reset)?;
            sim2.reset(&mask, &reset)?;
            // chunks of `chunk` policy steps per variant: long enough to amortise the wake-up of
            // idle pool threads, short enough (tens of ms) for drift to cancel
            for c0 in (0..w.steps()).step_by(a.chunk) {
                let ks = c0..(c0 + a.chunk).min(w.steps());
                let t0 = Instant::now();
                ks.clone().for_each(|k| raw1.step(&scene, w.step_actions(k)));
                let t1 = Instant::now();
                for k in ks.clone() {
                    sim1.step(w.step_actions(k))?;
                }
                let t2 = Instant::now();
                ks.clone().for_each(|k| raw2.step(&scene, w.step_actions(k)));
                let t3 = Instant::now();
                for k in ks {
                    sim2.step(w.step_actions(k))?;
                }
                let t4 = Instant::now();
                if round > 0 {
                    // round 0 warms caches and thread pools
                    for (s, d) in secs.iter_mut().zip([t1 - t0, t2 - t1, t3 - t2, t4 - t3]) {
                        *s += d.as_secs_f64();
                    }
                }
            }
        }
        let n = (a.rounds * w.steps() * a.envs) as f64;
        let [ma1, mb1, ma2, mb2] = secs.map(|s| n / s);
        println!(
            "{:<8} {:>12.0} {:>12.0} {:>12.0} {:>12.0} {:>12.3} {:>13.2}x {:>13.2}x",
            h.name(),
            ma1,
            ma2,
            mb1,
            mb2,
            mb1 / ma1,
            mb2 / mb1,
            ma2 / ma1
        );
    }
    println!("targets: (b)/(a) >= 0.90 and 1->2-thread scaling >= 1.85x");
    Ok(())
}
