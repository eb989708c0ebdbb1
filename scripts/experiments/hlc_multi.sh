#!/usr/bin/env bash
# Multi-task high-level controller (issue 17, must-show 4): one `token_transformer_categorical`
# controller trained on heading + circling (`hlc_multi`, environments split 50/50) against the
# single-task `categorical_mlp` controllers of the high-level issue, at the same budget (same
# iterations, environments, horizon and PPO settings, so the same number of high-level samples in
# all; the multi-task run spends half of them on each task), all over one frozen skill policy.
#
#   scripts/experiments/hlc_multi.sh LLC [OUT] [ITERS] [ENVS] [SEED]
#
# LLC: a skill-policy checkpoint (e.g. from scripts/experiments/hlc_heading.sh); OUT default
# runs/hlc_multi; ITERS default 80; ENVS default 128 (horizon 32 → ENVS × 32 high-level samples
# per iteration). The transformer is CPU-sized (2 layers, feed-forward 256, head [256, 128]), as
# in scripts/experiments/hsi_multi.sh. Every run and evaluation resumes / is skipped when its
# output exists. Evaluation: 128 episodes per task on the same episode starts (seed 1), the
# multi-task controller once per task with the other task's token masked out.
# Results on the 2-core development machine: docs/results-tokenhsi.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
llc=${1:?skill-policy checkpoint}
out=${2:-runs/hlc_multi}
iters=${3:-80}
envs=${4:-128}
seed=${5:-0}
shared=${SKILLMIMIC_SHARED:-../shared}
bin=${SKILLMIMIC_BIN:-target/release/skillmimic}
[ -x "$bin" ] || cargo build --release -p skillmimic-cli
mkdir -p "$out/clips"
for c in run/013_018pickle_run_3.pt lrun/011_018pickle_lrun_1.pt rrun/012_018pickle_pick2rrun_2.pt; do
    ln -sf "$(realpath "$shared/data/ballplay_m/$c")" "$out/clips/"
done
common=(--preset small --llc "$llc" --motion "$out/clips" --num-envs "$envs" --iterations "$iters" --seed "$seed"
        --set "ppo.minibatch=$((envs * 16))" --set run.save_every=20 --no-video)
token=(--policy token_transformer_categorical --set ppo.token.layers=2 --set ppo.token.feedforward=256
       --set "ppo.token.head=[256, 128]")
train() { # name args...
    local name=$1; shift
    local resume=()
    [ -f "$out/$name/latest.safetensors" ] && resume=(--resume "$out/$name/latest.safetensors")
    [ -f "$out/$name/summary.json" ] || "$bin" train "${common[@]}" "$@" "${resume[@]}" --out "$out/$name" > "$out/$name.log" 2>&1
}
train heading --task heading
train circling --task circling
train multi --task hlc_multi "${token[@]}"
evaluate() { # checkpoint out args...
    local ck=$1 o=$2; shift 2
    [ -f "$o" ] || "$bin" eval --checkpoint "$ck" --episodes 128 --num-envs 64 --seed 1 --out "$o" "$@" >> "$out/eval.log" 2>&1
}
evaluate "$out/heading/latest.safetensors" "$out/heading/eval_heading.json" --baselines
evaluate "$out/circling/latest.safetensors" "$out/circling/eval_circling.json" --baselines
for task in heading circling; do
    evaluate "$out/multi/latest.safetensors" "$out/multi/eval_$task.json" --set env.task=hlc_multi \
        --set "env.multi.tasks=[\"$task\"]" --set "env.multi.mix=[]" --set 'env.multi.groups=["heading", "circling"]'
done
python3 scripts/experiments/hlc_multi_summary.py "$out"
