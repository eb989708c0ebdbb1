#!/usr/bin/env bash
# ModSkill comparison (issue 15, must-show 3): gaussian_mlp vs modular_attention on the imitation
# and the tracking task, same sample budget and seed, real BallPlay-M clips (run, layup, lrun,
# rrun); then the overlaid curves and a tracking evaluation with the paper's 0.5 m threshold.
# Each run resumes from its latest checkpoint when restarted.
#   ITERS=2000 SEED=0 OUT=runs/modskill_compare scripts/experiments/modskill_compare.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/modskill_compare}
ITERS=${ITERS:-2000}
SEED=${SEED:-0}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
for task in tracking imitation; do
  for fam in gaussian_mlp modular_attention; do
    out=$OUT/$task-$fam
    if [ -f "$out/summary.json" ]; then continue; fi
    resume=()
    if [ -f "$out/latest.safetensors" ]; then resume=(--resume latest); fi
    "$BIN" train --preset tiny --task $task \
      --motion "$S/run" --motion "$S/layup" --motion "$S/lrun" --motion "$S/rrun" \
      --set env.num_envs=32 --set run.iterations="$ITERS" --set run.seed="$SEED" \
      --set run.eval_episodes=16 --set run.save_every=100 \
      --set ppo.policy=$fam --set 'ppo.modular.controller=[128, 64]' --out "$out" "${resume[@]}"
  done
  "$BIN" plot --log "$OUT/$task-gaussian_mlp/log.jsonl" --log "$OUT/$task-modular_attention/log.jsonl" \
    --label gaussian_mlp --label modular_attention --smooth 50 --out "$OUT/$task-compare.png"
done
for fam in gaussian_mlp modular_attention; do
  "$BIN" eval --checkpoint "$OUT/tracking-$fam/latest.safetensors" --episodes 64 --seed 1 --start-frame 0 \
    --set env.tracking.termination_distance=0.5 --out "$OUT/tracking-$fam-eval05.json"
done
