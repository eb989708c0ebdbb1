//! The run folder across a `kill -9` and a resume, and resuming a finished run. A child process
//! (this test binary again, running only `child_trains_until_killed`) trains on the shipped demo
//! clips; the parent kills it with SIGKILL once it saved a checkpoint and logged iterations past
//! it, then resumes in-process and checks the folder: no temporary files, every iteration once in
//! `log.jsonl`, every TensorBoard step once. A finished run resumed from an explicit checkpoint
//! is refused; re-entered with `--resume latest` (a restarted job) it only finishes.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use skillmimic_core::shared_data::workspace_root;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::runner::{Runner, train_loop};
use skillmimic_learn::tblog;
use skillmimic_learn::trainer::Trainer;

const CHILD_ENV: &str = "SKILLMIMIC_TEST_KILL_CHILD_OUT";

fn tiny(out: &Path, iterations: usize, save_every: usize) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 1;
    c.run.learner_threads = 1;
    c.run.iterations = iterations;
    c.run.save_every = save_every;
    c.run.out_dir = out.to_path_buf();
    c
}

fn fresh_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sm-runfolder-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Iteration numbers of `log.jsonl`, in order.
fn logged_iterations(out: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(out.join("log.jsonl")).unwrap_or_default();
    text.lines()
        .filter_map(|l| {
            serde_json::from_str::<serde_json::Value>(l).ok()?.get("iteration")?.as_u64()
        })
        .collect()
}

/// Every file below `dir` (recursive).
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() { v.extend(files(&p)) } else { v.push(p) }
    }
    v
}

/// Not a test of its own: the child process of `kill_9_then_resume_leaves_a_clean_folder`
/// (does nothing unless the parent set `CHILD_ENV`). Trains far longer than it is let live.
#[test]
fn child_trains_until_killed() {
    let Some(out) = std::env::var_os(CHILD_ENV) else { return };
    let mut t = Trainer::new(tiny(Path::new(&out), 10_000, 2), None).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
}

#[test]
fn kill_9_then_resume_leaves_a_clean_folder() {
    let out = fresh_dir("kill");
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child_trains_until_killed", "--nocapture", "--test-threads=1"])
        .env(CHILD_ENV, &out)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // wait for a checkpoint (iteration 2) and at least one logged iteration past it
    let t0 = Instant::now();
    while !(out.join("latest.safetensors").is_file() && logged_iterations(&out).len() >= 3) {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the training child exited early: {status}");
        }
        assert!(
            t0.elapsed() < Duration::from_secs(300),
            "the child did not reach iteration 3 in 300 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = child.id();
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let before = logged_iterations(&out);
    println!("killed after iterations {before:?}");
    // what a kill during an atomic write leaves: the dead process's temporary checkpoint
    let stale = out.join(format!("checkpoints/iter_{:06}.safetensors.tmp{pid}", before.len() + 1));
    std::fs::write(&stale, vec![0u8; 4096]).unwrap();
    std::fs::write(out.join(format!("latest.safetensors.tmp{pid}")), b"partial").unwrap();

    let latest = out.join("latest.safetensors");
    let start = skillmimic_learn::checkpoint::load(&latest, None).unwrap().progress.iteration;
    assert!(
        start >= 2 && start.is_multiple_of(2) && (start as usize) <= before.len(),
        "checkpoint at {start}, log {before:?}"
    );
    let target = before.len() as u64 + 2;
    let mut t = Trainer::new(tiny(&out, target as usize, 2), Some(&latest)).unwrap();
    train_loop(&mut t, |_| {}).unwrap();

    let temps: Vec<_> = files(&out)
        .into_iter()
        .filter(|p| p.file_name().unwrap().to_str().unwrap().contains(".tmp"))
        .collect();
    assert!(temps.is_empty(), "temporary files left: {temps:?}");
    assert_eq!(
        logged_iterations(&out),
        (1..=target).collect::<Vec<_>>(),
        "each iteration exactly once"
    );
    // TensorBoard: every step once over all event files, one per iteration (step = samples)
    let per_iteration = 8 * 16;
    let mut steps = Vec::new();
    for f in tblog::event_files(&out.join("tb")).unwrap() {
        steps.extend(
            tblog::read_events(&f).unwrap().into_iter().filter(|e| e.has_summary).map(|e| e.step),
        );
    }
    let unique: BTreeSet<i64> = steps.iter().copied().collect();
    assert_eq!(unique.len(), steps.len(), "TensorBoard steps logged twice: {steps:?}");
    assert_eq!(unique, (1..=target as i64).map(|k| k * per_iteration).collect::<BTreeSet<_>>());
    // the log records the simulation's instabilities
    let text = std::fs::read_to_string(out.join("log.jsonl")).unwrap();
    assert!(text.lines().all(|l| l.contains("\"unstable_steps\":")), "{text}");
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn resuming_a_finished_run_says_so() {
    let out = fresh_dir("done");
    let mut t = Trainer::new(tiny(&out, 2, 2), None).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
    let latest = out.join("latest.safetensors");
    let log = std::fs::read(out.join("log.jsonl")).unwrap();
    for iterations in [2, 1] {
        let mut t = Trainer::new(tiny(&out, iterations, 2), Some(&latest)).unwrap();
        let e = train_loop(&mut t, |_| {}).unwrap_err().to_string();
        assert!(
            e.contains("already complete")
                && e.contains("at iteration 2")
                && e.contains(&format!("run.iterations is {iterations}")),
            "{e}"
        );
        assert!(e.contains(&latest.display().to_string()), "{e}");
    }
    assert_eq!(
        std::fs::read(out.join("log.jsonl")).unwrap(),
        log,
        "the refused resume leaves the log alone"
    );
    // one more iteration is fine
    let mut t = Trainer::new(tiny(&out, 3, 2), Some(&latest)).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
    assert_eq!(logged_iterations(&out), vec![1, 2, 3]);
    std::fs::remove_dir_all(&out).ok();
}

/// A job restarted after its last checkpoint but before its end (`torchrun --max-restarts` after
/// a worker died in the evaluation) re-enters with `--resume latest`: nothing is trained or
/// rewritten, the evaluation and `summary.json` are done, and the summary's rewards are the run's.
#[test]
fn a_finished_run_re_entered_with_resume_latest_only_finishes() {
    let out = fresh_dir("reenter");
    let mut first = Runner::new(Trainer::new(tiny(&out, 3, 2), None).unwrap());
    let want = first.run(|_| {}).unwrap().unwrap();
    let latest = out.join("latest.safetensors");
    let (log, ckpt) =
        (std::fs::read(out.join("log.jsonl")).unwrap(), std::fs::read(&latest).unwrap());
    std::fs::remove_file(out.join("summary.json")).unwrap();
    std::fs::remove_file(out.join("metrics.json")).unwrap();
    let mut t = Trainer::new(tiny(&out, 3, 2), Some(&latest)).unwrap();
    t.finish_if_complete = true;
    let got = Runner::new(t).run(|_| panic!("nothing is trained")).unwrap().unwrap();
    assert_eq!(std::fs::read(out.join("log.jsonl")).unwrap(), log, "the log is left alone");
    assert_eq!(std::fs::read(&latest).unwrap(), ckpt, "the checkpoint is left alone");
    assert!(out.join("summary.json").is_file() && out.join("metrics.json").is_file());
    assert_eq!((got.iterations, got.samples), (want.iterations, want.samples));
    assert_eq!(got.samples_per_s, 0.0, "this invocation trained nothing");
    // the same evaluation (deterministic policy, run.seed) and the run's rewards from its log
    let (a, b) = (want.eval.as_ref().unwrap(), got.eval.as_ref().unwrap());
    assert_eq!((a.nr, a.acc_percent), (b.nr, b.acc_percent));
    for (x, y) in [
        (want.first_mean_reward, got.first_mean_reward),
        (want.last_mean_reward, got.last_mean_reward),
        (want.early_mean_reward, got.early_mean_reward),
    ] {
        assert!((x - y).abs() <= 1e-6 * x.abs().max(1e-6), "{x} vs {y}");
    }
    // a run past its end, or an explicit checkpoint, is still refused with the flag's help
    let mut t = Trainer::new(tiny(&out, 2, 2), Some(&latest)).unwrap();
    t.finish_if_complete = true;
    let e = match Runner::new(t).run(|_| {}) {
        Ok(_) => panic!("a run past its end is refused"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("already complete") && e.contains("run.iterations is 2"), "{e}");
    std::fs::remove_dir_all(&out).ok();
}
