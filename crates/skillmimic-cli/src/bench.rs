//! `skillmimic bench …`: throughput benchmarks that print ratios measured within one run.
//!
//! Variants run the same workload (bit-identical trajectories) interleaved in short chunks of
//! steps, each chunk timed separately, so slow drifts of a noisy machine hit all variants alike
//! and cancel in the ratios.

use std::sync::Arc;
use std::time::Instant;

use mujoco_rs::prelude::*;
use rand::{Rng, SeedableRng};
use skillmimic_core::skeleton::NUM_DOFS;
use skillmimic_sim::{BatchSim, HandModel, ResetState, Scene};

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

#[derive(clap::Args)]
pub struct SimArgs {
    /// Environments per batch (a training-sized batch: thread scaling needs enough work per step).
    #[arg(long, default_value_t = 256)]
    pub envs: usize,
    /// Policy steps per round.
    #[arg(long, default_value_t = 60)]
    pub steps: usize,
    /// Policy steps a variant runs before the next variant takes over (interleaving grain).
    #[arg(long, default_value_t = 10)]
    pub chunk: usize,
    /// Measured rounds (after one warm-up round).
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Hand models to measure: full, box or both.
    #[arg(long, default_value = "both")]
    pub hands: String,
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

/// The workload: every environment starts upright at rest and follows the same random targets.
pub(crate) struct Workload {
    actions: Vec<f32>, // steps × envs × 156
    envs: usize,
    steps: usize,
}

impl Workload {
    pub(crate) fn new(envs: usize, steps: usize) -> Self {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let actions = (0..steps * envs * NUM_DOFS).map(|_| 0.15 * rng.random_range(-1.0f32..=1.0)).collect();
        Self { actions, envs, steps }
    }
    pub(crate) fn steps(&self) -> usize {
        self.steps
    }
    pub(crate) fn step_actions(&self, k: usize) -> &[f32] {
        &self.actions[k * self.envs * NUM_DOFS..(k + 1) * self.envs * NUM_DOFS]
    }
}

/// (a) the anchor: plain `MjData`s, set `ctrl`, `mj_step` twice per policy step, no read-out.
/// With a pool the environments are spread over its threads (to show MuJoCo's own scaling).
pub(crate) struct RawLoop {
    pub(crate) datas: Vec<MjData<Arc<MjModel>>>,
    pool: Option<rayon::ThreadPool>,
}

impl RawLoop {
    pub(crate) fn new(scene: &Scene, envs: usize, threads: Option<usize>) -> anyhow::Result<Self> {
        let datas = (0..envs).map(|_| MjData::new(Arc::clone(scene.model()))).collect();
        let pool = match threads {
            Some(n) => Some(rayon::ThreadPoolBuilder::new().num_threads(n).build()?),
            None => None,
        };
        Ok(Self { datas, pool })
    }

    /// MuJoCo data bytes of one environment.
    pub(crate) fn data_bytes(&self) -> u64 {
        self.datas.first().map_or(0, |d| skillmimic_sim::memory::data_bytes(d.ffi()))
    }

    /// Start from exactly the state of a freshly reset batch.
    pub(crate) fn reset_from(&mut self, init: &BatchSim) {
        for (i, d) in self.datas.iter_mut().enumerate() {
            d.qpos_mut().copy_from_slice(init.qpos(i));
            d.qvel_mut().copy_from_slice(init.qvel(i));
            d.qacc_warmstart_mut().fill(0.0);
            d.ctrl_mut().fill(0.0);
            d.forward();
        }
    }

    pub(crate) fn step(&mut self, scene: &Scene, a: &[f32]) {
        use rayon::prelude::*;
        let step_env = |i: usize, d: &mut MjData<Arc<MjModel>>| {
            let row = &a[i * NUM_DOFS..(i + 1) * NUM_DOFS];
            for (c, &j) in d.ctrl_mut().iter_mut().zip(&scene.actuator_action) {
                *c = (row[j] as f64).clamp(-1.0, 1.0) * std::f64::consts::PI;
            }
            d.step();
            d.step();
        };
        match &self.pool {
            None => self.datas.iter_mut().enumerate().for_each(|(i, d)| step_env(i, d)),
            Some(p) => {
                let datas = &mut self.datas;
                p.install(|| datas.par_iter_mut().enumerate().for_each(|(i, d)| step_env(i, d)))
            }
        }
    }
}

fn bench_sim(a: SimArgs) -> anyhow::Result<()> {
    let hands: Vec<HandModel> = match a.hands.as_str() {
        "both" => vec![HandModel::Full, HandModel::Box],
        h => vec![crate::cmd_trace::parse_hands(h)?],
    };
    let w = Workload::new(a.envs, a.steps);
    println!(
        "bench sim: {} envs, {} policy steps (2 x mj_step each) x {} rounds, variants interleaved every {} steps; unit: policy steps/s",
        a.envs, a.steps, a.rounds, a.chunk
    );
    println!(
        "{:<8} {:>12} {:>12} {:>12} {:>12} {:>12} {:>14} {:>14}",
        "hands", "(a) raw 1T", "(a) raw 2T", "(b) core 1T", "(b) core 2T", "(b)/(a) 1T", "(b) 2T/1T", "(a) 2T/1T"
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
            for c0 in (0..w.steps).step_by(a.chunk) {
                let ks = c0..(c0 + a.chunk).min(w.steps);
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
        let n = (a.rounds * w.steps * w.envs) as f64;
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
