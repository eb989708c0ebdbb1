"""``skillmimic`` (the console command ``pip install`` creates) and ``python -m skillmimic_rs``:
the project's command-line tool, the very code of the cargo-built binary run in this process
(``skillmimic_rs._core.cli_main``). ``skillmimic --help`` lists the commands: train, eval, play,
export, import-rlgames, infer, plot, mjcf, bench, convert, synth-motions, demo, history, retarget,
trace, config."""

from __future__ import annotations

import signal
import sys


def main(argv: list[str] | None = None) -> int:
    """Run the tool on ``argv`` (default ``sys.argv[1:]``) and return its exit code."""
    # The process is the tool: signals act as on the binary. Ctrl-C ends a command at once, but
    # `train`, which stops after the iteration under way with a checkpoint (a second Ctrl-C ends
    # it at once); the Rust code does not return to the interpreter, where Python's handler would run
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    from . import _core

    return int(_core.cli_main(list(sys.argv[1:] if argv is None else argv), own_signals=True))


if __name__ == "__main__":
    sys.exit(main())
