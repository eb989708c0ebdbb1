#!/usr/bin/env bash
# Issue 21: each throughput lever's contribution, measured with `skillmimic bench train` (preset
# small = the paper's network and PPO settings; each line carries its own raw mj_step anchor from
# the same rounds), twice in alternation. BASE_BIN is a binary built at the commit before the
# levers (38e31d8), for the "before" line. Needs a quiet machine.
#   BASE_BIN=/path/to/old/skillmimic OUT=runs/levers scripts/experiments/throughput_levers.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${BIN:-target/release/skillmimic}
OUT=${OUT:-runs/levers}
ROUNDS=${ROUNDS:-3}
mkdir -p "$OUT"
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
bench() { # label binary args...
  local label=$1 bin=$2
  shift 2
  echo "== $label" | tee -a "$OUT/levers.txt"
  "$bin" bench train --preset small --rounds "$ROUNDS" "$@" 2>&1 | grep -E "^median|^raw mj_step" | tee -a "$OUT/levers.txt"
}
: > "$OUT/levers.txt"
for pass in 1 2; do
  [ -n "${BASE_BIN:-}" ] && bench "before (38e31d8): newton, f32" "$BASE_BIN"
  bench "newton, f32 (branch-free ReLU mask)" "$BIN" --set 'ppo.precision="f32"'
  bench "newton, bf16 backward" "$BIN" --set 'ppo.precision="bf16"'
  bench "pgs, f32" "$BIN" --set 'ppo.precision="f32"' --set 'env.physics.solver="pgs"'
  bench "pgs, bf16 backward" "$BIN" --set 'ppo.precision="bf16"' --set 'env.physics.solver="pgs"'
done
cargo run --release -q -p skillmimic-nn --example bf16_bench | tee "$OUT/matmul.txt"
