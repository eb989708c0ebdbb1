"""What budget a run's trend suggests (issue 42: "what budget the trend suggests" when a method
has not reached a level yet): a straight line fitted to a metric of a run's checkpoint
evaluations against log10(samples), over the last part of the run, and the samples at which that
line reaches a target.

    python3 scripts/results/trend.py --metric start_eps001_completed_pct --target 90 RUN_DIR ...
    python3 scripts/results/trend.py --metric e_b_mm --target 200 --last 0.5 docs/results/runs/layup-*/

Each argument is a run folder holding checkpoint_evals.jsonl (scripts/results/eval_checkpoints.py)
or such a file. Prints one JSON object per run:
  - window: the first and last samples of the checkpoints fitted (the last `--last` fraction of
    the evaluated samples, at least 4 checkpoints);
  - slope_per_decade: the fitted change of the metric per tenfold samples; last_fit: the line at
    the last checkpoint;
  - target_reached_at: the first evaluated samples where the metric itself reached the target
    (>= when the target lies above the run's first evaluation, <= when below; `--lower-is-better`
    says it outright), else null;
  - extrapolated_samples: where the line reaches the target, when the run has not reached it and
    the line moves towards it; null otherwise, with `why`.
This is a log-linear extrapolation of a noisy curve, not a prediction: it names the order of
magnitude the trend points to, and says when the trend points nowhere (flat or moving away).
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import statistics
import sys


def rows(path: pathlib.Path) -> list[dict]:
    f = path / "checkpoint_evals.jsonl" if path.is_dir() else path
    if not f.is_file():
        sys.exit(f"trend.py: {f} not found (scripts/results/eval_checkpoints.py writes it)")
    return [json.loads(line) for line in f.read_text().splitlines() if line.strip()]


def trend(points: list[tuple[float, float]], target: float, last: float = 0.5, lower_is_better: bool | None = None) -> dict:
    """Fit `metric ~ a + b · log10(samples)` to the points (samples, metric) in the last `last`
    fraction of the evaluated samples (at least 4 points) and extrapolate to `target`; the
    metric improves downwards when `lower_is_better`, or (None) when the target lies below the
    run's first evaluation."""
    pts = sorted((s, m) for s, m in points if s > 0 and m is not None and math.isfinite(m))
    if len(pts) < 4:
        return {"points": len(pts), "extrapolated_samples": None, "why": "fewer than 4 evaluated checkpoints"}
    end = pts[-1][0]
    window = [p for p in pts if p[0] >= end * (1 - last)]
    if len(window) < 4:
        window = pts[-4:]
    xs = [math.log10(s) for s, _ in window]
    ys = [m for _, m in window]
    rising = target > pts[0][1] if lower_is_better is None else not lower_is_better
    reached = next((s for s, m in pts if (m >= target if rising else m <= target)), None)
    out = {"points": len(window), "window": [window[0][0], window[-1][0]], "target_reached_at": reached}
    if len(set(xs)) < 2:
        return {**out, "extrapolated_samples": None, "why": "one sample count only"}
    slope, intercept = statistics.linear_regression(xs, ys)
    fit_end = intercept + slope * xs[-1]
    out |= {"slope_per_decade": round(slope, 4), "last_fit": round(fit_end, 4)}
    if reached is not None:
        return {**out, "extrapolated_samples": None, "why": "reached"}
    if slope == 0 or (slope > 0) != rising:
        return {**out, "extrapolated_samples": None, "why": "the trend does not move towards the target"}
    return {**out, "extrapolated_samples": round(10 ** ((target - intercept) / slope)), "why": "extrapolated"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--metric", required=True, help="a field of checkpoint_evals.jsonl, e.g. start_eps001_completed_pct")
    ap.add_argument("--target", required=True, type=float)
    ap.add_argument("--lower-is-better", action="store_true", default=None,
                    help="the metric improves downwards (an error); default: the target's side of the first evaluation")
    ap.add_argument("--last", type=float, default=0.5, help="fraction of the evaluated samples fitted (default 0.5)")
    ap.add_argument("runs", nargs="+", type=pathlib.Path)
    a = ap.parse_args()
    if not 0 < a.last <= 1:
        sys.exit(f"trend.py: --last {a.last}: expected a fraction in (0, 1]")
    for run in a.runs:
        data = rows(run)
        if data and not any(a.metric in r for r in data):
            sys.exit(f"trend.py: {run}: no row has the field '{a.metric}' (fields: {sorted(data[0])})")
        pts = [(r["samples"], r[a.metric]) for r in data if a.metric in r]
        print(json.dumps({"run": str(run), "metric": a.metric, "target": a.target, **trend(pts, a.target, a.last, a.lower_is_better)}))


if __name__ == "__main__":
    main()
