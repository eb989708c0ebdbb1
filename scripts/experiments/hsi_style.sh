#!/usr/bin/env bash
# hsi_follow with TokenHSI's style reward (issue 16): BallPlay-M locomotion clips (run, turn, lrun,
# rrun) retargeted onto the TokenHSI character are the discriminator's references; task and style
# rewards mixed 0.5 / 0.5. Same preset, budget and seed as scripts/experiments/hsi_signal.sh (its
# hsi_follow run is the task-only comparison); the discriminator is smaller than TokenHSI's
# [1024, 512] to fit the CPU budget.
# Usage: scripts/experiments/hsi_style.sh OUT_DIR [ITERATIONS] [NUM_ENVS] [SEED] [SHARED]
set -euo pipefail
out=${1:?output folder}
iters=${2:-1000}
envs=${3:-64}
seed=${4:-0}
shared=${5:-$(dirname "$0")/../../../shared}
bin=$(dirname "$0")/../../target/release/skillmimic
mkdir -p "$out"
m=()
for s in run turn lrun rrun; do m+=(--motion "$shared/data/ballplay_m/$s"); done
"$bin" retarget --to tokenhsi "${m[@]}" --out "$out/clips" > "$out/retarget.log"
"$bin" train --preset tiny --task hsi_follow --num-envs "$envs" --iterations "$iters" --seed "$seed" \
  --set run.save_every="$iters" --set ppo.amp.enabled=true --set 'ppo.amp.hidden=[256, 128]' \
  --set 'env.hsi.style_features="proprioception"' \
  --set "env.hsi.style_motion=[\"$out/clips\"]" --out "$out/hsi_follow_style" --no-video > "$out/hsi_follow_style.log" 2>&1
"$bin" eval --checkpoint "$out/hsi_follow_style/latest.safetensors" --episodes 64 --out "$out/hsi_follow_style/eval.json" >> "$out/hsi_follow_style.log" 2>&1
