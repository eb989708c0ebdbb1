//! `skillmimic train` stopped by Ctrl-C (SIGINT) or a scheduler's SIGTERM ends after the iteration
//! under way with a checkpoint of it, says so, and `--resume latest` then ends exactly as the run
//! that was never stopped (the same log rows but for timings, a byte-identical last checkpoint); a
//! second signal ends the process at once with 128 + its number. The signals are sent while the
//! run is in its training loop, started as a script's background job would be: with SIGINT
//! ignored, which the tool's handlers must override. A closed output pipe ends a command quietly.

use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const ITERATIONS: u64 = 60;

fn train(out: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_skillmimic"));
    cmd.args(["train", "--preset", "tiny", "--no-video", "--threads", "1", "--out"])
        .arg(out)
        .args(["--iterations", &ITERATIONS.to_string(), "--resume", "latest"])
        .args(["--set", "run.save_every=1000", "--set", "run.eval_episodes=2"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    cmd
}

#[allow(dead_code)] // the machine class is the results tests'
mod repro;

/// The log rows without their timings.
fn rows(out: &Path) -> Vec<serde_json::Value> {
    repro::rows(&std::fs::read_to_string(out.join("log.jsonl")).unwrap_or_default())
}

/// How many rows the log has so far (whole lines: the row being written has no newline yet).
fn logged(out: &Path) -> usize {
    std::fs::read_to_string(out.join("log.jsonl")).map_or(0, |t| t.matches('\n').count())
}

/// Start a run with SIGINT ignored (as `cmd &` in a script starts it) and wait until it has
/// logged two iterations.
fn start_and_wait_for_training(mut cmd: Command, out: &Path) -> Child {
    // SAFETY: only async-signal-safe calls between fork and exec
    unsafe {
        cmd.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_IGN);
            Ok(())
        });
    }
    let mut child = cmd.spawn().unwrap();
    let t0 = Instant::now();
    while logged(out) < 2 {
        assert!(child.try_wait().unwrap().is_none(), "{}: ended before training", out.display());
        assert!(t0.elapsed() < Duration::from_secs(300), "{}: no training", out.display());
        std::thread::sleep(Duration::from_millis(2));
    }
    child
}

fn signal(child: &Child, sig: i32) {
    // SAFETY: kill(2) on our own child
    assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
}

fn wait(child: Child, tag: &str) -> (ExitStatus, String) {
    let t0 = Instant::now();
    let o = child.wait_with_output().unwrap();
    assert!(t0.elapsed() < Duration::from_secs(120), "{tag}: took {:?} to stop", t0.elapsed());
    (o.status, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Stop the run in `base/run` with `sig`, check the stop's checkpoint, resume it to the end and
/// compare with `reference` (rows, last checkpoint).
fn stopped_run_resumes_exactly(
    base: &Path,
    sig: i32,
    reference: &(Vec<serde_json::Value>, Vec<u8>),
) {
    let out = base.join("run");
    let tag = format!("signal {sig}");
    let child = start_and_wait_for_training(train(&out), &out);
    signal(&child, sig);
    let (status, stderr) = wait(child, &tag);
    assert_eq!(status.code(), Some(1), "{tag}: {stderr}");
    assert!(stderr.contains("training stopped at iteration"), "{tag}: {stderr}");
    let stopped_at = rows(&out).len() as u64;
    assert!((2..ITERATIONS).contains(&stopped_at), "{tag}: stopped at {stopped_at}");
    let ckpt = format!("checkpoints/iter_{stopped_at:06}.safetensors");
    assert!(stderr.contains(&ckpt), "{tag}: the message names {ckpt}: {stderr}");
    let stop = std::fs::read(out.join(&ckpt)).unwrap();
    assert_eq!(stop, std::fs::read(out.join("latest.safetensors")).unwrap(), "{tag}: latest");
    assert!(!out.join("summary.json").exists(), "{tag}: a stopped run wrote its summary");
    println!("{tag}: stopped at iteration {stopped_at} of {ITERATIONS}");

    let o = train(&out).output().unwrap();
    assert!(o.status.success(), "{tag}: resume: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(rows(&out), reference.0, "{tag}: the resumed run's log rows");
    let last = std::fs::read(out.join(format!("checkpoints/iter_{ITERATIONS:06}.safetensors")));
    assert!(last.unwrap() == reference.1, "{tag}: the last checkpoint differs");
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_signalled_run_stops_with_a_checkpoint_and_resumes_exactly() {
    let base = std::env::temp_dir().join(format!("sm-stop-signals-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    // the reference is trained in the same folder name, so that the configuration inside the
    // checkpoints agrees
    let out = base.join("run");
    let o = train(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let last = format!("checkpoints/iter_{ITERATIONS:06}.safetensors");
    let reference = (rows(&out), std::fs::read(out.join(last)).unwrap());
    assert_eq!(reference.0.len() as u64, ITERATIONS);
    std::fs::remove_dir_all(&out).unwrap();

    stopped_run_resumes_exactly(&base, libc::SIGINT, &reference);
    stopped_run_resumes_exactly(&base, libc::SIGTERM, &reference);
    std::fs::remove_dir_all(&base).unwrap();
}

#[test]
fn a_second_signal_ends_the_process_at_once() {
    let base = std::env::temp_dir().join(format!("sm-stop-twice-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    for (sig, code) in [(libc::SIGINT, 130), (libc::SIGTERM, 143)] {
        let out = base.join(format!("run{sig}"));
        // the stop's checkpoint write pauses halfway (the writer's test hook), so that the second
        // signal finds the process still stopping, never already gone
        let mut cmd = train(&out);
        cmd.env("SKILLMIMIC_TEST_WRITE_PAUSE_MS", "3000");
        let child = start_and_wait_for_training(cmd, &out);
        signal(&child, sig);
        // two signals sent at once may arrive as one
        std::thread::sleep(Duration::from_millis(300));
        signal(&child, sig);
        let (status, stderr) = wait(child, "twice");
        assert_eq!(status.code(), Some(code), "signal {sig} twice: {stderr}");
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// A reader that went away (`skillmimic ... | head`) ends the command quietly with the shell's
/// code for a process ended by SIGPIPE (141), not with an "internal error" report.
#[test]
fn a_closed_output_pipe_ends_the_command_quietly() {
    use std::os::fd::{FromRawFd, OwnedFd};
    let mut fds = [0; 2];
    // SAFETY: pipe(2) fills both descriptors, which are owned from here on
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    let (read, write) = unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    drop(read);
    let o = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .args(["config", "reference"])
        .stdout(Stdio::from(write))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(141), "{stderr}");
    assert!(stderr.is_empty(), "nothing to report: {stderr}");
}
