"""Metrics along a results run (issue 22, docs/results.md): evaluate every EVERY-th checkpoint of
OUT/NAME/checkpoints and keep one JSON line per checkpoint in OUT/NAME/checkpoint_evals.jsonl.

Evaluations per checkpoint (64 episodes each, seed 7):
  - "sampled": from the clip's first usable frame (2) to its end with sampled actions (the
    policy's σ): completion rate (no fall), E_b-mpjpe;
  - "mean": the same with the mean action. Physics and policy are deterministic, so its episodes
    are one trajectory;
  - "eps": the mean action from frame 2 with the start state perturbed by ε = 0.01 per component
    (`--init-noise`: 1 cm, 0.01 rad, 0.01 m/s, 0.01 rad/s), so that deterministic episodes
    differ: completion rate, the skill's SkillMimic success score and, per skill with falls, the
    median clip frame where they ended (`start_eps001_fall_frame_median`; rows evaluated before
    stop 74 lack it);
  - "random": from random frames as in training: Acc, E_b/E_o-mpjpe, E_cg, NR, falls.
A row that lacks an evaluation added later gets only that one run and is completed in place.

    python3 scripts/results/eval_checkpoints.py run                 # every 25th checkpoint
    EVERY=100 BIN=target/release/skillmimic python3 scripts/results/eval_checkpoints.py pickup
    KINDS=eps,random OUT=runs/tts python3 scripts/results/eval_checkpoints.py run-cpu-s0   # a subset
"""

from __future__ import annotations

import fcntl
import json
import os
import pathlib
import subprocess
import sys
import tempfile

FROM_START = ["--start-frame", "2", "--set", "env.episode_length=100000"]
EVALS = {
    "sampled": [*FROM_START, "--stochastic"],
    "mean": FROM_START,
    "eps": [*FROM_START, "--init-noise", "0.01"],
    "random": [],
}


def v1_score(nominal: dict) -> float | None:
    """The SkillMimic success score of the clip's (single) skill, None if it has no rule."""
    scores = [s["v1_score"] for s in nominal["per_skill"].values() if s["v1_score"] is not None]
    return round(sum(scores) / len(scores), 4) if scores else None


def fall_frame_medians(nominal: dict) -> dict[str, int]:
    """Per skill with falls: the median clip frame where they ended (eval's `fall_frames`)."""
    return {k: s["fall_frames"]["median"] for k, s in nominal["per_skill"].items() if s.get("fall_frames")}


def fields(kind: str, n: dict) -> dict:
    """The row's fields of one evaluation's nominal report."""
    if kind == "sampled":
        return {"start_sampled_completed_pct": round(100 * (1 - n["fall_rate"]), 2), "start_sampled_e_b_mm": round(n["e_b_mpjpe_mm"], 1),
                "start_sampled_mean_length": round(n["mean_episode_length"], 1)}
    if kind == "mean":
        return {"start_mean_action_fell": n["fall_rate"] > 0.5, "start_mean_action_length": n["mean_episode_length"],
                "start_mean_action_e_b_mm": round(n["e_b_mpjpe_mm"], 1), "start_mean_action_v1_score": v1_score(n)}
    if kind == "eps":
        return {"start_eps001_completed_pct": round(100 * (1 - n["fall_rate"]), 2), "start_eps001_e_b_mm": round(n["e_b_mpjpe_mm"], 1),
                "start_eps001_v1_score": v1_score(n), "start_eps001_fall_frame_median": fall_frame_medians(n)}
    return {"acc_pct": round(n["acc_percent"], 2), "e_b_mm": round(n["e_b_mpjpe_mm"], 1), "e_o_mm": round(n["e_o_mpjpe_mm"], 1),
            "e_cg": round(n["e_cg"], 4), "nr": round(n["nr"], 4), "falls_pct": round(100 * n["fall_rate"], 2)}


KEY = {"sampled": "start_sampled_completed_pct", "mean": "start_mean_action_v1_score", "eps": "start_eps001_completed_pct", "random": "acc_pct"}


def evaluate(binary: str, ck: pathlib.Path, flags: list[str], tmp: pathlib.Path) -> dict:
    out = tmp / "eval.json"
    subprocess.run([binary, "eval", "--checkpoint", str(ck), "--episodes", "64", "--seed", "7", *flags, "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.loads(out.read_text())["nominal"]


def main() -> None:
    name = sys.argv[1] if len(sys.argv) == 2 else sys.exit("usage: eval_checkpoints.py NAME")
    root = pathlib.Path(__file__).resolve().parents[2]
    binary = os.environ.get("BIN", str(root / "target/release/skillmimic"))
    run = pathlib.Path(os.environ.get("OUT", root / "runs/results")) / name
    every = int(os.environ.get("EVERY", "25"))
    kinds = os.environ.get("KINDS", ",".join(EVALS)).split(",")
    if unknown := [k for k in kinds if k not in EVALS]:
        sys.exit(f"KINDS: unknown evaluation(s) {unknown}, expected some of {list(EVALS)}")
    table = run / "checkpoint_evals.jsonl"
    log_file = run / "log.jsonl"
    log = [json.loads(line) for line in (log_file.read_text().splitlines() if log_file.exists() else []) if line.strip()]
    if not log:  # a run that has just started: nothing to evaluate yet (the evaluation loops call again)
        print(f"eval_checkpoints.py: {log_file} has no iteration yet", file=sys.stderr)
        return
    per_it = log[0]["samples"] // log[0]["iteration"]
    with tempfile.TemporaryDirectory() as tmp:
        for ck in sorted((run / "checkpoints").glob("iter_*.safetensors")):
            it = int(ck.stem.removeprefix("iter_"))
            if it % every:
                continue
            row = read_rows(table).get(it) or {"iteration": it, "samples": it * per_it}
            missing = [k for k in kinds if KEY[k] not in row]
            if not missing:
                continue
            near = [r["mean_reward"] for r in log if it - 25 < r["iteration"] <= it]
            new = {"reward_per_step": round(sum(near) / max(1, len(near)), 5)}
            for kind in missing:
                new.update(fields(kind, evaluate(binary, ck, EVALS[kind], pathlib.Path(tmp))))
            print(json.dumps(merge(table, it, {"iteration": it, "samples": it * per_it, **new})), flush=True)


def read_rows(table: pathlib.Path) -> dict[int, dict]:
    """The table's rows by iteration ({} before the first)."""
    lines = table.read_text().splitlines() if table.exists() else []
    return {r["iteration"]: r for r in (json.loads(line) for line in lines if line.strip())}


def merge(table: pathlib.Path, it: int, fields_: dict) -> dict:
    """Add `fields_` to the row of iteration `it` and rewrite the table whole (a new file replaces
    the old: never half written). The table is read again under an exclusive lock, so that two
    evaluators of one run (a watcher beside time_to_skill.sh's own pass) keep each other's rows."""
    with open(table.with_suffix(".jsonl.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        rows = read_rows(table)
        row = {**rows.get(it, {}), **fields_}
        rows[it] = row
        part = table.with_suffix(".jsonl.part")
        part.write_text("".join(json.dumps(rows[k]) + "\n" for k in sorted(rows)))
        part.replace(table)
    return row


if __name__ == "__main__":
    main()
