//! `skillmimic_rs._core`: the Rust environment exposed to Python.
//!
//! The Python package wraps `env::CoreEnv` in a gymnasium `VectorEnv`; this layer only moves
//! data: numpy arrays in, the Rust core steps with the GIL released, results are written into
//! preallocated numpy buffers owned by the Python side. Every user mistake raises `ValueError` (or
//! `RuntimeError` after `close()`), never a crash.

use pyo3::prelude::*;

mod consts;
mod convert;
mod env;
mod generator;
mod learner;
mod nn;
mod train;

// env.rs: the batched environment; learner.rs: policy inference, normaliser, PPO loss; train.rs:
// the trainer (one process or one rank of a data-parallel run); nn.rs: network blocks; consts.rs:
// tables; convert.rs: argument checks and array helpers shared by them; generator.rs: Python clip
// generators of active skill learning

/// Run the `skillmimic` command-line tool in this process (`argv` without the program name) with
/// the GIL released; returns its exit code (0 ok, 1 failed command, 2 usage error). The console
/// command `skillmimic` and `python -m skillmimic_rs` call this, so the pip-installed command is
/// the cargo-built one.
#[pyfunction]
fn cli_main(py: Python<'_>, argv: Vec<String>) -> i32 {
    let args: Vec<String> = std::iter::once("skillmimic".to_string()).chain(argv).collect();
    // `run` catches panics itself (one `error:` line, exit code 1)
    py.detach(|| skillmimic_cli::run(args))
}

/// Version of the Rust core.
#[pyfunction]
fn core_version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<env::CoreEnv>()?;
    m.add_class::<learner::Policy>()?;
    m.add_class::<learner::RunningMeanStd>()?;
    m.add_class::<learner::HistoryEncoder>()?;
    m.add_class::<train::PyTrainer>()?;
    m.add_function(wrap_pyfunction!(core_version, m)?)?;
    m.add_function(wrap_pyfunction!(cli_main, m)?)?;
    m.add_function(wrap_pyfunction!(learner::ppo_loss_and_grads, m)?)?;
    m.add_function(wrap_pyfunction!(learner::init_policy, m)?)?;
    m.add_function(wrap_pyfunction!(nn::transformer_encoder_layer, m)?)?;
    m.add_function(wrap_pyfunction!(generator::register_generator, m)?)?;
    m.add("CLIP_FORMAT", skillmimic_motion::format::FORMAT_NAME)?;
    m.add("CLIP_FORMAT_VERSION", skillmimic_motion::format::FORMAT_VERSION)?;
    m.add("OBS_DIM", skillmimic_env::obs::layout::OBS_DIM)?;
    m.add("BUILTIN_DEMO", skillmimic_env::BUILTIN_DEMO)?;
    consts::register(m)?;
    Ok(())
}
