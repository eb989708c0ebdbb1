#!/usr/bin/env bash
# ModSkill comparison (issue 15, must-show 3): gaussian_mlp vs modular_attention on the imitation
# and the tracking task, same sample budget and seed, real BallPlay-M clips (run, layup, lrun,
# rrun); then the overlaid curves, a tracking evaluation with the paper's 0.5 m threshold, and
# skill reuse through the part embeddings
# (steering over the tracking controllers, against the same run over randomly initialised
# controllers of the same shape). Each run resumes from its latest checkpoint when restarted, and
# every finished run or evaluation is kept. The imitation runs' papers' metrics and evidence:
# scripts/results/evidence.sh NAME OUT/imitation-FAMILY (docs/results-modskill.md names them).
#   ITERS=2000 SEED=0 OUT=runs/modskill_compare scripts/experiments/modskill_compare.sh
# STEER_ITERS (default 300) sets the steering runs' iterations.
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/modskill_compare}
ITERS=${ITERS:-2000}
SEED=${SEED:-0}
STEER_ITERS=${STEER_ITERS:-300}
BIN=${BIN:-target/release/skillmimic}
clips=(--motion "$S/run" --motion "$S/layup" --motion "$S/lrun" --motion "$S/rrun")
# the two families' shared settings (the steering baseline's controllers use them too)
common=(--set env.num_envs=32 --set run.seed="$SEED" --set 'ppo.modular.controller=[128, 64]')
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
for task in tracking imitation; do
  for fam in gaussian_mlp modular_attention; do
    out=$OUT/$task-$fam
    if [ -f "$out/summary.json" ]; then continue; fi
    resume=()
    if [ -f "$out/latest.safetensors" ]; then resume=(--resume latest); fi
    "$BIN" train --preset tiny --task $task "${clips[@]}" "${common[@]}" --set run.iterations="$ITERS" \
      --set run.eval_episodes=16 --set run.save_every=100 --set ppo.policy=$fam --out "$out" "${resume[@]}"
  done
  "$BIN" plot --log "$OUT/$task-gaussian_mlp/log.jsonl" --log "$OUT/$task-modular_attention/log.jsonl" \
    --label gaussian_mlp --label modular_attention --smooth 50 --out "$OUT/$task-compare.png"
done
for fam in gaussian_mlp modular_attention; do
  [ -f "$OUT/tracking-$fam-eval05.json" ] || "$BIN" eval --checkpoint "$OUT/tracking-$fam/latest.safetensors" \
    --episodes 64 --seed 1 --start-frame 0 --set env.tracking.termination_distance=0.5 --out "$OUT/tracking-$fam-eval05.json"
done
# skill reuse: a gaussian_mlp high-level policy whose action is the frozen controllers' part embeddings
# the baseline's controllers: the tracking run's network as initialised (same seed, same part
# layout), written by one iteration at learning rate 1e-30: Adam's first step moves no parameter
# by more than about the learning rate, so every weight stays as initialised to float32 precision
# (the observation normaliser has seen that iteration's 512 samples)
random_llc=$OUT/random-modular_attention/latest.safetensors
if [ ! -f "$random_llc" ]; then
  "$BIN" train --preset tiny --task tracking "${clips[@]}" "${common[@]}" --set run.iterations=1 --set run.eval_episodes=0 \
    --set ppo.lr=1e-30 --set ppo.policy=modular_attention --out "$OUT/random-modular_attention" --no-video
fi
for llc in tracking random; do
  out=$OUT/steering-$llc
  ck=$OUT/tracking-modular_attention/latest.safetensors
  [ "$llc" = random ] && ck=$random_llc
  if [ ! -f "$out/summary.json" ]; then
    resume=()
    if [ -f "$out/latest.safetensors" ]; then resume=(--resume latest); fi
    "$BIN" train --preset tiny --task steering --llc "$ck" --motion "$S/run" \
      --set env.num_envs=32 --set run.iterations="$STEER_ITERS" --set run.seed="$SEED" --set run.eval_episodes=16 \
      --out "$out" --no-video "${resume[@]}"
  fi
done
