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
///
/// Stopping `train` (skillmimic_cli's `stop` module): with `own_signals` (the console command,
/// whose process is the tool) SIGINT and SIGTERM are handled as the binary handles them. Without
/// it (`skillmimic_rs.cli` and the functions on it, called from a user's program) the interpreter
/// keeps its handlers: training asks Python after every iteration whether a signal is pending (in
/// the main thread), and a pending one stops it after that iteration with a checkpoint, after
/// which its exception (KeyboardInterrupt for Ctrl-C) is raised here.
#[pyfunction]
#[pyo3(signature = (argv, own_signals = false))]
fn cli_main(py: Python<'_>, argv: Vec<String>, own_signals: bool) -> PyResult<i32> {
    if own_signals {
        skillmimic_cli::stop_on_signals();
    } else {
        skillmimic_cli::set_stop_check(python_signal_pending);
    }
    let args: Vec<String> = std::iter::once("skillmimic".to_string()).chain(argv).collect();
    // `run` catches panics itself (one `error:` line, exit code 1)
    let code = py.detach(|| skillmimic_cli::run(args));
    match PENDING_SIGNAL.lock().unwrap_or_else(|e| e.into_inner()).take() {
        Some(e) => Err(e),
        None => Ok(code),
    }
}

/// The exception of the signal that stopped a `cli_main` training run, raised when it returns.
static PENDING_SIGNAL: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);

/// Whether Python has a pending signal whose handler raises (its exception is kept for
/// `cli_main`).
fn python_signal_pending() -> bool {
    Python::attach(|py| match py.check_signals() {
        Ok(()) => false,
        Err(e) => {
            *PENDING_SIGNAL.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
            true
        }
    })
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
