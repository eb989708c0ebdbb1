"""Table of the fidelity ablation (scripts/experiments/fidelity_ablation.sh) as markdown.

For every (setting, clip): the mean over seeds (and each seed) of the training reward per step
over the last 10 % of iterations, and of the deterministic evaluation after the budget: NR (mean
reward per step), Acc, E_cg and the fall rate. V1 rows are also evaluated under the papers'
force-threshold graph (eval_ft.json) so that Acc and E_cg use one yardstick; V2 rows add the
SkillMimic-V2 success rates (eval_v2.json: SR, εNSR with each run's own noise).

    python scripts/experiments/fidelity_summary.py runs/fidelity > table.md
"""

from __future__ import annotations

import json
import pathlib
import sys

SETTINGS = [
    ("v1_force_threshold", "SkillMimic, contact graph `force_threshold` (default)"),
    ("v1_exact", "SkillMimic, contact graph `exact`"),
    ("v2_paper", "SkillMimic-V2 STF, `compat = paper` (default)"),
    ("v2_code", "SkillMimic-V2 STF, `compat = code`"),
]
CLIPS = ["run", "layup"]
SEEDS = [0, 1]


def last_reward(run: pathlib.Path) -> float:
    rows = [json.loads(line) for line in (run / "log.jsonl").read_text().splitlines() if line.strip()]
    tail = rows[-max(1, len(rows) // 10):]
    return sum(r["mean_reward"] for r in tail) / len(tail)


def load(run: pathlib.Path, name: str) -> dict | None:
    p = run / name
    return json.loads(p.read_text()) if p.exists() else None


def fmt(vals: list[float], scale: float = 1.0, digits: int = 3) -> str:
    vals = [v * scale for v in vals]
    if not vals:
        return "–"
    mean = sum(vals) / len(vals)
    each = " / ".join(f"{v:.{digits}f}" for v in vals)
    return f"{mean:.{digits}f} ({each})"


def main(root: pathlib.Path) -> None:
    print("| setting | clip | reward/step, last 10 % | NR | Acc % | E_cg | falls % | Acc % / E_cg (force-threshold yardstick) | SR / εNSR (V2) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for key, label in SETTINGS:
        for clip in CLIPS:
            runs = [root / f"{key}-{clip}-s{s}" for s in SEEDS]
            runs = [r for r in runs if (r / "log.jsonl").exists()]
            if not runs:
                continue
            ev = [load(r, "eval.json") for r in runs]
            ev = [e["nominal"] for e in ev if e]
            ft = [load(r, "eval_ft.json") for r in runs]
            ft = [e["nominal"] for e in ft if e]
            v2 = [load(r, "eval_v2.json") for r in runs]
            v2 = [e["v2"] for e in v2 if e and e.get("v2")]
            yard = f"{fmt([e['acc_percent'] for e in ft], digits=1)} / {fmt([e['e_cg'] for e in ft])}" if ft else "–"
            sr = f"{fmt([e['sr_mean'] for e in v2], 100, 1)} / {fmt([e['eps_nsr_mean'] for e in v2], 100, 1)}" if v2 else "–"
            print(
                f"| {label} | {clip} | {fmt([last_reward(r) for r in runs], digits=4)} | {fmt([e['nr'] for e in ev], digits=4)} "
                f"| {fmt([e['acc_percent'] for e in ev], digits=1)} | {fmt([e['e_cg'] for e in ev])} | {fmt([e['fall_rate'] for e in ev], 100, 1)} "
                f"| {yard} | {sr} |"
            )


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "runs/fidelity"))
