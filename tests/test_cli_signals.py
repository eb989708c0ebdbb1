"""Ctrl-C stops Python's ways of training after the iteration under way with a checkpoint that
``--resume latest`` continues: the pip-installed command (``python -m skillmimic_rs train`` runs
the function of the ``skillmimic`` console script), which handles the signals as the binary does,
and ``skillmimic_rs.cli("train", ...)`` called from a program, which keeps Python's own handler
and raises its ``KeyboardInterrupt`` once the checkpoint is written. (The binary's handlers, the
exact resume, SIGTERM and the second signal are tested in
crates/skillmimic-cli/tests/stop_signals.rs.)"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

ITERATIONS = 400


def _options(out: Path, iterations: int) -> list[str]:
    return [
        "train", "--preset", "tiny", "--no-video", "--threads", "1", "--out", str(out),
        "--iterations", str(iterations), "--resume", "latest",
        "--set", "run.save_every=1000", "--set", "run.eval_episodes=2",
    ]


def _train(out: Path, iterations: int) -> list[str]:
    return [sys.executable, "-m", "skillmimic_rs", *_options(out, iterations)]


# a program calling the tool as a function, which reports the interrupt it gets; it installs
# Python's default Ctrl-C handler itself, because a test run started as a background job of a
# non-interactive shell (`./scripts/test.sh &`) hands its children SIGINT ignored, and Python
# then keeps it ignored (the interrupt would never arrive and training would run to its end)
_PROGRAM = """
import signal
import sys
import skillmimic_rs as sm
signal.signal(signal.SIGINT, signal.default_int_handler)
try:
    sm.cli(*sys.argv[1:])
except KeyboardInterrupt:
    print("KeyboardInterrupt raised", file=sys.stderr)
    sys.exit(3)
"""


def _rows(out: Path) -> list[dict]:
    """The log's whole rows (a row being written has no newline yet)."""
    log = out / "log.jsonl"
    return [json.loads(line) for line in log.read_text().split("\n")[:-1]] if log.exists() else []


def _interrupted(command: list[str], out: Path) -> tuple[int, str]:
    """Run `command`, send SIGINT once it has logged two iterations; its exit code and stderr."""
    p = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while len(_rows(out)) < 2:
        assert p.poll() is None, f"ended before training: {p.stderr.read()}"
        assert time.monotonic() - t0 < 300, "no training"
        time.sleep(0.005)
    p.send_signal(signal.SIGINT)
    _, stderr = p.communicate(timeout=120)
    return p.returncode, stderr


def _stopped_with_a_checkpoint(out: Path, stderr: str) -> int:
    assert "training stopped at iteration" in stderr, stderr
    stopped = len(_rows(out))
    assert 2 <= stopped < ITERATIONS, stopped
    assert f"iter_{stopped:06}.safetensors" in stderr, stderr
    assert (out / "latest.safetensors").exists()
    assert not (out / "summary.json").exists()
    return stopped


def test_ctrl_c_stops_the_command_with_a_checkpoint_that_resumes(tmp_path):
    out = tmp_path / "run"
    code, stderr = _interrupted(_train(out, ITERATIONS), out)
    assert code == 1, stderr
    assert "Traceback" not in stderr, stderr
    stopped = _stopped_with_a_checkpoint(out, stderr)
    # the checkpoint continues: one more iteration, logged once
    r = subprocess.run(_train(out, stopped + 1), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert [row["iteration"] for row in _rows(out)] == list(range(1, stopped + 2))


def test_ctrl_c_stops_the_function_with_a_checkpoint_and_raises(tmp_path):
    out = tmp_path / "run"
    code, stderr = _interrupted([sys.executable, "-c", _PROGRAM, *_options(out, ITERATIONS)], out)
    assert code == 3 and "KeyboardInterrupt raised" in stderr, stderr
    _stopped_with_a_checkpoint(out, stderr)
