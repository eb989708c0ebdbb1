//! Errors of the simulation layer (user mistakes get a message, never a panic).

/// Simulation error.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The MJCF did not compile or lacks an expected element.
    #[error("scene {source_name}: {message}")]
    Model { source_name: String, message: String },
    /// A batched array has the wrong length.
    #[error("{what}: expected {expected} values ({shape}), got {got}")]
    Shape { what: &'static str, expected: usize, shape: String, got: usize },
    /// An input contains NaN or ±inf.
    #[error("{what}: non-finite value at environment {env}, entry {index}")]
    NonFinite { what: &'static str, env: usize, index: usize },
    /// A bad environment count or thread count.
    #[error("{0}")]
    Config(String),
}
