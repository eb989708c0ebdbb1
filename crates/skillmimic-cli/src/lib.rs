//! `skillmimic`: the command-line tool of skillmimic-rs, as a library.
//!
//! [`run`] is the whole tool: the cargo-built binary (`src/main.rs`) and the Python package's
//! `skillmimic` command and `python -m skillmimic_rs` (through `skillmimic_rs._core.cli_main`) call
//! it, so every way of installing gives the same command. Every subcommand lives in its own
//! module; user mistakes end with a one-line `error:` message and exit code 1 (no backtrace).

use std::ffi::OsString;

pub use cmd_train::with_artefact_hooks;
pub use stop::{set_stop_check, stop_on_signals};

use clap::{Parser, Subcommand};

mod bench;
mod bench_learner;
mod bench_raw;
mod bench_solver;
mod bench_train;
mod cmd_config;
mod cmd_eval_tasks;
mod cmd_history;
mod cmd_import;
mod cmd_mjcf;
mod cmd_motion;
mod cmd_onnx;
mod cmd_play;
mod cmd_policy;
mod cmd_retarget;
mod cmd_trace;
mod cmd_train;
mod common;
mod demo;
mod ghost;
mod plot;
mod plot_draw;
mod plot_tts;
mod stop;
mod video;

#[derive(Parser)]
#[command(
    name = "skillmimic",
    version,
    about = "SkillMimic / SkillMimic-V2 on MuJoCo: train, evaluate, play, export, convert, bench"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a policy with PPO (writes checkpoints, logs, metrics, curve, video).
    Train(cmd_train::Args),
    /// Evaluate a checkpoint: imitation metrics, success rates, optional robustness sweep (JSON).
    Eval(cmd_policy::EvalArgs),
    /// Roll out a policy or play back a reference clip; write a headless video and/or the states.
    Play(cmd_play::Args),
    /// Export the policy part of a checkpoint (safetensors, no optimizer state) or an ONNX graph.
    Export(cmd_policy::ExportArgs),
    /// Import an rl_games `.pth` checkpoint (skill or high-level policy) without running pickle
    /// code.
    #[command(name = "import-rlgames")]
    ImportRlgames(cmd_import::Args),
    /// Batched inference of a checkpoint on observations from a safetensors file.
    Infer(cmd_policy::InferArgs),
    /// PNG learning curves from a training log.
    Plot(plot::Args),
    /// Write the shipped MJCF scenes (full and box hands) into a folder.
    Mjcf(cmd_mjcf::Args),
    /// Run a benchmark and print throughput ratios measured in one run.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Convert BallPlay-M `.pt` clips (a file or a folder tree) into the project clip format.
    Convert(cmd_motion::ConvertArgs),
    /// Regenerate the shipped demo clips (IK stand-and-dribble) into `motions/`; with
    /// `--character tokenhsi --out-dir DIR`, write the procedural TokenHSI walks and sits.
    SynthMotions(cmd_motion::SynthArgs),
    /// Short simulation demo on the batched core.
    Demo(demo::Args),
    /// SkillMimic-V2 history encoder tools (pre-training).
    #[command(subcommand)]
    History(cmd_history::HistoryCommand),
    /// Retarget a BVH motion onto the SkillMimic humanoid (`--bvh`), or SkillMimic-skeleton clips
    /// onto the TokenHSI character (`--to tokenhsi`); clips + a JSON report.
    Retarget(cmd_retarget::Args),
    /// Record a physics trace (initial state, actions, final state) for cross-checks with PyPI
    /// mujoco.
    Trace(cmd_trace::Args),
    /// Configuration tools: the generated reference of every key (docs/config.md).
    #[command(subcommand)]
    Config(cmd_config::ConfigCommand),
}

/// Whether a panic's message is `print!` failing because standard output or error was closed (a
/// pipe whose reader exited).
fn is_closed_output(message: &str) -> bool {
    message.starts_with("failed printing to std") && message.contains("Broken pipe")
}

/// Keep freed large blocks in the process instead of returning them to the kernel: candle
/// allocates fresh multi-megabyte tensors for every operation, and with glibc's defaults each of
/// them is a new mmap whose pages fault in again (measured on history pre-training: 4.6 s of
/// 8.8 s were kernel time; with these settings 0.4 s, 1.3–1.4x faster overall). The binary calls
/// it first thing; in Python it runs when the first command starts (mallopt is thread-safe).
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes allocator thresholds.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
    }
}

/// Run the tool on `args` (the program name first, as in `std::env::args_os`) and return the exit
/// code: 0 on success (also for `--help` / `--version`), 1 with an `error:` line on stderr for a
/// failed command (also after an internal panic, reported as one `error: internal error` line), 2
/// for a usage error (clap's message on stderr), 141 and no message when standard output was closed
/// under it (`skillmimic eval ... | head`). Never exits the process itself, so a Python caller
/// keeps control; `train` stops early (a checkpoint, then exit code 1) when [`set_stop_check`]'s
/// question says so.
pub fn run<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    // a second call in one process (Python) keeps the subscriber of the first
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_target(false)
        .try_init();
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli.command)));
    match result {
        Ok(Ok(())) => 0,
        // a write of ours that met the closed pipe and was handed up as an error
        Ok(Err(e))
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            141
        }
        Ok(Err(e)) => {
            eprintln!("error: {e:#}");
            1
        }
        Err(payload) => {
            let what = LAST_PANIC
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
                .unwrap_or_else(|| skillmimic_core::panic_message(&*payload));
            if is_closed_output(&what) {
                // `skillmimic eval ... | head`: the reader went away, as for any Unix tool (the
                // shell's code for a process ended by SIGPIPE), not a bug to report
                return 141;
            }
            eprintln!(
                "error: internal error: {what} (a bug of skillmimic-rs, not of your input; please \
                    report it with the command line)"
            );
            1
        }
    }
}

/// The last panic's message and location, recorded by the hook of [`quiet_panics`].
static LAST_PANIC: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// For the `skillmimic` binary: a panic prints nothing where it happens (no multi-line
/// "thread panicked" report, no backtrace); [`run`] reports it as one `error:` line with its
/// location and exits with code 1. Not installed for the Python module, whose host process keeps
/// its own hook.
pub fn quiet_panics() {
    std::panic::set_hook(Box::new(|info| {
        let loc =
            info.location().map(|l| format!(" (at {}:{})", l.file(), l.line())).unwrap_or_default();
        let text = format!("{}{loc}", skillmimic_core::panic_message(info.payload()));
        *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = Some(text);
    }));
}

fn dispatch(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Train(a) => cmd_train::run(a),
        Command::Eval(a) => cmd_policy::eval(a),
        Command::Play(a) => cmd_play::run(a),
        Command::Export(a) => cmd_policy::export(a),
        Command::ImportRlgames(a) => cmd_import::run(a),
        Command::Infer(a) => cmd_policy::infer(a),
        Command::Plot(a) => plot::run(a),
        Command::Mjcf(a) => cmd_mjcf::run(a),
        Command::Bench(b) => bench::run(b),
        Command::Demo(a) => demo::run(a),
        Command::Convert(a) => cmd_motion::convert(a),
        Command::SynthMotions(a) => cmd_motion::synth(a),
        Command::Trace(a) => cmd_trace::run(a),
        Command::Retarget(a) => cmd_retarget::run(a),
        Command::History(c) => cmd_history::run(c),
        Command::Config(c) => cmd_config::run(c),
    }
}
