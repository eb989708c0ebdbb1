"""Tables of scripts/experiments/hlc_multi.sh: reward curves of the single-task high-level
controllers and of the multi-task one (per task), and their evaluations side by side.
Usage: python3 scripts/experiments/hlc_multi_summary.py OUT_DIR"""

from __future__ import annotations

import json
import pathlib
import statistics as st
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "results"))
from runlog import read_run_log, reward_term  # noqa: E402 (scripts/results/runlog.py)

out = pathlib.Path(sys.argv[1])
TASKS = ("heading", "circling")


def rows(run: str) -> list[dict]:
    return read_run_log(out / run) or []


def window(rs: list[dict], name: str, first: bool, w: int = 10) -> float:
    part = rs[:w] if first else rs[-w:]
    return st.mean(reward_term(r, name) for r in part)


def load(path: pathlib.Path) -> dict | None:
    if not path.exists():
        return None
    e = json.loads(path.read_text())
    return e.get("policy", e)


def fmt(e: dict | None, task: str, prefix: str) -> str:
    if e is None:
        return "– | – | – | –"
    fm = e["final_metrics"]
    succ = fm[f"{prefix}success"]
    code = fm.get(f"{prefix}success_code", succ)  # heading: the paper rule is the code latch
    return f"{e['mean_return']:.3f} | {e['mean_reward_per_step']:.4f} | {100 * succ:.1f} % | {100 * code:.1f} %"


print("| controller | samples (this task / all) | task reward / high-level step: first 10 it. → last 10 it. |")
print("|---|---|---|")
for t in TASKS:
    s = rows(t)
    if s:
        print(f"| `{t}` alone (`categorical_mlp` [1024, 512]) | {s[-1]['samples']} / {s[-1]['samples']} | "
              f"{window(s, t, True):.4f} → {window(s, t, False):.4f} |")
m = rows("multi")
for t in TASKS:
    if m:
        n = m[-1]["samples"]
        print(f"| `{t}` in `hlc_multi` (`token_transformer_categorical`) | {n // 2} / {n} | "
              f"{window(m, f'{t}/reward', True):.4f} → {window(m, f'{t}/reward', False):.4f} |")
print("\n| task | controller | return | reward / step | success (paper) | success (code latch) |")
print("|---|---|---|---|---|---|")
for t in TASKS:
    print(f"| {t} | single-task | {fmt(load(out / t / f'eval_{t}.json'), t, '')} |")
    print(f"| {t} | multi-task | {fmt(load(out / 'multi' / f'eval_{t}.json'), t, f'{t}/')} |")
    base = out / t / f"eval_{t}.json"
    if base.exists():
        b = json.loads(base.read_text())
        for actor, e in b.items():
            if actor != "policy":
                print(f"| {t} | {actor} | {fmt(e, t, '')} |")
