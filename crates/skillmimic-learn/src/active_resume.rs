//! Resuming a run with active skill learning ([`crate::active`]) exactly: before the environment
//! is built, the run's generated library and its sampling weights are put back as they were at
//! the checkpoint.
//!
//! A round grows `env.motion` (the folder `<run.out_dir>/generated/`) and sets
//! `env.tracking.clip_weights` while the run trains; the checkpoint's stored configuration holds
//! both. A run killed after a round but before the next checkpoint has written clips and a line
//! of `active.jsonl` that the checkpoint does not know of.

use std::collections::BTreeSet;
use std::path::Path;

use skillmimic_core::tensorfile::TensorFile;
use skillmimic_env::tasks::tracking::config::TrackingConfig;

use crate::config::TrainConfig;
use crate::error::{LearnError, bad_checkpoint, io};

/// Prepare `cfg` (with `run.active.enabled`) for a resume from `checkpoint` (iteration s):
///
/// * `active.jsonl` keeps the rounds of iterations up to s; the `.safetensors` clips of
///   `<run.out_dir>/generated/` that none of the kept rounds accepted (made by rounds after the
///   checkpoint) are removed, so the library is the checkpoint's;
/// * `env.motion` and `env.tracking.clip_weights` are taken from the checkpoint's configuration
///   where the rounds changed them: its `env.motion` must be the given list plus the generated
///   folder (any other difference stays, and the resume refuses it naming the key), its weights
///   are those of its last round. An info line names the keys taken.
///
/// Assumes that a generated clip's name identifies its motion (a later round that makes a clip of
/// the same name writes the same clip), as the names of the model-free generator do
/// (`<clip>~mirror`, `<clip>~warp<factor>`, `<clip>~<part>-from-<donor>`); an external generator
/// should name its clips likewise.
pub fn prepare(cfg: &mut TrainConfig, checkpoint: &Path) -> Result<(), LearnError> {
    let f = TensorFile::open(checkpoint).map_err(|e| bad_checkpoint(checkpoint)(e.to_string()))?;
    let s: u64 = f
        .meta_parse("iteration", "an integer")
        .map_err(|e| bad_checkpoint(checkpoint)(e.to_string()))?;
    let out = cfg.run.out_dir.clone();
    let log = out.join("active.jsonl");
    crate::run_dir::truncate_log(&log, s)?;
    let kept = accepted_files(&log)?;
    let dir = out.join("generated");
    if dir.is_dir() {
        for entry in std::fs::read_dir(&dir).map_err(io(&dir))? {
            let p = entry.map_err(io(&dir))?.path();
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if name.ends_with(".safetensors") && p.is_file() && !kept.contains(&name) {
                std::fs::remove_file(&p).map_err(io(&p))?;
                tracing::info!("resume: removed {} (generated after the checkpoint)", p.display());
            }
        }
    }
    let text = f.metadata().get("config").cloned().unwrap_or_default();
    if text.is_empty() {
        return Ok(());
    }
    let stored = crate::checkpoint::stored_config(checkpoint, &text)?;
    if !stored.run.active.enabled {
        return Ok(());
    }
    let mut taken = Vec::new();
    let mut grown = cfg.env.motion.clone();
    grown.push(dir);
    if stored.env.motion != cfg.env.motion && stored.env.motion == grown {
        cfg.env.motion = grown;
        taken.push("env.motion");
    }
    let weights = &stored.env.table::<TrackingConfig>().clip_weights;
    if *weights != cfg.env.table::<TrackingConfig>().clip_weights {
        cfg.env.table_mut::<TrackingConfig>().clip_weights = weights.clone();
        taken.push("env.tracking.clip_weights");
    }
    if !taken.is_empty() {
        tracing::info!(
            "resume: {} taken from {} (set by active learning's rounds)",
            taken.join(" and "),
            checkpoint.display()
        );
    }
    Ok(())
}

/// The rounds logged in `log` (`active.jsonl`, one JSON object per line; missing: none).
fn rounds(log: &Path) -> Result<Vec<serde_json::Value>, LearnError> {
    let text = match std::fs::read_to_string(log) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        other => other.map_err(io(log))?,
    };
    text.lines()
        .map(|line| {
            serde_json::from_str(line).map_err(|e| {
                LearnError::Config(format!("{}: a line is not JSON: {e}", log.display()))
            })
        })
        .collect()
}

/// The file names of the clips accepted by the rounds logged in `log`.
fn accepted_files(log: &Path) -> Result<BTreeSet<String>, LearnError> {
    let mut names = BTreeSet::new();
    for v in rounds(log)? {
        let accepted = v["report"]["accepted"].as_array().into_iter().flatten();
        for file in accepted.filter_map(|pair| pair.get(1)?.as_str()) {
            if let Some(name) = Path::new(file).file_name() {
                names.insert(name.to_string_lossy().into_owned());
            }
        }
    }
    Ok(names)
}

/// How many of the rounds logged in `log` (`active.jsonl`) each clip failed.
pub fn failure_counts(log: &Path) -> Result<std::collections::BTreeMap<String, usize>, LearnError> {
    let mut counts = std::collections::BTreeMap::new();
    for v in rounds(log)? {
        for name in
            v["report"]["failed"].as_array().into_iter().flatten().filter_map(|n| n.as_str())
        {
            *counts.entry(name.to_string()).or_default() += 1;
        }
    }
    Ok(counts)
}

/// Whether `log` (`active.jsonl`) holds a round of iteration `it`.
pub fn round_logged(log: &Path, it: u64) -> Result<bool, LearnError> {
    Ok(rounds(log)?.iter().any(|v| v.get("iteration").and_then(|x| x.as_u64()) == Some(it)))
}
