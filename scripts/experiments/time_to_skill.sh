#!/usr/bin/env bash
# Issue 41: time to skill with preset `cpu` against preset `small` (docs/throughput.md, "Time to
# skill"). For each clip (run, pickup) and seed (0, 1), both presets train side by side, one
# single-threaded run per core (so that the two interleave on the same machine), resuming from
# their checkpoints; every 25th checkpoint is evaluated (completion from the clip's start with
# the mean action and start noise 0.01, and the random-frame metrics); then a quiet
# `bench train --preset cpu --against small` gives each preset's rate and
# scripts/experiments/time_to_skill.py the samples and wall-clock to the criterion.
#   OUT=runs/tts ITERS_SMALL=1600 ITERS_CPU=2400 scripts/experiments/time_to_skill.sh run 0
#   PRESETS=cpu scripts/experiments/time_to_skill.sh pickup 1   # one preset's run (a free core)
#   PRESETS=cpu CPU_CORE=0 scripts/experiments/time_to_skill.sh pickup 0   # cpu on core 0
# Runs are resumed: call again with a larger ITERS_* to go on. Needs ../shared beside the checkout.
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${BIN:-target/release/skillmimic}
OUT=${OUT:-runs/tts}
clip=${1:?clip: run or pickup}
seed=${2:?seed}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
train() { # core preset iterations checkpoint-interval
  "$BIN" train --preset "$2" --config "configs/results/$clip.toml" --out "$OUT/$clip-$2-s$seed" \
    --seed "$seed" --iterations "$3" --resume latest --no-video --threads 1 --learner-threads 1 \
    --set run.save_every="$4" >> "$OUT/$clip-$2-s$seed.log" 2>&1 &
  # one core each where taskset exists
  command -v taskset > /dev/null && taskset -cp "$1" $! > /dev/null || true
}
# checkpoints every 204 800 samples: 25 iterations of `small` (8192), 50 of `cpu` (4096)
presets=${PRESETS:-small cpu}
for p in $presets; do
  case $p in
    small) train "${SMALL_CORE:-0}" small "${ITERS_SMALL:-1600}" 25 ;;
    cpu) train "${CPU_CORE:-1}" cpu "${ITERS_CPU:-2400}" 50 ;;
    *) echo "PRESETS: small and/or cpu, not '$p'" >&2; exit 2 ;;
  esac
done
wait
for p in $presets; do
  [ $p = small ] && every=25 || every=50
  EVERY=$every KINDS=eps,random OUT="$OUT" BIN="$BIN" python3 scripts/results/eval_checkpoints.py "$clip-$p-s$seed"
done
if [ ! -f "$OUT/rates-$clip.json" ]; then
  "$BIN" bench train --preset cpu --against small --config "configs/results/$clip.toml" --rounds 6 | tee "$OUT/bench-$clip.txt"
  python3 - "$OUT/bench-$clip.txt" "$OUT/rates-$clip.json" "$clip" <<'EOF'
import json, re, sys
text = open(sys.argv[1]).read()
rates = {f"{sys.argv[3]}-{p}": float(re.search(rf"^{p}: median: end-to-end (\d+)", text, re.M).group(1)) for p in ("small", "cpu")}
open(sys.argv[2], "w").write(json.dumps(rates) + "\n")
EOF
fi
# the run folders only (OUT also holds each run's console log, CLIP-PRESET-sSEED.log)
runs=()
for d in "$OUT/$clip"-{small,cpu}-s*; do [ -d "$d" ] && runs+=("$d"); done
python3 scripts/experiments/time_to_skill.py "$OUT/rates-$clip.json" "${runs[@]}"
