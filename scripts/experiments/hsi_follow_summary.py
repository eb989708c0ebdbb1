"""Summary of a follow run of scripts/experiments/hsi_follow_released.sh (docs/results-tokenhsi.md):
per-50-iteration means of the training log and one line per evaluation JSON of the folder
(`eval_{reference,rest}_start_itN.json`, 256 deterministic episodes each).
Usage: python3 scripts/experiments/hsi_follow_summary.py FOLDER   (a run folder or its committed copy)

Columns of the training part (unweighted means over the block's iterations): the mean training
episode length (steps of 1/30 s), the fraction of ended episodes that ended early, and the per-step
reward terms `follow`, `power` and `style` (the motion prior's reward, before its weight).
"mean samples/s" is the mean of the iterations' own rates (rollout + update); "rollout + update"
is the sum of those times, in hours (checkpoint saves and start-up are not in the log)."""

from __future__ import annotations

import json
import pathlib
import re
import statistics as st
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "results"))
from runlog import read_run_log, reward_term  # noqa: E402 (scripts/results/runlog.py)

BLOCK = 50


def training_lines(rows: list[dict], log_name: str) -> list[str]:
    out = [
        f"# per-{BLOCK}-iteration means of {log_name} (episode length in steps, per-step reward terms) "
        "and the eval JSONs of this folder",
        f"iters {rows[-1]['iteration']} samples {rows[-1]['samples']} mean samples/s "
        f"{st.mean(r['samples_per_s'] for r in rows):.0f} rollout + update "
        f"{sum(r['rollout_s'] + r['update_s'] for r in rows) / 3600:.2f} h",
    ]
    for start in range(0, len(rows), BLOCK):
        b = rows[start : start + BLOCK]
        out.append(
            f"it {b[0]['iteration']}-{b[-1]['iteration']}: "
            f"eplen {st.mean(r['episode_length'] for r in b):.1f} "
            f"early {st.mean(r['early_terminations'] for r in b):.3f} "
            + " ".join(f"{n} {st.mean(reward_term(r, n) for r in b):.3f}" for n in ("follow", "power", "style"))
        )
    return out


def evaluation_lines(folder: pathlib.Path) -> list[str]:
    found = []
    for p in folder.glob("eval_*_start_it*.json"):
        m = re.fullmatch(r"eval_(reference|rest)_start_it(\d+)\.json", p.name)
        if m:
            found.append((int(m.group(2)), m.group(1) != "reference", m.group(1), p))
    out = []
    for it, _, start, p in sorted(found):
        e = json.loads(p.read_text())
        out.append(
            f"it {it} {start} starts: len {e['mean_episode_length']:.1f} "
            f"ended early {e['early_termination_rate']:.3f} "
            f"success {e['final_metrics']['success']:.4f} "
            f"error mean {e['metrics']['error_m']:.3f} at end {e['final_metrics']['error_m']:.3f}"
        )
    return out


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    folder = pathlib.Path(sys.argv[1])
    rows = read_run_log(folder)
    if not rows:
        sys.exit(f"hsi_follow_summary.py: no log.jsonl(.gz) with rows in {folder}")
    log_name = "log.jsonl" if (folder / "log.jsonl").exists() else "log.jsonl.gz"
    print("\n".join(training_lines(rows, log_name) + evaluation_lines(folder)))


if __name__ == "__main__":
    main()
