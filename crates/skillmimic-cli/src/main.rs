//! `skillmimic`: the command-line tool of skillmimic-rs.
//!
//! Every subcommand lives in its own module; user mistakes end with a one-line `error:` message
//! and exit code 1 (no backtrace).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod bench;
mod cmd_mjcf;
mod cmd_motion;
mod cmd_trace;
mod demo;

#[derive(Parser)]
#[command(name = "skillmimic", version, about = "SkillMimic / SkillMimic-V2 on MuJoCo: scenes, simulation, benchmarks")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write the shipped MJCF scenes (full and box hands) into a folder.
    Mjcf(cmd_mjcf::Args),
    /// Run a benchmark and print throughput ratios measured in one run.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Convert BallPlay-M `.pt` clips (a file or a folder tree) into the project clip format.
    Convert(cmd_motion::ConvertArgs),
    /// Regenerate the shipped demo clips (IK stand-and-dribble) into `motions/`.
    SynthMotions(cmd_motion::SynthArgs),
    /// Short simulation demo on the batched core.
    Demo(demo::Args),
    /// Record a physics trace (initial state, actions, final state) for cross-checks with PyPI mujoco.
    Trace(cmd_trace::Args),
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_target(false)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Mjcf(a) => cmd_mjcf::run(a),
        Command::Bench(b) => bench::run(b),
        Command::Demo(a) => demo::run(a),
        Command::Convert(a) => cmd_motion::convert(a),
        Command::SynthMotions(a) => cmd_motion::synth(a),
        Command::Trace(a) => cmd_trace::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
