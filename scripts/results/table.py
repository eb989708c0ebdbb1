"""Markdown table of a results run's checkpoint metrics (docs/results.md), from the
checkpoint_evals.jsonl that scripts/results/eval_checkpoints.py writes.

    python3 scripts/results/table.py runs/results/run/checkpoint_evals.jsonl --every 100
"""

from __future__ import annotations

import argparse
import json
import pathlib


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("evals", type=pathlib.Path)
    ap.add_argument("--every", type=int, default=100, help="rows at multiples of this iteration (and the last)")
    a = ap.parse_args()
    rows = [json.loads(line) for line in a.evals.read_text().splitlines() if line.strip()]
    rows.sort(key=lambda r: r["iteration"])
    keep = [r for r in rows if r["iteration"] % a.every == 0]
    if rows and (not keep or keep[-1] is not rows[-1]):
        keep.append(rows[-1])
    print("| iteration (samples) | reward/step | from the start, mean action, start ±0.01: completed % / score | sampled actions: completed % | "
          "mean action, exact start: steps | random frames: Acc % | E_b mm | E_o mm | E_cg | NR | falls % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in keep:
        mean = f"{r['start_mean_action_length']:.0f}, " + ("fell" if r["start_mean_action_fell"] else "completed")
        score = "–" if r.get("start_eps001_v1_score") is None else f"{r['start_eps001_v1_score']:.2f}"
        print(f"| {r['iteration']} ({r['samples'] / 1e6:.2f} M) | {r['reward_per_step']:.3f} | {r['start_eps001_completed_pct']:.1f} / {score} | "
              f"{r['start_sampled_completed_pct']:.1f} | {mean} | {r['acc_pct']:.1f} | {r['e_b_mm']:.0f} | {r['e_o_mm']:.0f} | {r['e_cg']:.3f} | "
              f"{r['nr']:.3f} | {r['falls_pct']:.1f} |")

if __name__ == "__main__":
    main()
