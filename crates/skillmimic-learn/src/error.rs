//! The learner crate's error type.

use std::path::{Path, PathBuf};

use skillmimic_env::EnvError;

/// Learner error: configuration, environment, checkpoint files, candle.
#[derive(Debug, thiserror::Error)]
pub enum LearnError {
    #[error(transparent)]
    Env(#[from] EnvError),
    /// An invalid configuration; the message names the field (`config field 'ppo.lr': …`).
    #[error("{0}")]
    Config(String),
    /// A checkpoint file that cannot be used (the message names the file).
    #[error("{message}")]
    Checkpoint { path: PathBuf, message: String },
    /// (The I/O error is part of the message, not a `source`, so error chains do not repeat it.)
    #[error("{}: {error}", path.display())]
    Io { path: PathBuf, error: std::io::Error },
    /// A tensor operation failed (device, shapes).
    #[error("candle: {0}")]
    Candle(#[from] candle_core::Error),
    /// Training produced non-finite values.
    #[error("{0}")]
    Diverged(String),
    /// A collective operation of a data-parallel run failed (a rank died, the group timed out).
    #[error("distributed: {0}")]
    Distributed(String),
    /// The requested device is not in this build.
    #[error(
        "config field 'ppo.device': device '{0}' is not available in this build (cpu, or cuda \
            with the `cuda` feature)"
    )]
    Device(String),
}

/// `map_err` helper: an I/O error on `path`.
pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> LearnError + '_ {
    move |error| LearnError::Io { path: path.to_path_buf(), error }
}

/// `map_err` helper: an unusable checkpoint `path`.
pub fn bad_checkpoint(path: &Path) -> impl FnOnce(String) -> LearnError + '_ {
    move |message| LearnError::Checkpoint { path: path.to_path_buf(), message }
}
