//! `skillmimic`: the command-line tool of skillmimic-rs (the whole tool is the library's
//! [`skillmimic_cli::run`], shared with the Python package's `skillmimic` command).

use std::process::ExitCode;

fn main() -> ExitCode {
    skillmimic_cli::tune_allocator();
    skillmimic_cli::quiet_panics();
    // Ctrl-C / SIGTERM stop `train` after the iteration under way, with a checkpoint
    skillmimic_cli::stop_on_signals();
    ExitCode::from(skillmimic_cli::run(std::env::args_os()) as u8)
}
