"""Time to skill (issue 41, docs/throughput.md): samples and wall-clock until a run first meets the
skill criterion, from its checkpoint evaluations (`scripts/results/eval_checkpoints.py` with
KINDS=eps,random) and the end-to-end rate of its configuration measured on a quiet machine
(`skillmimic bench train --preset A --against B`, both presets in the same rounds).

Criterion (the issue's, until SkillMimic's 10-s success suits a 1.35-s clip): at one checkpoint
  - completed from the clip's start with the mean action and start noise 0.01 in >= 90 % of 64
    episodes (`start_eps001_completed_pct`), and
  - E_b-mpjpe from random frames <= 200 mm (`e_b_mm`, 64 episodes).
Wall-clock to the criterion = samples at that checkpoint / the quiet rate (samples/s). A run's own
logged time is printed beside it but not used: the runs share the 2-core machine with each other.

Learning-curve screening: the mean reward per step over the 204 800 samples up to each mark of
MARKS (the variants differ in samples per iteration, so the curves are compared per sample).

Plateau metrics: the mean of the last K evaluated checkpoints (K = 4) of each run, so that a
variant cannot win by stopping at a lower level than the baseline. On the command line the runs of
one clip are compared at equal samples: each run's last K checkpoints up to the samples the
shortest of them was evaluated to (`plateau_end_samples`); a run's own last K beside them
(`final_*`).

    python3 scripts/experiments/time_to_skill.py RATES.json RUN_DIR [RUN_DIR ...] [--json OUT]

RATES.json maps a run folder's name prefix (its preset label, e.g. "run-small", "run-cpu") to the
samples/s of its configuration; the longest matching prefix applies.

Per clip, for run folders named CLIP-PRESET-sSEED (what time_to_skill.sh writes), it also prints the
issue's comparison: the median over seeds of each preset's hours to the criterion, their ratio
(cpu ÷ small; the target is <= 1/3) and whether cpu's plateau metrics lie within the seed spread of
small's or better (completion and Acc not lower than small's lowest seed, E_b not higher than its
highest). A seed that has not met the criterion makes its preset's median unknown (None); since it
would meet it after the samples it was evaluated to, if at all, those samples bound its hours from
below, and a median is non-decreasing in each seed's value, so the comparison also gives the
median's lower bound (`median_hours_at_least`) and, where only one preset has such a seed, the bound
this puts on the ratio (`ratio_at_most` when `small` has it, `ratio_at_least` when `cpu` has it).
"""

from __future__ import annotations

import json
import pathlib
import re
import statistics
import sys

COMPLETION_PCT = 90.0
E_B_MM = 200.0
PLATEAU_K = 4


def rows(path: pathlib.Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def first_meeting(evals: list[dict]) -> dict | None:
    """The first evaluated checkpoint that meets both parts of the criterion."""
    for r in sorted(evals, key=lambda r: r["samples"]):
        if r.get("start_eps001_completed_pct", 0.0) >= COMPLETION_PCT and r.get("e_b_mm", 1e9) <= E_B_MM:
            return r
    return None


def median(v: list[float]) -> float | None:
    """The median rounded to 4 decimals, None for no values."""
    return round(statistics.median(v), 4) if v else None


def logged_seconds(log: list[dict], samples: int) -> float:
    """Rollout + update seconds the run logged up to `samples` (shared machine: not published)."""
    return sum(r["rollout_s"] + r["update_s"] for r in log if r["samples"] <= samples)


MARKS = [0.4096e6, 0.8192e6, 1.2288e6, 1.6384e6, 2.4576e6, 3.2768e6, 4.9152e6]


def reward_at(log: list[dict], samples: float, window: float = 204800) -> float | None:
    """Mean reward per step of the iterations whose samples lie in (samples - window, samples]."""
    near = [r["mean_reward"] for r in log if samples - window < r["samples"] <= samples]
    return round(sum(near) / len(near), 4) if near and log[-1]["samples"] >= samples else None


def summary(run: pathlib.Path, rate: float, end: float | None = None) -> dict:
    """One run's time to the criterion and its plateau: the last K checkpoints up to `end`
    samples (None: all), and its own last K (`final_*`)."""
    evals = rows(run / "checkpoint_evals.jsonl")
    log = rows(run / "log.jsonl")
    hit = first_meeting(evals)
    ordered = sorted(evals, key=lambda r: r["samples"])
    tail = [r for r in ordered if end is None or r["samples"] <= end][-PLATEAU_K:]
    mean = lambda k, rs=tail: round(sum(r[k] for r in rs) / len(rs), 2)  # noqa: E731
    last = ordered[-PLATEAU_K:]
    out = {
        "run": run.name,
        "rate_samples_per_s": rate,
        "evaluated_to_samples": ordered[-1]["samples"],
        "plateau_end_samples": tail[-1]["samples"],
        "final_completion_pct": mean("start_eps001_completed_pct", last),
        "final_e_b_mm": mean("e_b_mm", last),
        "final_acc_pct": mean("acc_pct", last),
        "criterion_samples": hit["samples"] if hit else None,
        "criterion_iteration": hit["iteration"] if hit else None,
        "criterion_hours": round(hit["samples"] / rate / 3600, 3) if hit else None,
        "criterion_logged_hours_shared_machine": round(logged_seconds(log, hit["samples"]) / 3600, 3) if hit else None,
        "plateau_checkpoints": [r["iteration"] for r in tail],
        "plateau_completion_pct": mean("start_eps001_completed_pct"),
        "plateau_e_b_mm": mean("e_b_mm"),
        "plateau_acc_pct": mean("acc_pct"),
        "plateau_reward_per_step": round(sum(r["reward_per_step"] for r in tail) / len(tail), 4),
        "reward_per_step_at_samples": {f"{m / 1e6:.2f}M": reward_at(log, m) for m in MARKS},
        # how far one update moves the policy: medians over the first 0.82 M samples
        "median_approx_kl_first_0.82M": median([r["approx_kl"] for r in log if r["samples"] <= 819200]),
        "median_clip_frac_first_0.82M": median([r["clip_frac"] for r in log if r["samples"] <= 819200]),
    }
    return out


NAME = re.compile(r"^(?P<clip>.+)-(?P<preset>[^-]+)-s(?P<seed>\d+)$")


def clip_of(name: str) -> str:
    """The clip of a run folder named CLIP-PRESET-sSEED (any other name is its own group)."""
    m = NAME.match(name)
    return m["clip"] if m else name


def compare(results: list[dict], base: str = "small", fast: str = "cpu") -> dict:
    """The issue's comparison per clip: median hours to the criterion per preset and their ratio,
    and whether `fast`'s plateau lies within `base`'s seed spread or better."""
    by: dict[str, dict[str, list[dict]]] = {}
    for r in results:
        m = NAME.match(r["run"])
        if m and m["preset"] in (base, fast):
            by.setdefault(m["clip"], {}).setdefault(m["preset"], []).append(r)
    out = {}
    for clip, presets in sorted(by.items()):
        if base not in presets or fast not in presets:
            continue
        hours = {p: [r["criterion_hours"] for r in presets[p]] for p in (base, fast)}
        med = {p: None if None in h else median(h) for p, h in hours.items()}
        # unmet seeds at the hours they were evaluated to: a lower bound on each preset's median
        floor = {
            p: median([r["criterion_hours"] if r["criterion_hours"] is not None
                       else r["evaluated_to_samples"] / r["rate_samples_per_s"] / 3600 for r in presets[p]])
            for p in (base, fast)
        }
        bound = {}
        if med[base] is None and med[fast] is not None:
            bound["ratio_at_most"] = round(med[fast] / floor[base], 3)
        if med[fast] is None and med[base] is not None:
            bound["ratio_at_least"] = round(floor[fast] / med[base], 3)
        b = presets[base]
        spread_ok = all(
            min(r["plateau_completion_pct"] for r in b) <= f["plateau_completion_pct"]
            and min(r["plateau_acc_pct"] for r in b) <= f["plateau_acc_pct"]
            and f["plateau_e_b_mm"] <= max(r["plateau_e_b_mm"] for r in b)
            for f in presets[fast]
        )
        out[clip] = {
            "seeds": {p: len(presets[p]) for p in (base, fast)},
            "criterion_hours": hours,
            "median_hours": med,
            "ratio": round(med[fast] / med[base], 3) if med[fast] is not None and med[base] else None,
            "median_hours_at_least": floor,
            **bound,
            f"{fast}_plateau_within_{base}_spread_or_better": spread_ok,
        }
    return out


def main() -> None:
    args = sys.argv[1:]
    out_json = None
    if "--json" in args:
        k = args.index("--json")
        out_json = pathlib.Path(args[k + 1])
        del args[k : k + 2]
    if len(args) < 2:
        sys.exit("usage: time_to_skill.py RATES.json RUN_DIR [RUN_DIR ...] [--json OUT]")
    rates = json.loads(pathlib.Path(args[0]).read_text())
    dirs = list(map(pathlib.Path, args[1:]))
    # per clip, the samples the shortest run was evaluated to: the plateaus compare there
    ends: dict[str, float] = {}
    for d in dirs:
        top = max(r["samples"] for r in rows(d / "checkpoint_evals.jsonl"))
        ends[clip_of(d.name)] = min(ends.get(clip_of(d.name), top), top)
    results = []
    for d in dirs:
        prefix = max((p for p in rates if d.name.startswith(p)), key=len, default=None)
        if prefix is None:
            sys.exit(f"{args[0]}: no rate for run folder {d.name} (keys: {sorted(rates)})")
        s = summary(d, float(rates[prefix]), ends[clip_of(d.name)])
        results.append(s)
        hit = f"{s['criterion_samples'] / 1e6:.2f} M samples, {s['criterion_hours']:.2f} h" if s["criterion_samples"] else "not met"
        print(f"{s['run']}: criterion {hit} (evaluated to {s['evaluated_to_samples'] / 1e6:.2f} M); plateau (last {PLATEAU_K} "
              f"to {s['plateau_end_samples'] / 1e6:.2f} M) completion {s['plateau_completion_pct']} %, E_b {s['plateau_e_b_mm']} mm, "
              f"Acc {s['plateau_acc_pct']} %; own last {PLATEAU_K}: {s['final_completion_pct']} %, {s['final_e_b_mm']} mm, "
              f"{s['final_acc_pct']} %")
    comparison = compare(results)
    for clip, c in comparison.items():
        ratio = "unknown (a seed has not met the criterion)" if c["ratio"] is None else f"{c['ratio']:.3f}"
        if "ratio_at_most" in c:
            ratio += f", at most {c['ratio_at_most']:.3f} (small's unmet seeds at the samples evaluated)"
        if "ratio_at_least" in c:
            ratio += f", at least {c['ratio_at_least']:.3f} (cpu's unmet seeds at the samples evaluated)"
        print(f"{clip}: median hours to the criterion {c['median_hours']} over seeds {c['seeds']}; ratio cpu/small {ratio}; "
              f"cpu plateau within small's seed spread or better: {c['cpu_plateau_within_small_spread_or_better']}")
    if out_json:
        out_json.write_text(json.dumps({"runs": results, "comparison": comparison}, indent=1) + "\n")


if __name__ == "__main__":
    main()
