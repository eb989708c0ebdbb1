"""Tables of scripts/experiments/modskill_compare.sh (docs/results-modskill.md, sections 1, 2 and 3):
the training curves of both policy families on the imitation and the tracking task, the tracking
evaluation with the paper's 0.5 m threshold, and the steering runs over the tracking controllers
and over random controllers.

    python3 scripts/experiments/modskill_compare_summary.py OUT_DIR

OUT_DIR holds the script's run folders (or their committed copies: `log.jsonl` or `log.jsonl.gz`,
and the evaluation JSON files beside them). Reward per step is the log's `mean_reward`, averaged
over the iterations named; terms are the log's `reward_terms`."""

from __future__ import annotations

import json
import pathlib
import statistics as st
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "results"))
from runlog import read_run_log, reward_term  # noqa: E402 (scripts/results/runlog.py)

FAMILIES = ("gaussian_mlp", "modular_attention")


def log(folder: pathlib.Path) -> list[dict]:
    rows = read_run_log(folder)
    if rows is None:
        sys.exit(f"modskill_compare_summary.py: no log.jsonl(.gz) in {folder}")
    return rows


def mean(rows: list[dict], first: int, last: int, key) -> float:
    """Mean of key(row) over iterations first..last (1-based, inclusive)."""
    return st.mean(key(r) for r in rows[first - 1:last])


def term(name: str):
    return lambda r: reward_term(r, name)


def windows(n: int) -> list[tuple[int, int]]:
    """The first, middle and last 50 iterations of an n-iteration run."""
    return [(1, 50), (n // 2 - 49, n // 2), (n - 49, n)]


def curve_table(out: pathlib.Path, task: str, extra_terms: tuple[str, ...]) -> None:
    runs = {fam: log(out / f"{task}-{fam}") for fam in FAMILIES}
    n = min(len(r) for r in runs.values())
    ws = windows(n)
    head = " | ".join(f"reward/step, it. {a}–{b}" for a, b in ws)
    terms = " | ".join([f"{t} term, it. 1–50 → {n - 49}–{n}" for t in extra_terms] + [f"episode length, it. 1–50 → {n - 49}–{n}"])
    print(f"\n{task} ({n} iterations, {runs[FAMILIES[0]][n - 1]['samples']} samples each)")
    print(f"| family | {head} | {terms} |")
    print("|---|" + "---|" * (len(ws) + len(extra_terms) + 1))
    for fam, rows in runs.items():
        cells = [f"{mean(rows, a, b, lambda r: r['mean_reward']):.4f}" for a, b in ws]
        cells += [f"{mean(rows, 1, 50, term(t)):.3f} → {mean(rows, n - 49, n, term(t)):.3f}" for t in extra_terms]
        length = lambda r: r["episode_length"]  # noqa: E731 (mean steps of the episodes that ended)
        cells.append(f"{mean(rows, 1, 50, length):.1f} → {mean(rows, n - 49, n, length):.1f}")
        print(f"| `{fam}` | " + " | ".join(cells) + " |")


def tracking_eval(out: pathlib.Path) -> None:
    print("\ntracking evaluation (whole clips from frame 0, termination 0.5 m)")
    print("| family | episodes | success | E_g-mpjpe | E_mpjpe | E_vel | E_acc | episode length |")
    print("|---|---|---|---|---|---|---|---|")
    for fam in FAMILIES:
        p = out / f"tracking-{fam}-eval05.json"
        if not p.exists():
            print(f"| `{fam}` | – (no {p.name}) |||||||")
            continue
        e = json.loads(p.read_text())
        m = e["metrics"]
        print(f"| `{fam}` | {e['episodes']} | {100 * m['success']:.1f} % | {m['g_mpjpe_mm']:.0f} mm | {m['mpjpe_mm']:.0f} mm "
              f"| {m['vel_err_mm']:.1f} mm/frame | {m['acc_err_mm']:.1f} mm/frame² | {e['mean_episode_length']:.1f} |")


def steering(out: pathlib.Path) -> None:
    print("\nsteering over frozen modular_attention controllers")
    print("| frozen controllers | reward/step it. 1–15 → last 15 | eval episodes | eval reward/step | eval length | eval metrics |")
    print("|---|---|---|---|---|---|")
    for llc in ("tracking", "random"):
        folder = out / f"steering-{llc}"
        if not folder.exists():
            print(f"| {llc} | – |||||")
            continue
        rows = log(folder)
        n = len(rows)
        first, last = mean(rows, 1, 15, lambda r: r["mean_reward"]), mean(rows, n - 14, n, lambda r: r["mean_reward"])
        e = json.loads((folder / "metrics.json").read_text())
        metrics = ", ".join(f"{k} {v:.3f}" for k, v in sorted(e.get("metrics", {}).items()))
        print(f"| {llc} | {first:.3f} → {last:.3f} | {e['episodes']} | {e['mean_reward_per_step']:.3f} "
              f"| {e['mean_episode_length']:.1f} | {metrics} |")


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = pathlib.Path(sys.argv[1])
    curve_table(out, "imitation", ())
    curve_table(out, "tracking", ("pos", "power"))
    tracking_eval(out)
    steering(out)


if __name__ == "__main__":
    main()
