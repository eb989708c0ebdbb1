#!/usr/bin/env bash
# ModSkill's setting (issue 39): a modular_attention tracker on the SMPL humanoid (30 Hz policy),
# trained on BallPlay-M body motion retargeted to SMPL by joint name on load (run, lrun, rrun,
# turn: 6 clips), evaluated as PHC/ModSkill evaluate (`eval --each-motion`: every clip once from
# frame 0, success = never beyond 0.5 m mean body distance, E_g-mpjpe, E_mpjpe, E_vel, E_acc per
# 30 Hz frame) on those clips and on held-back ones (back, legturn: 2 clips). Three runs, seed 0:
#   * power0: the power penalty off (env.tracking.power_coef = 0);
#   * power:  the released power penalty 0.0005 · Σ|τ·q̇|.
#   * bigbatch: power0's policy at BRANCH (4 000) iterations trained on with 4x larger
#     iterations (256 environments, 8 192 samples, minibatch 4 096) — the same samples per
#     wall-clock second on this machine, a quarter of the updates.
# Each run resumes from its latest checkpoint when restarted. The defaults are where the
# published runs stopped (docs/results-modskill.md §0). Every 100th checkpoint of power0 and
# every 50th of bigbatch is evaluated as well (checkpoint curves).
#   ITERS_POWER0=8050 ITERS_POWER=1850 ITERS_BIG=4940 SEED=0 OUT=runs/modskill_smpl scripts/experiments/modskill_smpl_tracking.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/modskill_smpl}
ITERS_POWER0=${ITERS_POWER0:-8050}
ITERS_POWER=${ITERS_POWER:-1850}
SEED=${SEED:-0}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
ITERS_BIG=${ITERS_BIG:-4940}
BRANCH=${BRANCH:-4000}
train() { # out iterations extra...
  local out=$1 iters=$2; shift 2
  [ -f "$out/summary.json" ] && return
  local resume=()
  if [ -f "$out/latest.safetensors" ]; then resume=(--resume latest); fi
  "$BIN" train --preset tiny --task tracking --set 'env.character="smpl"' \
    --motion "$S/run" --motion "$S/lrun" --motion "$S/rrun" --motion "$S/turn" \
    --set ppo.horizon=32 --set ppo.mini_epochs=2 \
    --set 'ppo.hidden=[256, 128]' --set 'ppo.modular.controller=[256, 128]' \
    --set 'ppo.policy="modular_attention"' --set run.eval_episodes=16 \
    --iterations "$iters" --seed "$SEED" --threads 1 --learner-threads 1 --no-video \
    "$@" --out "$out" "${resume[@]}"
}
small=(--set env.num_envs=64 --set ppo.minibatch=1024 --set run.save_every=25)
train "$OUT/power0" "$ITERS_POWER0" "${small[@]}" --set env.tracking.power_coef=0.0
train "$OUT/power" "$ITERS_POWER" "${small[@]}"
big=(--set env.num_envs=256 --set ppo.minibatch=4096 --set run.save_every=10 --set env.tracking.power_coef=0.0)
if [ -f "$OUT/bigbatch/latest.safetensors" ]; then
  train "$OUT/bigbatch" "$ITERS_BIG" "${big[@]}"
else
  branch=$(printf '%s/power0/checkpoints/iter_%06d.safetensors' "$OUT" "$BRANCH")
  train "$OUT/bigbatch" "$ITERS_BIG" "${big[@]}" --set run.fresh_episodes=true --resume "$branch"
fi
train_set="$S/run,$S/lrun,$S/rrun,$S/turn"
held_set="$S/back,$S/legturn"
for run in power0 power bigbatch; do
  for set in train heldback; do
    motion=(--motion "$S/run" --motion "$S/lrun" --motion "$S/rrun" --motion "$S/turn")
    if [ "$set" = heldback ]; then motion=(--motion "$S/back" --motion "$S/legturn"); fi
    "$BIN" eval --checkpoint "$OUT/$run/latest.safetensors" "${motion[@]}" --each-motion \
      --out "$OUT/$run-eval-$set.json"
  done
done
EVERY=100 BIN=$BIN python3 scripts/results/eval_tracking_checkpoints.py "$OUT/power0" "$OUT/power0-evals" \
  "train=$train_set" "heldback=$held_set"
EVERY=50 BIN=$BIN python3 scripts/results/eval_tracking_checkpoints.py "$OUT/bigbatch" "$OUT/bigbatch-evals" \
  "train=$train_set" "heldback=$held_set"
"$BIN" plot --log "$OUT/power0/log.jsonl" --log "$OUT/power/log.jsonl" --log "$OUT/bigbatch/log.jsonl" \
  --label "power penalty off" --label "released power penalty" --label "off, 4x larger iterations" \
  --smooth 50 --out "$OUT/curves.png"
"$BIN" plot --evals "$OUT/power0-evals/train_checkpoint_evals.jsonl" \
  --evals "$OUT/power0-evals/heldback_checkpoint_evals.jsonl" \
  --evals "$OUT/bigbatch-evals/train_checkpoint_evals.jsonl" \
  --label "training motions (6)" --label "held-back motions (2)" --label "training, 4x larger iterations" \
  --out "$OUT/checkpoint-evals.png"
