#!/usr/bin/env bash
# Survival of the four TokenHSI tasks under one small budget, for two builds of skillmimic
# (e.g. before and after issue 38's released-code rules): preset tiny, 64 environments,
# ITERATIONS iterations (x 64 x 16 samples), seed SEED, task reward only, rest-pose starts (no
# reference clips), then 64 deterministic evaluation episodes of the last checkpoint.
# Extra training settings: SURVIVAL_SET="key=value ..." (e.g. env.hsi.power_coefficient=0).
# Usage: scripts/experiments/hsi_survival.sh OUT_DIR LABEL BINARY [ITERATIONS] [SEED]
set -euo pipefail
out=${1:?output folder}
label=${2:?label, e.g. before or after}
bin=${3:?skillmimic binary}
iters=${4:-300}
seed=${5:-0}
extra=()
for kv in ${SURVIVAL_SET:-}; do extra+=(--set "$kv"); done
for task in hsi_follow hsi_sit hsi_climb hsi_carry; do
  dir="$out/$label/$task"
  mkdir -p "$dir"
  "$bin" train --preset tiny --task "$task" --num-envs 64 --iterations "$iters" --seed "$seed" \
    --set run.save_every="$iters" "${extra[@]}" --out "$dir" --no-video > "$dir/train.log" 2>&1
  "$bin" eval --checkpoint "$dir/latest.safetensors" --episodes 64 --out "$dir/eval.json" >> "$dir/train.log" 2>&1
  tail -1 "$dir/train.log"
done
