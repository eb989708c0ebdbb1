#!/usr/bin/env bash
# Issue 42, item 1: SkillMimic against SkillMimic-V2 on the layup clip at equal samples (the
# comparison of SkillMimic-V2 Tab. 1), one policy per method and seed, resumable:
#   scripts/experiments/layup_v1_v2.sh METHOD SEED        METHOD: sm | v2
#   PRESET=cpu ITERS=2400 scripts/experiments/layup_v1_v2.sh v2 1
# sm: configs/results/layup.toml (SkillMimic: the current layup run's settings);
# v2: configs/results/layup-v2.toml (STF, STG, ATS and the history encoder, pre-trained here on
#     the clip first if OUT has no encoder yet).
# PRESET: small (default: the paper's network and PPO settings at 256 environments, what the
# comparison reproduces) or cpu (the time-to-skill preset, a second pair labelled as such).
# ITERS: iterations of both methods (default 1500 = 12.3 M samples with small); the same for
# every method and seed of a preset, so that the budgets in samples are equal.
# When a run reaches ITERS its checkpoints are evaluated (scripts/results/eval_checkpoints.py,
# completion from the start and random-frame metrics every 204 800 samples) and its evidence is
# written to docs/results/runs/layup-METHOD-PRESET-sSEED (scripts/results/evidence.sh: the
# papers' metrics, V2's SR/εNSR/NR among them).
set -euo pipefail
cd "$(dirname "$0")/../.."
method=${1:?usage: layup_v1_v2.sh sm|v2 SEED}
seed=${2:?usage: layup_v1_v2.sh sm|v2 SEED}
PRESET=${PRESET:-small}
OUT=${OUT:-runs/layup-v1-v2}
BIN=${BIN:-target/release/skillmimic}
THREADS=${THREADS:-0}
case $PRESET in small) per=8192 ;; cpu) per=4096 ;; *) echo "PRESET: small or cpu, not '$PRESET'" >&2; exit 2 ;; esac
ITERS=${ITERS:-$((12288000 / per))}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
clip=${SHARED:-../shared}/data/ballplay_m/layup/031_015pickle_layup_001_001.pt
args=(train --preset "$PRESET" --out "$OUT/layup-$method-$PRESET-s$seed" --seed "$seed" --iterations "$ITERS"
  --resume latest --no-video --threads "$THREADS" --learner-threads "$THREADS" --set run.save_every=$((204800 / per)))
case $method in
  sm) args+=(--config configs/results/layup.toml) ;;
  v2)
    enc=$OUT/history-layup.safetensors
    [ -f "$enc" ] || "$BIN" history pretrain --motion "$clip" --out "$enc" --epochs 1000 --seed 0
    args+=(--config configs/results/layup-v2.toml --set "env.v2.history.encoder=\"$(realpath "$enc")\"") ;;
  *) echo "METHOD: sm or v2, not '$method'" >&2; exit 2 ;;
esac
name=layup-$method-$PRESET-s$seed
"$BIN" "${args[@]}" >> "$OUT/$name.log" 2>&1
EVERY=$((204800 / per)) KINDS=eps,random OUT="$OUT" BIN="$BIN" python3 scripts/results/eval_checkpoints.py "$name"
BIN="$BIN" scripts/results/evidence.sh "$name" "$OUT/$name"
