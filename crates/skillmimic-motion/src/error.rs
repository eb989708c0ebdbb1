//! Clip loading errors: every message names the file and what was expected.

use std::path::PathBuf;

/// Error while reading or validating a motion clip.
#[derive(Debug, thiserror::Error)]
pub enum ClipError {
    /// (The I/O error is part of the message, not a `source`, so error chains do not repeat it.)
    #[error("{path}: cannot read file: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error(
        "{path}: no such clip file or folder (give .pt/.safetensors files or folders holding \
            them; `builtin:demo` selects the built-in demo clips)"
    )]
    NotFound { path: PathBuf },
    #[error(
        "{path}: not a PyTorch zip archive ({detail}); expected a file written by torch.save \
            holding one float32 tensor of shape (T, 337)"
    )]
    NotZip { path: PathBuf, detail: String },
    #[error("{path}: {detail}")]
    Format { path: PathBuf, detail: String },
    #[error("{path}: tensor has shape {shape:?}, expected (T, {expected_width}) with T >= 1")]
    Shape { path: PathBuf, shape: Vec<usize>, expected_width: usize },
    #[error("{path}: non-finite value {value} at frame {frame}, column {column} ({field})")]
    NonFinite { path: PathBuf, frame: usize, column: usize, field: &'static str, value: f32 },
    #[error("{path}: {field} at frame {frame} {problem}")]
    Invalid { path: PathBuf, field: String, frame: usize, problem: String },
    #[error(
        "{path}: cannot read the skill label: the file name must start with three digits (e.g. \
            013_run.pt), got '{name}'"
    )]
    Label { path: PathBuf, name: String },
    #[error("{path}: skill label {label} is outside the one-hot width {width}")]
    LabelRange { path: PathBuf, label: u32, width: usize },
}
