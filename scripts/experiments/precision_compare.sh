#!/usr/bin/env bash
# Issue 21: the bf16 update (ppo.precision = "bf16") vs float32 on a real clip, with the paper's
# network and PPO settings at workstation scale (preset small: 256 environments, [1024, 512, 512],
# minibatch 4096, 6 mini-epochs, lr 2e-5), same seeds and budget for both; then the overlaid curves
# and the deterministic evaluation. Finished runs are skipped on restart.
#   ITERS=100 SEEDS="0 1 2" OUT=runs/precision scripts/experiments/precision_compare.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/precision}
ITERS=${ITERS:-100}
SEEDS=${SEEDS:-0 1 2}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
one() { # precision seed
  local out=$OUT/$1-s$2
  [ -f "$out/eval.json" ] && return 0
  "$BIN" train --preset small --motion "$S/run/013_018pickle_run_3.pt" --set run.iterations="$ITERS" \
    --set run.seed="$2" --set run.eval_episodes=0 --set "ppo.precision=\"$1\"" --out "$out" > "$out.log" 2>&1
  "$BIN" eval --checkpoint "$out/latest.safetensors" --episodes 64 --seed 7 --out "$out/eval.json" >> "$out.log" 2>&1
}
for s in $SEEDS; do one f32 "$s"; one bf16 "$s"; done
logs=(); labels=()
for s in $SEEDS; do for p in f32 bf16; do logs+=(--log "$OUT/$p-s$s/log.jsonl"); labels+=(--label "$p s$s"); done; done
"$BIN" plot "${logs[@]}" "${labels[@]}" --smooth 5 --out "$OUT/precision-run.png"
for s in $SEEDS; do for p in f32 bf16; do echo "$OUT/$p-s$s"; done; done | while read -r run; do
  python3 scripts/experiments/run_summary.py "$run"
done | tee "$OUT/summary.txt"
