//! `skillmimic bench train`: end-to-end training throughput (environments + inference + PPO
//! update) against the simulation-only throughput of the same environments, in the same run.
//!
//! Each measured round runs one training iteration and then one horizon of simulation only
//! (the same environments replaying the iteration's actions, resets included), so both
//! numbers see the same machine state. Ratio = end-to-end samples/s ÷ simulation-only
//! samples/s (1.0 would mean learning is free).

use skillmimic_learn::trainer::Trainer;

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
    println!(
        "bench train: preset '{}', {} envs x horizon {} = {} samples/iteration, network {:?}, minibatch {}, {} mini-epochs, backend {:?}, {} hands",
        a.base.preset,
        cfg.env.num_envs,
        cfg.ppo.horizon,
        cfg.batch_size(),
        cfg.ppo.hidden,
        cfg.ppo.minibatch,
        cfg.ppo.mini_epochs,
        cfg.ppo.backend,
        cfg.env.hands
    );
    for _ in 0..a.warmup {
        trainer.iteration()?;
        trainer.sim_only_horizon()?;
    }
    println!(
        "{:>5} {:>12} {:>12} {:>7} | per sample (ms): {:>7} {:>7} {:>7} {:>7}",
        "round", "e2e smp/s", "sim smp/s", "ratio", "env", "infer", "update", "total"
    );
    let (mut e2e, mut sim, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    let (mut env_ms, mut inf_ms, mut upd_ms) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..a.rounds {
        let s = trainer.iteration()?;
        let sim_s = trainer.sim_only_horizon()?;
        let (e, si) = (s.samples_per_s, batch / sim_s);
        let per = |x: f64| 1e3 * x / batch;
        println!(
            "{:>5} {:>12.0} {:>12.0} {:>7.3} | {:>24.4} {:>7.4} {:>7.4} {:>7.4}",
            r + 1,
            e,
            si,
            e / si,
            per(s.env_s),
            per(s.inference_s),
            per(s.update_s),
            per(s.rollout_s + s.update_s)
        );
        e2e.push(e);
        sim.push(si);
        ratio.push(e / si);
        env_ms.push(per(s.env_s));
        inf_ms.push(per(s.inference_s));
        upd_ms.push(per(s.update_s));
    }
    println!(
        "median: end-to-end {:.0} samples/s, simulation-only {:.0} samples/s, ratio {:.3}; per sample env {:.4} ms, inference {:.4} ms, update {:.4} ms",
        median(&mut e2e),
        median(&mut sim),
        median(&mut ratio),
        median(&mut env_ms),
        median(&mut inf_ms),
        median(&mut upd_ms)
    );
    Ok(())
}
