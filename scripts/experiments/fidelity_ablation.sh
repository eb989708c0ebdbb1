#!/usr/bin/env bash
# Fidelity ablation (issue 20, must-show 2): what each deviation from the papers does, on two real
# BallPlay-M clips (run, layup), two seeds each, the same sample budget for every run.
#   * SkillMimic (V1): env.reward.contact_graph = force_threshold (the papers' graph, default)
#     vs exact (MuJoCo contact pairs);
#   * SkillMimic-V2 (State Transition Field on, p_n = 0.1): env.compat = paper vs code (noise,
#     connection similarity and bridging steps of the released code).
# Every run is evaluated with the deterministic policy (Acc, E_cg, NR; eval.json), again under the
# papers' force-threshold graph (eval_ft.json, one yardstick for both graphs), V2 runs also with the
# SkillMimic-V2 metrics (eval_v2.json: SR, TSR, εNSR, NR over 10 s); the curves are plotted and
# scripts/experiments/fidelity_summary.py writes the table. Finished steps are skipped on restart.
#   ITERS=80 JOBS=2 OUT=runs/fidelity scripts/experiments/fidelity_ablation.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SHARED:-../shared}/data/ballplay_m
OUT=${OUT:-runs/fidelity}
ITERS=${ITERS:-80}
JOBS=${JOBS:-2}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
declare -A CLIP=([run]="$S/run/013_018pickle_run_3.pt" [layup]="$S/layup/031_015pickle_layup_001_001.pt")
one() { # name clip seed settings...
  local name=$1 clip=$2 seed=$3; shift 3
  local out=$OUT/$name-$clip-s$seed
  [ -f "$out/eval.json" ] && return 0
  local sets=()
  for s in "$@"; do sets+=(--set "$s"); done
  "$BIN" train --preset tiny --motion "${CLIP[$clip]}" --set env.num_envs=64 --set env.threads=1 \
    --set ppo.horizon=32 --set ppo.minibatch=512 --set ppo.lr=1e-4 --set run.iterations="$ITERS" \
    --set run.seed="$seed" --set run.eval_episodes=0 "${sets[@]}" --out "$out" > "$out.log" 2>&1
  "$BIN" eval --checkpoint "$out/latest.safetensors" --episodes 64 --seed 7 --out "$out/eval.json" >> "$out.log" 2>&1
}
evals() { # name clip seed: the extra evaluations of a finished run
  local out=$OUT/$1-$2-s$3
  [ -f "$out/eval_ft.json" ] || "$BIN" eval --checkpoint "$out/latest.safetensors" --episodes 64 --seed 7 \
    --set 'env.reward.contact_graph="force_threshold"' --out "$out/eval_ft.json" >> "$out.log" 2>&1
  case $1 in v2_*) [ -f "$out/eval_v2.json" ] || "$BIN" eval --checkpoint "$out/latest.safetensors" --v2 --episodes 16 \
    --seed 7 --out "$out/eval_v2.json" >> "$out.log" 2>&1 ;; esac
}
mkdir -p "$OUT"
jobs_list=()
for clip in run layup; do
  for seed in 0 1; do
    jobs_list+=("v1_force_threshold $clip $seed env.reward.contact_graph=\"force_threshold\"")
    jobs_list+=("v1_exact $clip $seed env.reward.contact_graph=\"exact\"")
    jobs_list+=("v2_paper $clip $seed env.v2.stf.enabled=true env.compat=\"paper\"")
    jobs_list+=("v2_code $clip $seed env.v2.stf.enabled=true env.compat=\"code\"")
  done
done
for j in "${jobs_list[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do sleep 2; done
  # shellcheck disable=SC2086
  one $j &
done
wait
for j in "${jobs_list[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do sleep 2; done
  # shellcheck disable=SC2086
  evals $j &
done
wait
for clip in run layup; do
  for pair in "v1_force_threshold v1_exact" "v2_paper v2_code"; do
    set -- $pair
    "$BIN" plot --log "$OUT/$1-$clip-s0/log.jsonl" --log "$OUT/$2-$clip-s0/log.jsonl" \
      --log "$OUT/$1-$clip-s1/log.jsonl" --log "$OUT/$2-$clip-s1/log.jsonl" \
      --label "$1 s0" --label "$2 s0" --label "$1 s1" --label "$2 s1" --smooth 5 --out "$OUT/${1%%_*}-$clip.png"
  done
done
.venv/bin/python scripts/experiments/fidelity_summary.py "$OUT" | tee "$OUT/table.md"
