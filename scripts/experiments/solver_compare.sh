#!/usr/bin/env bash
# Issue 21: training with the PGS solver vs Newton (the default) on a real clip, same seeds and
# budget as the fidelity ablation's V1 runs (scripts/experiments/fidelity_ablation.sh), then the
# overlaid curves and the deterministic evaluation. Finished runs are skipped on restart.
#   ITERS=150 OUT=runs/solver scripts/experiments/solver_compare.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/solver}
ITERS=${ITERS:-150}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
one() { # solver seed
  local out=$OUT/$1-s$2
  [ -f "$out/eval.json" ] && return 0
  "$BIN" train --preset tiny --motion "$S/run/013_018pickle_run_3.pt" --set env.num_envs=64 --set env.threads=1 \
    --set ppo.horizon=32 --set ppo.minibatch=512 --set ppo.lr=1e-4 --set run.iterations="$ITERS" \
    --set run.seed="$2" --set run.eval_episodes=0 --set "env.physics.solver=\"$1\"" --out "$out" > "$out.log" 2>&1
  "$BIN" eval --checkpoint "$out/latest.safetensors" --episodes 64 --seed 7 --out "$out/eval.json" >> "$out.log" 2>&1
}
one newton 0 & one pgs 0 & wait
one newton 1 & one pgs 1 & wait
"$BIN" plot --log "$OUT/newton-s0/log.jsonl" --log "$OUT/pgs-s0/log.jsonl" --log "$OUT/newton-s1/log.jsonl" --log "$OUT/pgs-s1/log.jsonl" \
  --label "newton s0" --label "pgs s0" --label "newton s1" --label "pgs s1" --smooth 5 --out "$OUT/solver-run.png"
for r in newton-s0 pgs-s0 newton-s1 pgs-s1; do
  run=$OUT/$r
  python3 scripts/experiments/run_summary.py "$run"
done | tee "$OUT/summary.txt"
