//! An in-process mutation fuzzer for skillmimic-rs's readers, runnable on stable Rust.
//!
//! Each [`targets::Target`] starts from seed inputs generated from valid files; every execution
//! picks a corpus entry, applies 1–4 mutations ([`mutate`]: raw bytes, zip-inner pickle/storage
//! bytes re-zipped with valid CRCs, hostile pickle runs, safetensors header numbers, TOML values),
//! writes the input to a file and runs the target under `catch_unwind` with a silenced panic hook
//! (restored afterwards). Findings: a panic, an input that takes longer than the time limit, or a
//! single allocation above [`ALLOC_LIMIT`] (counted by this crate's global allocator). A watchdog
//! thread ends the process (exit code 3) if one input runs for ten time limits (a hang), after
//! saving it. Findings are printed and their inputs saved to the findings folder. Inputs whose
//! error text is of a kind not seen before (digits removed) join the corpus, a cheap stand-in for
//! coverage feedback.

pub mod mutate;
pub mod targets;

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};

pub use targets::Target;

/// Largest single allocation an input may cause before it counts as a finding (256 MiB).
pub const ALLOC_LIMIT: usize = 256 << 20;

/// The system allocator, recording the largest single request since the last reset.
pub struct CountingAlloc;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

/// Settings of one fuzzing run.
#[derive(Clone, Debug)]
pub struct Options {
    pub target: Target,
    /// Wall-clock budget.
    pub duration: Duration,
    pub seed: u64,
    /// An input running longer than this is a finding (a hang after ten times as long).
    pub time_limit: Duration,
    /// Where findings are saved.
    pub findings_dir: PathBuf,
    /// Print progress every this many seconds (0: never).
    pub progress_every: u64,
}

/// What a run found.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub executions: u64,
    /// Inputs the target accepted.
    pub accepted: u64,
    /// Distinct kinds of error text seen.
    pub error_kinds: usize,
    pub corpus: usize,
    /// One line per finding (the saved input's path and what happened).
    pub findings: Vec<String>,
    pub seconds: f64,
}

/// The error text with digits removed, cut to 80 characters: one "kind" of refusal.
fn error_kind(e: &str) -> String {
    e.chars().filter(|c| !c.is_ascii_digit()).take(80).collect()
}

fn save(dir: &Path, target: Target, n: usize, input: &[u8]) -> PathBuf {
    let _ = std::fs::create_dir_all(dir);
    let p = dir.join(format!("{}-{n}-{}", target.name(), std::process::id()));
    let _ = std::fs::write(&p, input);
    p
}

/// Serialises runs in one process: the panic hook is process-wide.
static RUN_LOCK: Mutex<()> = Mutex::new(());

/// Fuzz `opts.target` for `opts.duration`.
pub fn run(opts: &Options) -> Report {
    let _guard = RUN_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let work = std::env::temp_dir().join(format!(
        "skillmimic-fuzz-{}-{}",
        opts.target.name(),
        std::process::id()
    ));
    std::fs::create_dir_all(&work).expect("fuzz work folder");
    let input_path = work.join(opts.target.file_name());
    let mut corpus = opts.target.seeds(&work);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let mut kinds = HashSet::new();
    let mut report = Report::default();

    // watchdog: an input running for ten time limits is a hang; save it and end the process
    let started_ms = Arc::new(AtomicU64::new(0));
    let done = Arc::new(AtomicBool::new(false));
    let t0 = Instant::now();
    let watchdog = {
        let (started_ms, done) = (started_ms.clone(), done.clone());
        let (input_path, dir, target, hang) =
            (input_path.clone(), opts.findings_dir.clone(), opts.target, opts.time_limit * 10);
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                let s = started_ms.load(Ordering::Relaxed);
                if s > 0 && t0.elapsed().as_millis() as u64 > s + hang.as_millis() as u64 {
                    let input = std::fs::read(&input_path).unwrap_or_default();
                    let p = save(&dir, target, 0, &input);
                    eprintln!(
                        "FINDING [{}] hang: an input ran longer than {hang:?}; saved to {}",
                        target.name(),
                        p.display()
                    );
                    std::process::exit(3);
                }
            }
        })
    };

    let previous_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut last_progress = Instant::now();
    while t0.elapsed() < opts.duration {
        let a = rng.random_range(0..corpus.len());
        let b = rng.random_range(0..corpus.len());
        let mut input = corpus[a].clone();
        for _ in 0..rng.random_range(1..=4) {
            let structured = match rng.random_range(0..4) {
                0 | 1 => mutate::zip_inner(&mut rng, &input, &corpus[b]),
                2 => mutate::safetensors_header(&mut rng, &input),
                _ => None,
            };
            match structured {
                Some(m) => input = m,
                None if opts.target == Target::Config && rng.random_bool(0.5) => {
                    if let Some(t) = std::str::from_utf8(&input)
                        .ok()
                        .and_then(|t| mutate::replace_value(&mut rng, t))
                    {
                        input = t.into_bytes();
                    }
                }
                None => mutate::raw(&mut rng, &mut input, &corpus[b]),
            }
        }
        std::fs::write(&input_path, &input).expect("write fuzz input");
        LARGEST.store(0, Ordering::Relaxed);
        started_ms.store(t0.elapsed().as_millis() as u64 + 1, Ordering::Relaxed);
        let t = Instant::now();
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| opts.target.run(&input_path)));
        let took = t.elapsed();
        started_ms.store(0, Ordering::Relaxed);
        let largest = LARGEST.load(Ordering::Relaxed);
        report.executions += 1;
        let problem = match &outcome {
            Err(p) => Some(format!("panic: {}", skillmimic_core::panic_message(&**p))),
            Ok(_) if took > opts.time_limit => {
                Some(format!("slow: {took:?} (limit {:?})", opts.time_limit))
            }
            Ok(_) if largest > ALLOC_LIMIT => Some(format!("allocation of {largest} bytes")),
            Ok(_) => None,
        };
        if let Some(what) = problem {
            let p = save(&opts.findings_dir, opts.target, report.findings.len() + 1, &input);
            let line = format!("[{}] {what}; input saved to {}", opts.target.name(), p.display());
            eprintln!("FINDING {line}");
            report.findings.push(line);
        } else if let Ok(result) = outcome {
            match result {
                Ok(()) => report.accepted += 1,
                Err(e) => {
                    if kinds.insert(error_kind(&e)) && corpus.len() < 512 {
                        corpus.push(input);
                    }
                }
            }
        }
        if opts.progress_every > 0 && last_progress.elapsed().as_secs() >= opts.progress_every {
            last_progress = Instant::now();
            eprintln!(
                "[{}] {} executions, {} error kinds, corpus {}, {} findings",
                opts.target.name(),
                report.executions,
                kinds.len(),
                corpus.len(),
                report.findings.len()
            );
        }
    }
    std::panic::set_hook(previous_hook);
    done.store(true, Ordering::Relaxed);
    let _ = watchdog.join();
    let _ = std::fs::remove_dir_all(&work);
    report.error_kinds = kinds.len();
    report.corpus = corpus.len();
    report.seconds = t0.elapsed().as_secs_f64();
    report
}
