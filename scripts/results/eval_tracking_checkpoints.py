"""Success and errors along a tracking run (issue 39, docs/results-modskill.md): evaluate every
EVERY-th checkpoint of RUN/checkpoints as PHC and ModSkill evaluate (`skillmimic eval
--each-motion`: every motion once from frame 0, deterministic actions, success at 0.5 m) on named
motion sets, and keep one JSON line per checkpoint in OUT/<set>_checkpoint_evals.jsonl
(iteration, samples from RUN/log.jsonl, success over motions, errors pooled over every step).
Existing rows are kept; a rerun evaluates only the new checkpoints.

    python3 scripts/results/eval_tracking_checkpoints.py RUN OUT train=DIR,DIR... heldback=DIR,...
    EVERY=100 BIN=target/release/skillmimic python3 scripts/results/eval_tracking_checkpoints.py ...
    skillmimic plot --evals OUT/train_checkpoint_evals.jsonl --evals OUT/heldback_checkpoint_evals.jsonl \\
        --label training --label held-back --out OUT/checkpoint_evals.png
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import tempfile

ERRORS = ("g_mpjpe_mm", "mpjpe_mm", "vel_err_mm", "acc_err_mm")


def row(iteration: int, samples: int | None, report: dict) -> dict:
    """One checkpoint's line: success over motions and the errors over all motions' steps."""
    out = {"iteration": iteration, "samples": samples, "motions": report["motions"], "successes": report["successes"],
           "success_pct": round(100 * report["success_rate"], 2)}
    out.update({k: round(report["metrics_all"][k], 2) for k in ERRORS})
    return out


def main(argv: list[str]) -> None:
    if len(argv) < 3:
        sys.exit(__doc__)
    run, out = pathlib.Path(argv[0]), pathlib.Path(argv[1])
    sets = {}
    for spec in argv[2:]:
        name, _, dirs = spec.partition("=")
        if not name or not dirs:
            sys.exit(f"motion set '{spec}': expected NAME=DIR[,DIR...]")
        sets[name] = dirs.split(",")
    every = int(os.environ.get("EVERY", "100"))
    binary = os.environ.get("BIN", "target/release/skillmimic")
    samples = {}
    log = run / "log.jsonl"
    if log.exists():
        for line in log.read_text().splitlines():
            r = json.loads(line)
            samples[r["iteration"]] = r["samples"]
    out.mkdir(parents=True, exist_ok=True)
    checkpoints = sorted((run / "checkpoints").glob("iter_*.safetensors"))
    for name, dirs in sets.items():
        path = out / f"{name}_checkpoint_evals.jsonl"
        rows = {json.loads(x)["iteration"]: json.loads(x) for x in path.read_text().splitlines()} if path.exists() else {}
        for ck in checkpoints:
            it = int(ck.stem.removeprefix("iter_"))
            if it % every or it in rows:
                continue
            with tempfile.TemporaryDirectory() as tmp:
                report = pathlib.Path(tmp) / "eval.json"
                motion = [a for d in dirs for a in ("--motion", d)]
                subprocess.run([binary, "eval", "--checkpoint", str(ck), *motion, "--each-motion", "--out", str(report)],
                               check=True, stdout=subprocess.DEVNULL)
                rows[it] = row(it, samples.get(it), json.loads(report.read_text()))
            print(name, json.dumps(rows[it]))
        path.write_text("".join(json.dumps(rows[k]) + "\n" for k in sorted(rows)))


if __name__ == "__main__":
    main(sys.argv[1:])
