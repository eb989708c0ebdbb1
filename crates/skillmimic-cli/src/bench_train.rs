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
//!
//! `--against PRESET` builds a second trainer from the same config file and flags over another
//! preset and alternates the two within each round (configuration A, configuration B, both
//! against the round's anchor: the first preset's scene and environment count), so that their
//! medians share the machine's state: the speed-up of a preset is measured, not inferred from
//! two separate runs.

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
    /// Also measure this preset, with the same config file and flags, in alternating rounds
    /// (e.g. `--preset cpu --against small`): each preset's rates and end-to-end / raw ratio
    /// against the same anchor rounds, and the speed-up between them.
    #[arg(long)]
    pub against: Option<String>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// One configuration under measurement: its trainer and the per-round numbers.
struct Measured {
    label: String,
    trainer: Trainer,
    batch: f64,
    e2e: Vec<f64>,
    sim: Vec<f64>,
    raw_ratio: Vec<f64>,
    env_ms: Vec<f64>,
    inf_ms: Vec<f64>,
    upd_ms: Vec<f64>,
}

impl Measured {
    fn new(label: &str, cfg: &skillmimic_learn::config::TrainConfig) -> anyhow::Result<Self> {
        let trainer = Trainer::new(cfg.clone(), None)?;
        println!(
            "bench train: preset '{label}', {} envs x horizon {} = {} samples/iteration, network \
                {:?}, minibatch {}, {} mini-epochs, lr {:e}, backend {:?}, precision {:?} (runs in \
                {}), {} hands",
            cfg.env.num_envs,
            cfg.ppo.horizon,
            cfg.batch_size(),
            cfg.ppo.hidden,
            cfg.ppo.minibatch,
            cfg.ppo.mini_epochs,
            cfg.ppo.lr,
            cfg.ppo.backend,
            cfg.ppo.precision,
            trainer.update_precision(),
            cfg.env.hands
        );
        Ok(Self {
            label: label.into(),
            trainer,
            batch: cfg.batch_size() as f64,
            e2e: Vec::new(),
            sim: Vec::new(),
            raw_ratio: Vec::new(),
            env_ms: Vec::new(),
            inf_ms: Vec::new(),
            upd_ms: Vec::new(),
        })
    }

    /// One training iteration and one simulation-only horizon; `raw` (policy steps/s of the
    /// anchor in this round) is `None` during the warm-up, which records nothing.
    fn round(&mut self, r: usize, raw: Option<f64>) -> anyhow::Result<()> {
        let s = self.trainer.iteration()?;
        let sim_s = self.trainer.sim_only_horizon()?;
        let Some(rr) = raw else { return Ok(()) };
        let (e, si) = (s.samples_per_s, self.batch / sim_s);
        let per = |x: f64| 1e3 * x / self.batch;
        println!(
            "{:>5} {:>12.0} {:>12.0} {:>7.3} {:>12.0} {:>9.3} | {:>24.4} {:>7.4} {:>7.4} {:>7.4} {}",
            r + 1,
            e,
            si,
            e / si,
            rr,
            e / rr,
            per(s.env_s),
            per(s.inference_s),
            per(s.update_s),
            per(s.rollout_s + s.update_s),
            self.label
        );
        self.e2e.push(e);
        self.sim.push(si);
        self.raw_ratio.push(e / rr);
        self.env_ms.push(per(s.env_s));
        self.inf_ms.push(per(s.inference_s));
        self.upd_ms.push(per(s.update_s));
        Ok(())
    }

    /// The medians: the `median:` line (and the end-to-end / raw ratio for the anchor line).
    fn report(&mut self, prefix: &str) -> (f64, f64) {
        let e2e = median(&mut self.e2e);
        let mut ratio: Vec<f64> = self.e2e.iter().zip(&self.sim).map(|(e, s)| e / s).collect();
        println!(
            "{prefix}median: end-to-end {e2e:.0} samples/s, simulation-only {:.0} samples/s, ratio \
                {:.3}; per sample env {:.4} ms, inference {:.4} ms, update {:.4} ms",
            median(&mut self.sim),
            median(&mut ratio),
            median(&mut self.env_ms),
            median(&mut self.inf_ms),
            median(&mut self.upd_ms)
        );
        (e2e, median(&mut self.raw_ratio))
    }
}

pub fn run(a: TrainArgs) -> anyhow::Result<()> {
    let mut cfg = a.base.assemble()?;
    cfg.run.learner_threads = a.learner_threads;
    init_learner_threads(a.learner_threads);
    let mut runs = vec![Measured::new(&a.base.preset, &cfg)?];
    if let Some(other) = &a.against {
        let mut b = PresetArgs { preset: other.clone(), ..a.base.clone() }.assemble()?;
        b.run.learner_threads = a.learner_threads;
        runs.push(Measured::new(other, &b)?);
    }
    // the raw mj_step anchor: the same scene, environments and simulation threads
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&cfg.env)?)?);
    let n = cfg.env.num_envs;
    let threads = match skillmimic_env::config_range::capped_threads(cfg.env.threads, "env.threads")
    {
        0 => std::thread::available_parallelism().map_or(1, |c| c.get()),
        t => t,
    };
    let init = BatchSim::new(Arc::clone(&scene), n, 1)?;
    let mut raw = RawLoop::new(&scene, n, Some(threads))?;
    let work = Workload::new(n, cfg.ppo.horizon);
    let batch = (n * cfg.ppo.horizon) as f64;
    let mut raw_horizon = || {
        raw.reset_from(&init);
        let t0 = Instant::now();
        for k in 0..work.steps() {
            raw.step(&scene, work.step_actions(k));
        }
        batch / t0.elapsed().as_secs_f64()
    };
    for _ in 0..a.warmup {
        for m in runs.iter_mut() {
            m.round(0, None)?;
        }
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
    // rounds alternate the configurations, each round with its own anchor measurement
    let mut raw_rate = Vec::new();
    for r in 0..a.rounds {
        let rr = raw_horizon();
        raw_rate.push(rr);
        for m in runs.iter_mut() {
            m.round(r, Some(rr))?;
        }
    }
    let raw_median = median(&mut raw_rate);
    let mut rates = Vec::new();
    for m in runs.iter_mut() {
        let prefix = if a.against.is_some() { format!("{}: ", m.label) } else { String::new() };
        let (e2e, raw_ratio) = m.report(&prefix);
        println!(
            "{prefix}raw mj_step anchor ({threads} threads, {n} envs): {raw_median:.0} policy \
                steps/s; end-to-end / raw {raw_ratio:.3}"
        );
        rates.push(e2e);
    }
    if let [a_rate, b_rate] = rates[..] {
        println!(
            "speed-up: preset '{}' trains {:.2}x the samples/s of preset '{}' (medians of the same \
                rounds)",
            runs[0].label,
            a_rate / b_rate,
            runs[1].label
        );
    }
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
