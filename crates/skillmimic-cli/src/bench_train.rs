//! `skillmimic bench train`: end-to-end training throughput (environments + inference + PPO
//! update) against the simulation-only throughput of the same environments, in the same run.
//!
//! Each measured round runs one training iteration and then one horizon of simulation only
//! (the same environments replaying the iteration's actions, resets included), so both
//! numbers see the same machine state. Ratio = end-to-end samples/s ÷ simulation-only
//! samples/s (1.0 would mean learning is free).
//!
//! The anchor of issue 21 is measured in the same rounds: a raw `mj_step` loop (plain `MjData`s
//! of the same scene, as many environments on as many threads, `ctrl` set and two `mj_step`
//! per policy step, no read-out, no task) runs one horizon of random targets after each
//! round; ratio raw = end-to-end samples/s ÷ raw policy steps/s. Memory per environment: one
//! environment's `MjData` and the process's resident memory divided by the environments.

use std::sync::Arc;
use std::time::Instant;

use skillmimic_learn::trainer::Trainer;
use skillmimic_sim::{BatchSim, Scene};

use crate::bench_raw::{RawLoop, Workload};
use crate::common::{PresetArgs, init_learner_threads};

#[derive(clap::Args)]
pub struct TrainArgs {
    #[command(flatten)]
    pub base: PresetArgs,
    /// Measured rounds (each: one training iteration + one simulation-only horizon).
    #[arg(long, default_value_t = 4)]
    pub rounds: usize,
    /// Unmeasured warm-up iterations first.
    #[arg(long, default_value_t = 1)]
    pub warmup: usize,
    /// Learner threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub learner_threads: usize,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

pub fn run(a: TrainArgs) -> anyhow::Result<()> {
    let mut cfg = a.base.assemble()?;
    cfg.run.learner_threads = a.learner_threads;
    init_learner_threads(cfg.run.learner_threads);
    let mut trainer = Trainer::new(cfg.clone(), None)?;
    let batch = cfg.batch_size() as f64;
    // the raw mj_step anchor: the same scene, environments and simulation threads
    let scene = Arc::new(Scene::new(cfg.env.scene_options()?)?);
    let n = cfg.env.num_envs;
    let threads = match skillmimic_env::config_range::capped_threads(cfg.env.threads, "env.threads")
    {
        0 => std::thread::available_parallelism().map_or(1, |c| c.get()),
        t => t,
    };
    let init = BatchSim::new(Arc::clone(&scene), n, 1)?;
    let mut raw = RawLoop::new(&scene, n, Some(threads))?;
    let work = Workload::new(n, cfg.ppo.horizon);
    let mut raw_horizon = || {
        raw.reset_from(&init);
        let t0 = Instant::now();
        for k in 0..work.steps() {
            raw.step(&scene, work.step_actions(k));
        }
        batch / t0.elapsed().as_secs_f64()
    };
    println!(
        "bench train: preset '{}', {} envs x horizon {} = {} samples/iteration, network {:?}, \
            minibatch {}, {} mini-epochs, backend {:?}, precision {:?} (runs in {}), {} hands",
        a.base.preset,
        cfg.env.num_envs,
        cfg.ppo.horizon,
        cfg.batch_size(),
        cfg.ppo.hidden,
        cfg.ppo.minibatch,
        cfg.ppo.mini_epochs,
        cfg.ppo.backend,
        cfg.ppo.precision,
        trainer.update_precision(),
        cfg.env.hands
    );
    for _ in 0..a.warmup {
        trainer.iteration()?;
        trainer.sim_only_horizon()?;
        raw_horizon();
    }
    println!(
        "{:>5} {:>12} {:>12} {:>7} {:>12} {:>9} | per sample (ms): {:>7} {:>7} {:>7} {:>7}",
        "round",
        "e2e smp/s",
        "sim smp/s",
        "ratio",
        "raw steps/s",
        "e2e/raw",
        "env",
        "infer",
        "update",
        "total"
    );
    let (mut e2e, mut sim, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    let (mut raw_rate, mut raw_ratio) = (Vec::new(), Vec::new());
    let (mut env_ms, mut inf_ms, mut upd_ms) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..a.rounds {
        let s = trainer.iteration()?;
        let sim_s = trainer.sim_only_horizon()?;
        let rr = raw_horizon();
        let (e, si) = (s.samples_per_s, batch / sim_s);
        let per = |x: f64| 1e3 * x / batch;
        println!(
            "{:>5} {:>12.0} {:>12.0} {:>7.3} {:>12.0} {:>9.3} | {:>24.4} {:>7.4} {:>7.4} {:>7.4}",
            r + 1,
            e,
            si,
            e / si,
            rr,
            e / rr,
            per(s.env_s),
            per(s.inference_s),
            per(s.update_s),
            per(s.rollout_s + s.update_s)
        );
        e2e.push(e);
        sim.push(si);
        ratio.push(e / si);
        raw_rate.push(rr);
        raw_ratio.push(e / rr);
        env_ms.push(per(s.env_s));
        inf_ms.push(per(s.inference_s));
        upd_ms.push(per(s.update_s));
    }
    println!(
        "median: end-to-end {:.0} samples/s, simulation-only {:.0} samples/s, ratio {:.3}; per \
            sample env {:.4} ms, inference {:.4} ms, update {:.4} ms",
        median(&mut e2e),
        median(&mut sim),
        median(&mut ratio),
        median(&mut env_ms),
        median(&mut inf_ms),
        median(&mut upd_ms)
    );
    println!(
        "raw mj_step anchor ({threads} threads, {n} envs): {:.0} policy steps/s; end-to-end / raw \
            {:.3}",
        median(&mut raw_rate),
        median(&mut raw_ratio)
    );
    let rss = std::fs::read_to_string("/proc/self/status").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("VmRSS:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
    });
    println!(
        "memory per environment: MjData {:.0} KB allocated (mostly the `<size memory>` arena, \
            resident only where touched); process resident {} (learner, rollout storage and the \
            anchor's second set of MjData included)",
        raw.data_bytes() as f64 / 1e3,
        rss.map_or("unknown".into(), |kb| format!("{:.0} KB", kb * 1.024 / n as f64))
    );
    Ok(())
}
