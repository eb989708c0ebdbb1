#!/usr/bin/env bash
# Issue 42, item 2: SkillMimic Tab. 3 on this machine: dribble forward (DF), left (DL), right (DR)
# and layup trained individually, and the four in one policy with 4x the samples, resumable:
#   scripts/experiments/tab3.sh RUN SEED        RUN: df | dl | dr | layup | mixed
#   ITERS=800 scripts/experiments/tab3.sh mixed 1
# Configurations: configs/results/tab3-{df,dl,dr,mixed}.toml and, for layup, the layup protocol
# of configs/results/layup.toml. PRESET: cpu (default; the time-to-skill preset of
# docs/throughput.md, a labelled deviation from the paper's settings) or small (the paper's
# network and PPO settings). ITERS: an individual run's iterations (default 1600 = 6.55 M samples
# with cpu); the mixed run trains 4 x ITERS, so every skill gets the samples it gets alone.
# When a run reaches its budget its checkpoints are evaluated (scripts/results/eval_checkpoints.py)
# and its evidence written to docs/results/runs/tab3-RUN-PRESET-sSEED (scripts/results/evidence.sh:
# SkillMimic's success per skill, V2's SR/TSR/εNSR and NR, Acc with its replay ceiling).
set -euo pipefail
cd "$(dirname "$0")/../.."
run=${1:?usage: tab3.sh df|dl|dr|layup|mixed SEED}
seed=${2:?usage: tab3.sh df|dl|dr|layup|mixed SEED}
PRESET=${PRESET:-cpu}
OUT=${OUT:-runs/tab3}
BIN=${BIN:-target/release/skillmimic}
THREADS=${THREADS:-0}
case $PRESET in small) per=8192 ;; cpu) per=4096 ;; *) echo "PRESET: small or cpu, not '$PRESET'" >&2; exit 2 ;; esac
ITERS=${ITERS:-$((6553600 / per))}
case $run in
  df | dl | dr) config=configs/results/tab3-$run.toml iters=$ITERS ;;
  layup) config=configs/results/layup.toml iters=$ITERS ;;
  mixed) config=configs/results/tab3-mixed.toml iters=$((4 * ITERS)) ;;
  *) echo "RUN: df, dl, dr, layup or mixed, not '$run'" >&2; exit 2 ;;
esac
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
name=tab3-$run-$PRESET-s$seed
"$BIN" train --preset "$PRESET" --config "$config" --out "$OUT/$name" --seed "$seed" --iterations "$iters" \
  --resume latest --no-video --threads "$THREADS" --learner-threads "$THREADS" \
  --set run.save_every=$((204800 / per)) >> "$OUT/$name.log" 2>&1
EVERY=$((204800 / per)) KINDS=eps,random OUT="$OUT" BIN="$BIN" python3 scripts/results/eval_checkpoints.py "$name"
BIN="$BIN" scripts/results/evidence.sh "$name" "$OUT/$name"
