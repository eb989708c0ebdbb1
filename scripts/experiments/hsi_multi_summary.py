"""Tables of scripts/experiments/hsi_multi.sh: per-task reward curves of the multi-task run, the
base tasks' evaluation before and after adaptation, and the composition task's curve.
Usage: python3 scripts/experiments/hsi_multi_summary.py OUT_DIR [ADAPT_SUBDIR (default adapt)]"""

from __future__ import annotations

import json
import pathlib
import statistics as st
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "results"))
from runlog import read_run_log, reward_term  # noqa: E402 (scripts/results/runlog.py)

out = pathlib.Path(sys.argv[1])
TASKS = ("hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb")


def rows(run: str) -> list[dict]:
    """Iterations 2.. of a run's log (iteration 1 starts every episode at once, which inflates its
    per-step reward: all environments are in their easy first steps)."""
    log = read_run_log(out / run)
    if log is None:
        sys.exit(f"hsi_multi_summary.py: no log.jsonl(.gz) in {out / run}")
    return log[1:]


def curve(rs: list[dict], name: str, points: int = 6) -> str:
    w = max(1, len(rs) // 40)
    idx = [round(i * (len(rs) - w) / (points - 1)) for i in range(points)]
    return " | ".join(f"{st.mean(reward_term(r, name) for r in rs[i:i + w]):.4f}" for i in idx)


def ev(path: pathlib.Path, task: str) -> str:
    if not path.exists():
        return "– | – | –"
    e = json.loads(path.read_text())
    fm = e["final_metrics"]
    return f"{e['mean_reward_per_step']:.4f} | {e['mean_episode_length']:.1f} | {100 * fm[f'{task}/success']:.1f} % ({fm[f'{task}/error_m']:.2f} m)"


m = rows("multi")
w = max(1, len(m) // 40)
print(f"multi-task run: {m[-1]['iteration']} iterations, {m[-1]['samples']} samples; columns: mean over {w} iterations starting at evenly spaced points (iteration 1 left out)\n")
print("| task reward / step | " + " | ".join(f"it. {round(i * (len(m) - w) / 5) + 2}" for i in range(6)) + " |")
print("|---|" + "---|" * 6)
for t in TASKS:
    print(f"| `{t}` | {curve(m, f'{t}/reward')} |")
print("\n| base task (64 episodes, deterministic) | multi-task policy: reward/step | length | success (error) | after adaptation: reward/step | length | success (error) |")
print("|---|---|---|---|---|---|---|")
for t in TASKS:
    print(f"| `{t}` | {ev(out / 'multi' / f'eval_{t}.json', t)} | {ev(out / (sys.argv[2] if len(sys.argv) > 2 else 'adapt') / f'eval_{t}.json', t)} |")
ADAPT = sys.argv[2] if len(sys.argv) > 2 else "adapt"
if read_run_log(out / ADAPT) is not None:
    a = rows(ADAPT)
    print(f"\nadaptation to hsi_follow_carry ({sys.argv[2] if len(sys.argv) > 2 else 'adapt'}): {a[-1]['iteration']} iterations, {a[-1]['samples']} samples")
    print("| reward / step | " + " | ".join(f"it. {round(i * (len(a) - max(1, len(a) // 40)) / 5) + 2}" for i in range(6)) + " |")
    print("|---|" + "---|" * 6)
    for name in ("hsi_follow_carry/reward", "hsi_follow_carry/follow", "hsi_follow_carry/pick"):
        print(f"| `{name}` | {curve(a, name)} |")
    print(f"\nevaluation of `hsi_follow_carry`: {ev(out / ADAPT / 'eval_hsi_follow_carry.json', 'hsi_follow_carry')}")
