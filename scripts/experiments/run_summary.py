"""One summary line per training run folder (log.jsonl + eval.json), for the comparison scripts:
reward per step over the last tenth of the iterations, the nominal evaluation (NR, Acc, E_cg, falls)
and the mean samples/s.

    python3 scripts/experiments/run_summary.py RUN_DIR [RUN_DIR ...]
"""

import json
import pathlib
import sys


def summary(run: pathlib.Path) -> str:
    rows = [json.loads(line) for line in (run / "log.jsonl").read_text().splitlines() if line.strip()]
    tail = rows[-max(1, len(rows) // 10):]
    ev = json.loads((run / "eval.json").read_text())["nominal"]
    sps = sum(r["samples_per_s"] for r in rows) / len(rows)
    return (f"{run.name}: reward/step last 10 % {sum(r['mean_reward'] for r in tail) / len(tail):.4f}, NR {ev['nr']:.4f}, "
            f"Acc {ev['acc_percent']:.1f} %, E_cg {ev['e_cg']:.3f}, falls {100 * ev['fall_rate']:.1f} %, mean {sps:.0f} samples/s")


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(summary(pathlib.Path(arg)))
