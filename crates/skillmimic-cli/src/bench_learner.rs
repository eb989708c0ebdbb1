//! `skillmimic bench infer|update`: the learner's network against PyTorch, same run.
//!
//! Ours and PyTorch's timings are taken in interleaved rounds (a persistent PyTorch worker
//! process answers one measurement at a time), and medians are compared. The ratio printed is
//! PyTorch time / our time (≥ 1: we are at least as fast).

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Instant;

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use skillmimic_learn::adam::Adam;
use skillmimic_learn::config::PpoConfig;
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_learn::ppo::{RawMinibatch, UpdateBuffers, update_minibatch};

use crate::common::init_learner_threads;

#[derive(clap::Args, Clone)]
pub struct NetArgs {
    /// Batch sizes to measure (default: 64,2048 for infer, 4096,16384 for update).
    #[arg(long, value_delimiter = ',')]
    pub batch: Vec<usize>,
    /// Hidden layer widths.
    #[arg(long, value_delimiter = ',', default_value = "1024,512,512")]
    pub hidden: Vec<usize>,
    /// Threads for both sides (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Interleaved rounds.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Skip the PyTorch comparison.
    #[arg(long)]
    pub no_torch: bool,
}

const TORCH_SCRIPT: &str = include_str!("../../../python/skillmimic_rs/bench_torch.py");
const OBS: usize = 902;
const ACT: usize = 156;

/// A persistent PyTorch worker.
pub struct TorchWorker {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    pub version: String,
}

fn python_candidates() -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    if let Some(p) = std::env::var_os("SKILLMIMIC_PYTHON") {
        v.push(p.into());
    }
    v.push(".venv/bin/python".into());
    v.push(skillmimic_core::shared_data::workspace_root().join(".venv/bin/python"));
    v.push("python3".into());
    v
}

impl TorchWorker {
    /// Start a worker if a Python with PyTorch is found.
    pub fn start(hidden: &[usize], threads: usize) -> Option<Self> {
        for py in python_candidates() {
            let ok = Command::new(&py)
                .args(["-c", "import torch"])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
            if !ok {
                continue;
            }
            let mut child = Command::new(&py)
                .args(["-c", TORCH_SCRIPT])
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .spawn()
                .ok()?;
            let stdin = child.stdin.take()?;
            let stdout = BufReader::new(child.stdout.take()?);
            let mut w = Self { child, stdin, stdout, version: String::new() };
            let r = w.ask(&serde_json::json!({
                "op": "setup", "obs_dim": OBS, "act_dim": ACT, "hidden": hidden, "threads": threads
            }))?;
            w.version =
                format!("torch {} ({} threads)", r["torch"].as_str().unwrap_or("?"), r["threads"]);
            return Some(w);
        }
        None
    }

    fn ask(&mut self, cmd: &serde_json::Value) -> Option<serde_json::Value> {
        writeln!(self.stdin, "{cmd}").ok()?;
        self.stdin.flush().ok()?;
        let mut line = String::new();
        self.stdout.read_line(&mut line).ok()?;
        serde_json::from_str(&line).ok()
    }

    /// Median seconds of `reps` calls of `op` at `batch`.
    pub fn time(&mut self, op: &str, batch: usize, reps: usize) -> Option<f64> {
        self.ask(&serde_json::json!({"op": op, "batch": batch, "reps": reps}))?["seconds"].as_f64()
    }
}

impl Drop for TorchWorker {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "{{\"op\": \"quit\"}}");
        let _ = self.child.wait();
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Our side of the benchmark.
pub struct Ours {
    policy: Policy,
    adam: Adam,
    buf: InferenceBuffers,
    cfg: PpoConfig,
}

impl Ours {
    pub fn new(hidden: &[usize]) -> Self {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let cfg = PpoConfig { hidden: hidden.to_vec(), ..Default::default() };
        let policy = Policy::new(OBS, ACT, &cfg, &mut rng);
        let sizes: Vec<usize> = policy
            .actor
            .params()
            .iter()
            .chain(policy.critic.params().iter())
            .map(|p| p.len())
            .collect();
        Self {
            adam: Adam::new(&sizes, cfg.lr, cfg.adam_eps),
            policy,
            buf: InferenceBuffers::default(),
            cfg,
        }
    }

    /// Median seconds of batched inference (normalisation, actor, critic).
    pub fn infer(&mut self, batch: usize, reps: usize, threads: usize) -> f64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let obs: Vec<f32> = (0..batch * OBS).map(|_| StandardNormal.sample(&mut rng)).collect();
        let (mut mu, mut v) = (vec![0.0; batch * ACT], vec![0.0; batch]);
        let mut times = Vec::new();
        for _ in 0..=reps {
            let t = Instant::now();
            self.policy.infer(&obs, batch, &mut self.buf, &mut mu, &mut v, threads);
            times.push(t.elapsed().as_secs_f64());
        }
        median(times[1..].to_vec())
    }

    /// Median seconds of one PPO minibatch update.
    pub fn update(&mut self, batch: usize, reps: usize, threads: usize) -> f64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let mut normal = |n: usize, s: f32| -> Vec<f32> {
            (0..n)
                .map(|_| {
                    let z: f32 = StandardNormal.sample(&mut rng);
                    s * z
                })
                .collect()
        };
        let obs = normal(batch * OBS, 1.0);
        let act = normal(batch * ACT, 0.1);
        let konst = 0.5 * ACT as f32 * (2.0 * std::f32::consts::PI).ln();
        let old: Vec<f32> = normal(batch, 1.0).into_iter().map(|x| x + konst).collect();
        let adv = normal(batch, 1.0);
        let ret = normal(batch, 1.0);
        let mut buf = UpdateBuffers::default();
        let mut times = Vec::new();
        for _ in 0..=reps {
            let mb = RawMinibatch {
                n: batch,
                obs: &obs,
                actions: &act,
                old_neglogp: &old,
                advantages: &adv,
                returns_n: &ret,
            };
            let t = Instant::now();
            update_minibatch(
                &mut self.policy,
                &mut self.adam,
                &mb,
                mb.n,
                &mut buf,
                &self.cfg,
                threads,
                &mut skillmimic_learn::collective::Single,
            )
            .expect("update");
            times.push(t.elapsed().as_secs_f64());
        }
        median(times[1..].to_vec())
    }
}

/// Run `op` ("infer" or "update") for the given batches and print ours vs PyTorch.
pub fn run(op: &str, a: NetArgs) -> anyhow::Result<()> {
    let threads = if a.threads == 0 {
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    } else {
        a.threads
    };
    init_learner_threads(threads);
    let batches = if a.batch.is_empty() {
        if op == "infer" { vec![64, 2048] } else { vec![4096, 16384] }
    } else {
        a.batch.clone()
    };
    let mut torch = if a.no_torch { None } else { TorchWorker::start(&a.hidden, threads) };
    println!(
        "bench {op}: obs {OBS} -> {:?} -> {ACT} (actor) / 1 (critic), {threads} threads, {} \
            interleaved rounds, medians",
        a.hidden, a.rounds
    );
    match &torch {
        Some(t) => println!("PyTorch: {}", t.version),
        None => println!(
            "PyTorch: not importable (set SKILLMIMIC_PYTHON to a Python with torch) - ours only"
        ),
    }
    println!("{:>8} {:>14} {:>14} {:>22}", "batch", "ours [ms]", "torch [ms]", "ratio torch/ours");
    let mut ours = Ours::new(&a.hidden);
    for &b in &batches {
        let reps = if op == "infer" { 10 } else { 1 };
        let (mut o, mut t) = (Vec::new(), Vec::new());
        for _ in 0..a.rounds {
            o.push(if op == "infer" {
                ours.infer(b, reps, threads)
            } else {
                ours.update(b, reps, threads)
            });
            if let Some(w) = torch.as_mut()
                && let Some(s) = w.time(op, b, reps)
            {
                t.push(s);
            }
        }
        let mo = median(o) * 1e3;
        if t.is_empty() {
            println!("{b:>8} {mo:>14.2} {:>14} {:>22}", "-", "-");
        } else {
            let mt = median(t) * 1e3;
            println!("{b:>8} {mo:>14.2} {mt:>14.2} {:>21.2}x", mt / mo);
        }
    }
    Ok(())
}
