#!/usr/bin/env bash
# Training signal of the four TokenHSI tasks with the gaussian_mlp policy (issue 16, item 3): the
# `tiny` preset (network [256, 128], horizon 16, lr 3e-5), the same budget per task, task reward
# only (no style reward), then a deterministic evaluation of the last checkpoint (success rates
# and errors in <out>/<task>/eval.json).
# Usage: scripts/experiments/hsi_signal.sh OUT_DIR [ITERATIONS] [NUM_ENVS] [SEED]
set -euo pipefail
out=${1:?output folder}
iters=${2:-1000}
envs=${3:-64}
seed=${4:-0}
bin=$(dirname "$0")/../../target/release/skillmimic
mkdir -p "$out"
for task in hsi_follow hsi_sit hsi_climb hsi_carry; do
  "$bin" train --preset tiny --task "$task" --num-envs "$envs" --iterations "$iters" --seed "$seed" \
    --set run.save_every="$iters" --out "$out/$task" --no-video > "$out/$task.log" 2>&1
  "$bin" eval --checkpoint "$out/$task/latest.safetensors" --episodes 64 --out "$out/$task/eval.json" >> "$out/$task.log" 2>&1
done
# summary: task reward per step (first / last 25 iterations), episode length, evaluation
python3 - "$out" <<'PY'
import json, pathlib, statistics as st, sys
out = pathlib.Path(sys.argv[1])
print("| task | reward/step first 25 → last 25 it. | episode length first → last | eval reward/step | eval length | success | final error (m) |")
print("|---|---|---|---|---|---|---|")
for task in ("hsi_follow", "hsi_sit", "hsi_climb", "hsi_carry"):
    rows = [json.loads(l) for l in open(out / task / "log.jsonl")]
    m = lambda rs, k: st.mean(r[k] for r in rs)  # noqa: E731
    e = json.loads((out / task / "eval.json").read_text())
    print(f"| `{task}` | {m(rows[:25], 'mean_reward'):.4f} → {m(rows[-25:], 'mean_reward'):.4f} | {m(rows[:25], 'episode_length'):.1f} → {m(rows[-25:], 'episode_length'):.1f} "
          f"| {e['mean_reward_per_step']:.4f} | {e['mean_episode_length']:.1f} | {100 * e['final_metrics']['success']:.1f} % | {e['final_metrics']['error_m']:.2f} |")
PY
