//! A training run killed with SIGKILL at random moments and restarted each time with
//! `--resume latest` ends exactly as the run that was never stopped: the same `log.jsonl` rows
//! (all but the timings) and byte-identical checkpoints. For each task family: imitation, with
//! the SkillMimic-V2 parts (STF, STG, ATS) and the motion prior, a high-level task (driven by the
//! imitation run's checkpoint as its skill policy), tracking on the SMPL humanoid and the TokenHSI
//! multi-task environment with the token policy. The kill moments are drawn from a fixed
//! seed, between 25 % and 50 % of the uninterrupted run's wall time after each start, so they
//! fall all over the run (start-up, rollouts, updates, checkpoint writes — a checkpoint is
//! written after every iteration — and the end-of-run evaluation). A start killed before it wrote
//! a new checkpoint doubles the window of the next start (and so on), so that a start-up slower
//! than usual — a busy CI machine — cannot keep the run from finishing, and a killed run whose
//! first restart finished before its kill moment (the machine got faster than when the reference
//! run was timed) is redone with half the window; the test prints how many kills
//! interrupted an atomic write (a `*.tmp<pid>` file left behind). The first kill of each family
//! always lands inside a checkpoint write: that start runs with the writer's test pause
//! (`SKILLMIMIC_TEST_WRITE_PAUSE_MS`, halfway through the file) and is killed as soon as the
//! temporary file of a randomly chosen checkpoint of the first half of the run (an `iter_*` file or
//! `latest`) appears. A finished run re-entered with `--resume latest` only finishes.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use rand::{Rng, SeedableRng};

const ITERATIONS: u64 = 8;

fn train(out: &Path, extra: &[String]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_skillmimic"));
    cmd.args(["train", "--preset", "tiny", "--no-video", "--threads", "2", "--out"])
        .arg(out)
        .args(["--iterations", &ITERATIONS.to_string(), "--resume", "latest"])
        .args(["--set", "run.save_every=1", "--set", "run.eval_episodes=2"])
        .args(extra)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped());
    cmd
}

fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

/// The log rows without their timings.
fn rows(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("log.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().retain(|k, _| !(k.ends_with("_s") || k == "samples_per_s"));
            v
        })
        .collect()
}

fn temp_files(out: &Path) -> usize {
    [out.to_path_buf(), out.join("checkpoints")]
        .iter()
        .filter_map(|d| std::fs::read_dir(d).ok())
        .flatten()
        .filter(|e| e.as_ref().is_ok_and(|e| e.file_name().to_string_lossy().contains(".tmp")))
        .count()
}

/// How many `iter_*` checkpoints of the run are whole on disk (its progress).
fn checkpoints(out: &Path) -> usize {
    std::fs::read_dir(out.join("checkpoints"))
        .map(|d| {
            d.filter(|e| {
                e.as_ref().is_ok_and(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    name.starts_with("iter_") && name.ends_with(".safetensors")
                })
            })
            .count()
        })
        .unwrap_or(0)
}

#[test]
fn runs_killed_at_random_moments_end_as_the_uninterrupted_runs() {
    let base = std::env::temp_dir().join(format!("sm-kill-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(44);
    killed_run_matches(&base.join("imitation"), &[], &mut rng);
    let llc = base.join("imitation/reference/latest.safetensors");
    let token = [
        "--set",
        "ppo.token.tokenizer=[32]",
        "--set",
        "ppo.token.embed=16",
        "--set",
        "ppo.token.layers=1",
        "--set",
        "ppo.token.feedforward=32",
        "--set",
        "ppo.token.head=[32]",
    ];
    let cases: Vec<(&str, Vec<String>)> = vec![
        (
            "v2_amp",
            args(&[
                "--set",
                "env.v2.stf.enabled=true",
                "--set",
                "env.v2.stg.enabled=true",
                "--set",
                "env.v2.ats.enabled=true",
                "--set",
                "env.v2.ats.update_interval=5",
                "--set",
                "ppo.amp.enabled=true",
                "--set",
                "ppo.amp.hidden=[32]",
                "--set",
                "ppo.amp.batch=32",
                "--set",
                "ppo.amp.buffer=128",
            ]),
        ),
        (
            "heading",
            [args(&["--task", "heading", "--llc"]), vec![llc.display().to_string()]].concat(),
        ),
        ("tracking", args(&["--task", "tracking", "--set", "env.character=\"smpl\""])),
        (
            "hsi_multi",
            [args(&["--task", "hsi_multi", "--policy", "token_transformer"]), args(&token)]
                .concat(),
        ),
    ];
    for (tag, extra) in cases {
        killed_run_matches(&base.join(tag), &extra, &mut rng);
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// Start the run with the checkpoint writer's test pause and kill it inside the write of a
/// checkpoint drawn from `rng` (iterations 1 to half the run, so that the random kills after it
/// find a run to interrupt; its `iter_*` file or `latest`):
/// the partial temporary file is left behind and `latest.safetensors` is still whole.
fn kill_inside_a_write(out: &Path, extra: &[String], rng: &mut rand_chacha::ChaCha8Rng) {
    let k = rng.random_range(1..=ITERATIONS / 2);
    let file = if rng.random_bool(0.5) {
        out.join(format!("checkpoints/iter_{k:06}.safetensors"))
    } else {
        out.join("latest.safetensors")
    };
    let mut child = train(out, extra).env("SKILLMIMIC_TEST_WRITE_PAUSE_MS", "500").spawn().unwrap();
    let tmp = PathBuf::from(format!("{}.tmp{}", file.display(), child.id()));
    let t0 = std::time::Instant::now();
    // `latest` is written at every iteration: wait for iteration k's, after iter_k's file
    let ready = || match file.ends_with("latest.safetensors") {
        true => out.join(format!("checkpoints/iter_{k:06}.safetensors")).exists(),
        false => true,
    };
    while !(ready() && tmp.exists()) {
        assert!(child.try_wait().unwrap().is_none(), "{}: ended before the write", out.display());
        assert!(t0.elapsed() < Duration::from_secs(600), "{}: no write", out.display());
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(tmp.exists(), "{}: the partial file is gone", tmp.display());
    let latest = out.join("latest.safetensors");
    if latest.exists() {
        skillmimic_core::tensorfile::TensorFile::open(&latest).expect("latest is whole");
    }
    println!("{}: killed inside the write of {}", out.display(), file.display());
}

/// Train in `base/run` in one go (kept as `base/reference`), then again killed at random
/// moments from `rng` and resumed until it finishes; compare.
fn killed_run_matches(base: &Path, extra: &[String], rng: &mut rand_chacha::ChaCha8Rng) {
    // both runs use the same folder name, so that the configuration inside the checkpoints agrees
    let out: PathBuf = base.join("run");
    let t0 = std::time::Instant::now();
    let o = train(&out, extra).output().unwrap();
    // kill moments scale with the run's length (start-up differs a lot between tasks)
    let ms = t0.elapsed().as_millis() as u64;
    let tag = base.display().to_string();
    assert!(o.status.success(), "{tag}: {}", String::from_utf8_lossy(&o.stderr));
    let want_rows = rows(&out);
    let last = format!("checkpoints/iter_{ITERATIONS:06}.safetensors");
    let want = std::fs::read(out.join(&last)).unwrap();
    let want_latest = std::fs::read(out.join("latest.safetensors")).unwrap();
    assert_eq!(want, want_latest);
    std::fs::rename(&out, base.join("reference")).unwrap();

    // On a shared machine a later start can run much faster than the timed reference run did, so
    // that the first resumed start finishes before its kill moment (no kill at a random moment):
    // then the killed run is redone from scratch with half the window, at most five times.
    let mut window_ms = ms;
    let (kills, in_writes) = loop {
        kill_inside_a_write(&out, extra, rng);
        let (kills, in_writes) = kill_at_random_moments(&out, extra, rng, window_ms, &tag);
        if kills >= 2 || window_ms <= ms / 16 {
            break (kills, in_writes);
        }
        println!("{tag}: finished before a random kill; again with half the window");
        std::fs::remove_dir_all(&out).unwrap();
        window_ms /= 2;
    };
    println!("{tag}: {kills} kills, {in_writes} of them during an atomic write");
    assert!(kills >= 2, "{tag}: no kill at a random moment: the run was barely interrupted");
    let got_rows = rows(&out);
    assert_eq!(got_rows.len(), want_rows.len());
    for (k, (a, b)) in want_rows.iter().zip(&got_rows).enumerate() {
        assert_eq!(a, b, "{tag}: log row {} differs after {kills} kills", k + 1);
    }
    assert!(std::fs::read(out.join(&last)).unwrap() == want, "{tag}: the last checkpoint differs");
    assert!(std::fs::read(out.join("latest.safetensors")).unwrap() == want);
    for k in 1..ITERATIONS {
        let p = format!("checkpoints/iter_{k:06}.safetensors");
        let a = std::fs::read(base.join("reference").join(&p)).unwrap();
        assert!(std::fs::read(out.join(&p)).unwrap() == a, "{tag}: {p} differs");
    }
}

/// Start the run after its kill inside a write, again and again, each start killed at a random
/// moment between `ms / 4` and `ms / 2` after it (`ms`: the reference run's wall time), until a
/// start finishes. Returns the kills (the one inside a write included) and how many of them
/// left a temporary file behind.
fn kill_at_random_moments(
    out: &Path,
    extra: &[String],
    rng: &mut rand_chacha::ChaCha8Rng,
    ms: u64,
    tag: &str,
) -> (usize, usize) {
    let (mut kills, mut in_writes, mut stretch) = (1, 1, 1);
    for attempt in 0.. {
        assert!(attempt < 100, "{tag}: the killed run did not finish in 100 attempts");
        let before = checkpoints(out);
        let mut child = train(out, extra).spawn().unwrap();
        let wait = Duration::from_millis(rng.random_range(ms / 4..ms / 2) * stretch);
        let t0 = std::time::Instant::now();
        let mut finished = None;
        while t0.elapsed() < wait {
            if let Some(s) = child.try_wait().unwrap() {
                finished = Some(s);
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        match finished {
            Some(s) => {
                let mut err = String::new();
                use std::io::Read;
                child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
                // a start after a kill in the end-of-run work re-enters the finished run and
                // only finishes it (`--resume latest`)
                assert!(s.success(), "{tag}: attempt {attempt}: {err}");
                break;
            }
            None => {
                child.kill().unwrap();
                child.wait().unwrap();
                kills += 1;
                in_writes += usize::from(temp_files(out) > 0);
                // no new checkpoint: give the next start twice the time (a slow start-up)
                stretch = if checkpoints(out) > before { 1 } else { (stretch * 2).min(64) };
            }
        }
    }
    (kills, in_writes)
}

/// `skillmimic train --resume latest` on a finished run (a job restarted after its last
/// checkpoint) trains nothing, says so, evaluates and writes the summary, and exits 0; an
/// explicit checkpoint path of the finished run is refused.
#[test]
fn resume_latest_of_a_finished_run_only_finishes_it() {
    let out = std::env::temp_dir().join(format!("sm-finished-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let first = train(&out, &[]).output().unwrap();
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let log = std::fs::read(out.join("log.jsonl")).unwrap();
    std::fs::remove_file(out.join("summary.json")).unwrap();
    let again = train(&out, &[]).stdout(std::process::Stdio::piped()).output().unwrap();
    let said = String::from_utf8_lossy(&again.stdout);
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    assert!(said.contains(&format!("already complete at {ITERATIONS} iterations")), "{said}");
    assert!(out.join("summary.json").is_file());
    assert_eq!(std::fs::read(out.join("log.jsonl")).unwrap(), log, "nothing trained again");
    let latest = out.join("latest.safetensors");
    let explicit = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .args(["train", "--preset", "tiny", "--no-video", "--threads", "2", "--out"])
        .arg(&out)
        .args(["--iterations", &ITERATIONS.to_string(), "--resume"])
        .arg(&latest)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&explicit.stderr);
    assert!(!explicit.status.success() && err.contains("already complete"), "{err}");
    std::fs::remove_dir_all(&out).ok();
}
