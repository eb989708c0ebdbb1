#!/usr/bin/env bash
# Skill reuse, learning signal (issue 12): train a skill policy on the three BallPlay-M run clips
# (run, lrun, rrun), then the high-level `heading` task over it, then evaluate the high-level
# policy against a uniformly random choice and each fixed skill on the same episode starts.
#
#   scripts/experiments/hlc_heading.sh [OUT]      (default runs/hlc_heading)
#
# Budgets (environment variables): LLC_ITERS skill-policy iterations (preset small: 8 192
# samples each), HLC_ITERS high-level iterations of 8192 high-level samples (= 24 576 simulation
# steps; 0: stop after the skill policy), EPISODES evaluation episodes per actor; LLC_PRESET the
# skill policy's preset (default small, the paper's network and PPO settings; `cpu` is the
# time-to-skill preset of docs/throughput.md, whose iterations are 4 096 samples). Each stage
# resumes if its checkpoint exists.
# Results of the run on the 2-core development machine: docs/results-hlc.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
SHARED=${SKILLMIMIC_SHARED:-../shared}
OUT=${1:-runs/hlc_heading}
LLC_ITERS=${LLC_ITERS:-500}
HLC_ITERS=${HLC_ITERS:-150}
EPISODES=${EPISODES:-128}
LLC_PRESET=${LLC_PRESET:-small}
BIN=${SKILLMIMIC_BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT/clips"
for c in run/013_018pickle_run_3.pt lrun/011_018pickle_lrun_1.pt rrun/012_018pickle_pick2rrun_2.pt; do
    ln -sf "$(realpath "$SHARED/data/ballplay_m/$c")" "$OUT/clips/"
done
resume() { [ -f "$1/latest.safetensors" ] && echo "--resume $1/latest.safetensors" || true; }
# shellcheck disable=SC2046
"$BIN" train --preset "$LLC_PRESET" --motion "$OUT/clips" --iterations "$LLC_ITERS" --seed 0 --out "$OUT/skills" --no-video $(resume "$OUT/skills")
# HLC_ITERS=0: the skill policy only (e.g. for scripts/experiments/hlc_multi.sh)
[ "$HLC_ITERS" -gt 0 ] || exit 0
# shellcheck disable=SC2046
"$BIN" train --preset small --task heading --llc "$OUT/skills/latest.safetensors" --motion "$OUT/clips" \
    --iterations "$HLC_ITERS" --seed 0 --out "$OUT/heading" --no-video $(resume "$OUT/heading")
"$BIN" eval --checkpoint "$OUT/heading/latest.safetensors" --baselines --episodes "$EPISODES" --num-envs 64 --seed 1 \
    --out "$OUT/heading_eval.json"
