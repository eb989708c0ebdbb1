//! Stopping `skillmimic train` from outside: Ctrl-C (SIGINT) or a scheduler's SIGTERM (SLURM and
//! Kubernetes send it before they kill) ends training after the iteration under way, with a
//! checkpoint of it that `--resume latest` continues exactly, instead of losing everything since
//! the last regular checkpoint.
//!
//! Where the request comes from depends on who runs the tool; the training loop only asks
//! [`stop_requested`] after every iteration:
//! * a process that is the tool (the binary, the pip-installed `skillmimic` script) calls
//!   [`stop_on_signals`]: while `train` trains and finishes its run ([`training`]: the loop, the
//!   end-of-run evaluation and artefacts), SIGINT and SIGTERM set a flag (signal-hook), and a
//!   second signal (of either kind) ends the process at once with 128 + its number (130 for
//!   SIGINT, 143 for SIGTERM), for a user who does not want to wait for the iteration (or the
//!   evaluation, which a first signal does not cut short) to finish; a checkpoint being written
//!   then is left as a temporary file and `latest` stays whole. The handlers replace an inherited
//!   "ignore" too, so `kill -INT` reaches a run started in the background of a script (such shells
//!   start background jobs with SIGINT ignored). Outside that span (set-up, other commands) the
//!   signals keep their default action: they end the process;
//! * a Python program calling the tool as a function (`skillmimic_rs.cli`) keeps the
//!   interpreter's handlers and sets [`set_stop_check`] to a function asking Python whether a
//!   signal is pending (`skillmimic_rs.train` runs the trainer itself and asks Python the same).
//!
//! A process that did neither (a Rust program calling [`crate::run`]) trains to the end.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock, OnceLock};

/// Set by the signal handlers while training.
static SIGNALLED: LazyLock<Arc<AtomicBool>> = LazyLock::new(|| Arc::new(AtomicBool::new(false)));
/// True outside [`Training`]'s span: a signal then takes its default action.
static OUTSIDE_TRAINING: LazyLock<Arc<AtomicBool>> =
    LazyLock::new(|| Arc::new(AtomicBool::new(true)));
/// Whether this process handles the signals itself ([`stop_on_signals`]).
static HANDLE_SIGNALS: AtomicBool = AtomicBool::new(false);
/// The handlers, registered once per process, the first time training starts.
static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
/// The caller's way of asking whether training should stop (the first one set wins).
static STOP_CHECK: OnceLock<fn() -> bool> = OnceLock::new();

/// Make `check` a question asked after every training iteration: `true` stops training after
/// that iteration with a checkpoint. Only the first call of a process takes effect (returns
/// whether this one did).
pub fn set_stop_check(check: fn() -> bool) -> bool {
    STOP_CHECK.set(check).is_ok()
}

/// This process is the tool: let `train` handle SIGINT and SIGTERM while it trains (see the
/// module). Call it before [`crate::run`].
pub fn stop_on_signals() {
    HANDLE_SIGNALS.store(true, Ordering::Relaxed);
}

/// Whether training should stop now.
pub(crate) fn stop_requested() -> bool {
    SIGNALLED.load(Ordering::Relaxed) || STOP_CHECK.get().is_some_and(|check| check())
}

/// The span of `train`'s run (its loop, evaluation and artefacts): while it lives, the signals
/// ask training to stop (where [`stop_on_signals`] was called); dropped, they take their default
/// action again.
pub(crate) struct Training(());

/// Enter the run's span (see [`Training`]).
pub(crate) fn training() -> Training {
    if HANDLE_SIGNALS.load(Ordering::Relaxed) {
        if let Err(e) = REGISTERED.get_or_init(|| register().map_err(|e| e.to_string())) {
            tracing::warn!("Ctrl-C and SIGTERM will end training without a checkpoint: {e}");
        }
        SIGNALLED.store(false, Ordering::Relaxed);
        OUTSIDE_TRAINING.store(false, Ordering::Relaxed);
    }
    Training(())
}

impl Drop for Training {
    fn drop(&mut self) {
        OUTSIDE_TRAINING.store(true, Ordering::Relaxed);
    }
}

/// Per signal, in the order signal-hook runs them: outside training the default action; a
/// signal that finds the flag already set exits; then the flag is set.
fn register() -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    for signal in [SIGINT, SIGTERM] {
        flag::register_conditional_default(signal, OUTSIDE_TRAINING.clone())?;
        flag::register_conditional_shutdown(signal, 128 + signal, SIGNALLED.clone())?;
        flag::register(signal, SIGNALLED.clone())?;
    }
    Ok(())
}
