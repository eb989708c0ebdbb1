"""Table of scripts/experiments/hsi_survival.sh: per task and build, the training episode length
(mean over the first and the last 25 iterations of log.jsonl or log.jsonl.gz) and the evaluation's
episode length, early-end rate and success (eval.json).

Usage: python scripts/experiments/hsi_survival_summary.py DIR   (DIR/<build label>/<task>/...)
"""

import gzip
import json
import pathlib
import sys

TASKS = ["hsi_follow", "hsi_sit", "hsi_climb", "hsi_carry"]


def log_rows(d: pathlib.Path) -> list[dict]:
    p = d / "log.jsonl"
    text = p.read_text() if p.exists() else gzip.decompress((d / "log.jsonl.gz").read_bytes()).decode()
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def main(root: pathlib.Path) -> None:
    print("| task | build | training episode length, first → last 25 iterations (steps) "
          "| eval episode length (steps) | eval ended early | eval success |")
    print("|---|---|---|---|---|---|")
    for task in TASKS:
        labels = [p.name for p in root.iterdir() if (p / task).is_dir()]
        order = {"before": 0, "after": 1}
        for label in sorted(labels, key=lambda name: (order.get(name, 2), name)):
            d = root / label / task
            rows = log_rows(d)
            first = sum(r["episode_length"] for r in rows[:25]) / 25
            last = sum(r["episode_length"] for r in rows[-25:]) / 25
            ev = json.loads((d / "eval.json").read_text())
            print(f"| `{task}` | {label} | {first:.1f} → {last:.1f} | {ev['mean_episode_length']:.1f} "
                  f"({ev['mean_episode_length'] / 30:.2f} s) | {100 * ev['early_termination_rate']:.0f} % "
                  f"| {100 * ev['final_metrics']['success']:.1f} % |")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
