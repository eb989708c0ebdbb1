#!/usr/bin/env bash
# Metrics along a results run (issue 22, docs/results.md): evaluate every EVERY-th checkpoint of
# OUT/NAME/checkpoints with the protocol's evaluations and append one JSON line per checkpoint to
# OUT/NAME/checkpoint_evals.jsonl (checkpoints already in it are skipped):
#   - from the clip's first usable frame (2) to its end, 64 episodes with sampled actions:
#     completion rate (no fall) and E_b-mpjpe;
#   - the same with the mean action (deterministic: one trajectory);
#   - 64 episodes from random frames as in training: Acc, E_b/E_o-mpjpe, E_cg, NR, falls.
#   scripts/results/eval_checkpoints.sh run             # every 25th iteration's checkpoint
#   EVERY=100 scripts/results/eval_checkpoints.sh pickup
set -euo pipefail
cd "$(dirname "$0")/../.."
NAME=${1:?usage: eval_checkpoints.sh NAME}
BIN=${BIN:-target/release/skillmimic}
DIR=${OUT:-runs/results}/$NAME
EVERY=${EVERY:-25}
TABLE=$DIR/checkpoint_evals.jsonl
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
touch "$TABLE"
for ck in "$DIR"/checkpoints/iter_*.safetensors; do
  it=$(basename "$ck" .safetensors); it=$((10#${it#iter_}))
  (( it % EVERY == 0 )) || continue
  grep -q "\"iteration\": $it," "$TABLE" && continue
  "$BIN" eval --checkpoint "$ck" --episodes 64 --seed 7 --start-frame 2 --stochastic --set env.episode_length=100000 --out "$TMP/sampled.json" > /dev/null 2>&1
  "$BIN" eval --checkpoint "$ck" --episodes 64 --seed 7 --start-frame 2 --set env.episode_length=100000 --out "$TMP/mean.json" > /dev/null 2>&1
  "$BIN" eval --checkpoint "$ck" --episodes 64 --seed 7 --out "$TMP/random.json" > /dev/null 2>&1
  python3 - "$TMP" "$it" "$DIR/log.jsonl" >> "$TABLE" <<'PY'
import json, pathlib, sys
tmp, it, log = pathlib.Path(sys.argv[1]), int(sys.argv[2]), pathlib.Path(sys.argv[3])
m = {k: json.loads((tmp / f"{k}.json").read_text())["nominal"] for k in ("sampled", "mean", "random")}
rows = [json.loads(l) for l in log.read_text().splitlines() if l.strip()]
near = [r for r in rows if it - 25 < r["iteration"] <= it]
print(json.dumps({
    "iteration": it, "samples": it * rows[0]["samples"] // rows[0]["iteration"],
    "reward_per_step": round(sum(r["mean_reward"] for r in near) / max(1, len(near)), 5),
    "start_sampled_completed_pct": round(100 * (1 - m["sampled"]["fall_rate"]), 2), "start_sampled_e_b_mm": round(m["sampled"]["e_b_mpjpe_mm"], 1),
    "start_sampled_mean_length": round(m["sampled"]["mean_episode_length"], 1),
    "start_mean_action_fell": m["mean"]["fall_rate"] > 0.5, "start_mean_action_length": m["mean"]["mean_episode_length"],
    "start_mean_action_e_b_mm": round(m["mean"]["e_b_mpjpe_mm"], 1),
    "acc_pct": round(m["random"]["acc_percent"], 2), "e_b_mm": round(m["random"]["e_b_mpjpe_mm"], 1), "e_o_mm": round(m["random"]["e_o_mpjpe_mm"], 1),
    "e_cg": round(m["random"]["e_cg"], 4), "nr": round(m["random"]["nr"], 4), "falls_pct": round(100 * m["random"]["fall_rate"], 2)}))
PY
  tail -n 1 "$TABLE"
done
