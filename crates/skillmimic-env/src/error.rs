//! The environment crate's error type.

use skillmimic_motion::ClipError;
use skillmimic_sim::SimError;

use skillmimic_nn::history::HistoryError;

/// Environment error.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Clip(#[from] ClipError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    History(#[from] HistoryError),
    /// An action batch of the wrong length.
    #[error("actions: expected {expected} values (environments × action width), got {got}")]
    ActionShape { expected: usize, got: usize },
    /// A discrete action that is not one of the task's choices.
    #[error("actions: environment {env} sent {value}, expected an integer choice in 0..{n}")]
    DiscreteAction { env: usize, value: f32, n: usize },
    /// The frozen skill policy of a high-level task.
    #[error(transparent)]
    Frozen(#[from] skillmimic_nn::frozen::FrozenError),
    /// An operation the task does not offer.
    #[error("{0}")]
    Unsupported(String),
    /// `env.task` names no registered task.
    #[error("config field 'env.task': unknown task '{name}'; registered tasks: {known}")]
    UnknownTask { name: String, known: String },
}

/// Invalid configuration value.
#[derive(Debug, thiserror::Error)]
#[error("config field '{field}': {message}")]
pub struct ConfigError {
    pub field: String,
    pub message: String,
}

pub(crate) fn bad(field: &str, message: impl Into<String>) -> ConfigError {
    ConfigError { field: field.into(), message: message.into() }
}
