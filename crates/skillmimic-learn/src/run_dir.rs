//! The run folder when a run starts or resumes (rank 0, before the first iteration):
//!
//! * stale temporary files are removed: atomic writes (`skillmimic_core::tensorfile::
//!   write_bytes_atomic`) write `<name>.tmp<pid>` and rename it, so a process killed mid-write
//!   leaves one behind (a checkpoint's is megabytes); those of processes that no longer run, and
//!   this process's own (it writes nothing into the folder yet), are removed from the folder,
//!   `checkpoints/` and `tb/`;
//! * the training log `log.jsonl` keeps only the iterations up to the one the run starts from
//!   (the checkpoint's iteration; 0 for a fresh run), so after a resume every iteration is in it
//!   exactly once; a line cut short by a kill is dropped too;
//! * the TensorBoard event files in `tb/` likewise keep only the steps up to the run's starting
//!   step (the step of an event is the sample count, see [`crate::runner`]).

use std::path::{Path, PathBuf};

use crate::checkpoint::Progress;
use crate::error::{LearnError, io};
use crate::tblog;

/// Whether process `pid` is running (Linux: `/proc/<pid>` exists; elsewhere unknown = no).
fn pid_alive(pid: u32) -> bool {
    Path::new("/proc/self").exists() && Path::new(&format!("/proc/{pid}")).exists()
}

/// Remove the stale `<name>.tmp<pid>` files of `dir` (not recursive): those whose process is
/// gone or is this one. Returns the removed paths.
pub fn remove_stale_temps(dir: &Path) -> Result<Vec<PathBuf>, LearnError> {
    let own = std::process::id();
    let mut removed = Vec::new();
    let rd = match std::fs::read_dir(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(removed),
        other => other.map_err(io(dir))?,
    };
    for entry in rd {
        let path = entry.map_err(io(dir))?.path();
        let Some(pid) = path.file_name().and_then(|n| n.to_str()).and_then(tblog::temp_pid) else {
            continue;
        };
        if (pid == own || !pid_alive(pid)) && path.is_file() {
            std::fs::remove_file(&path).map_err(io(&path))?;
            removed.push(path);
        }
    }
    Ok(removed)
}

/// Keep the lines of the training log `path` whose `iteration` is at most `iteration` (lines
/// that are not a JSON object with an integer `iteration`, such as one cut short by a kill, are
/// dropped). Rewritten atomically when something changes; a missing log stays missing. Returns
/// the number of lines dropped.
pub fn truncate_log(path: &Path, iteration: u64) -> Result<usize, LearnError> {
    let text = match std::fs::read(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        other => other.map_err(io(path))?,
    };
    let text = String::from_utf8_lossy(&text);
    let mut kept = String::with_capacity(text.len());
    let mut dropped = 0;
    for line in text.split_inclusive('\n') {
        let it = line
            .ends_with('\n')
            .then(|| serde_json::from_str::<serde_json::Value>(line).ok())
            .flatten()
            .and_then(|v| v.get("iteration")?.as_u64());
        match it {
            Some(k) if k <= iteration => kept.push_str(line),
            _ => dropped += usize::from(!line.trim().is_empty()),
        }
    }
    if kept.len() != text.len() {
        skillmimic_core::tensorfile::write_bytes_atomic(path, kept.as_bytes()).map_err(io(path))?;
    }
    Ok(dropped)
}

/// Prepare the run folder `out` for a run starting at `progress` (see the module
/// documentation); logs what it removed.
pub fn prepare(out: &Path, progress: &Progress) -> Result<(), LearnError> {
    for dir in [out.to_path_buf(), out.join("checkpoints"), out.join("tb")] {
        for p in remove_stale_temps(&dir)? {
            tracing::info!(
                "removed the stale temporary file {} (left by an interrupted write)",
                p.display()
            );
        }
    }
    let log = out.join("log.jsonl");
    let n = truncate_log(&log, progress.iteration)?;
    if n > 0 {
        tracing::info!(
            "{}: removed {n} line(s) past iteration {}, where this run starts",
            log.display(),
            progress.iteration
        );
    }
    let tb = out.join("tb");
    let n = tblog::truncate_dir(&tb, progress.samples as i64).map_err(io(&tb))?;
    if n > 0 {
        tracing::info!(
            "{}: removed {n} TensorBoard event(s) past step {}, where this run starts",
            tb.display(),
            progress.samples
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_keeps_each_iteration_up_to_the_start_and_temps_go() {
        let dir = std::env::temp_dir().join(format!("sm-rundir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("checkpoints")).unwrap();
        let log = dir.join("log.jsonl");
        std::fs::write(&log, "{\"iteration\":1}\n{\"iteration\":2}\n{\"iteration\":3}\n{\"itera")
            .unwrap();
        assert_eq!(truncate_log(&log, 2).unwrap(), 2);
        assert_eq!(
            std::fs::read_to_string(&log).unwrap(),
            "{\"iteration\":1}\n{\"iteration\":2}\n"
        );
        assert_eq!(truncate_log(&log, 5).unwrap(), 0);
        assert_eq!(truncate_log(&dir.join("none.jsonl"), 0).unwrap(), 0);
        // a stale temp file (no such process: pids are below 2^22 on Linux), this process's own,
        // and files that only look similar
        let stale = dir.join("checkpoints/iter_000002.safetensors.tmp4000000000");
        let own = dir.join(format!("latest.safetensors.tmp{}", std::process::id()));
        let keep = [dir.join("notes.tmp"), dir.join("x.tmpy")];
        for p in [&stale, &own].into_iter().chain(&keep) {
            std::fs::write(p, b"x").unwrap();
        }
        prepare(&dir, &Progress { iteration: 1, samples: 10 }).unwrap();
        assert!(!stale.exists() && !own.exists());
        assert!(keep.iter().all(|p| p.exists()));
        assert_eq!(std::fs::read_to_string(&log).unwrap(), "{\"iteration\":1}\n");
        std::fs::remove_dir_all(&dir).ok();
    }
}
