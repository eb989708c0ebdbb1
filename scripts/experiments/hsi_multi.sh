#!/usr/bin/env bash
# TokenHSI multi-task training and policy adaptation with the token transformer (issue 17, item 3).
# Stage 1: one token_transformer policy on hsi_multi (follow 0.1, sit 0.3, carry 0.3, climb 0.3 of
#          the environments), task reward only, the `tiny` PPO preset, a CPU-sized transformer
#          (tokenizers [256, 128] -> 64 as TokenHSI; 2 encoder layers with feed-forward 256 and an
#          action head [256, 128] instead of 4 / 512 / [1024, 512]).
# Stage 2: deterministic evaluation of the stage-1 policy on each base task alone (same layout).
# Stage 3: policy adaptation to hsi_follow_carry (frozen base, new tokenizer, zero adapters, new
#          critic), then the composition task's evaluation and the base tasks' evaluation again.
# Stage 4 (UNGATED_ITERS=N > 0, off by default): the adaptation again with the released code's
#          ungated adapters (ppo.token.gate_adapters=false) for N iterations into OUT/adapt_ungated,
#          its evaluations, and the stage-1 policy's base-task evaluation with seed 2 (the
#          evaluation-to-evaluation spread the ungated adapters' effect is read against).
# Task reward only, so the released power penalty is off (POWER=0; docs/results-tokenhsi.md's
# survival table shows that with it on and no style reward the policy learns to fall sooner);
# POWER=5e-4 is the released weight.
# Every stage resumes: an existing result is kept. ASSIGN=per_episode draws each stage-1 episode's
# task at its reset (the released rule, env.multi.assign); default fixed.
# Usage: scripts/experiments/hsi_multi.sh OUT_DIR [ITERATIONS] [ADAPT_ITERATIONS] [NUM_ENVS] [SEED]
set -euo pipefail
out=${1:?output folder}
iters=${2:-1000}
adapt_iters=${3:-300}
envs=${4:-64}
seed=${5:-0}
assign=${ASSIGN:-fixed}
bin=$(dirname "$0")/../../target/release/skillmimic
mkdir -p "$out"
power=${POWER:-0}
net=(--set "env.hsi.power_coefficient=$power" --set ppo.policy=token_transformer --set ppo.token.layers=2 --set ppo.token.feedforward=256 --set "ppo.token.head=[256, 128]")
base_groups='["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"]'
all_groups='["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb", "hsi_follow_carry"]'
if [ ! -f "$out/multi/latest.safetensors" ]; then
  "$bin" train --preset tiny --task hsi_multi --num-envs "$envs" --iterations "$iters" --seed "$seed" "${net[@]}" \
    --set "env.multi.assign=\"$assign\"" --set run.save_every=100 --out "$out/multi" --no-video > "$out/multi.log" 2>&1
fi
evaluate() { # checkpoint task groups out [seed, default 1]
  [ -f "$4" ] || "$bin" eval --checkpoint "$1" --set env.task=hsi_multi --set "env.multi.tasks=[\"$2\"]" --set "env.multi.mix=[]" \
    --set "env.multi.groups=$3" --num-envs 32 --episodes 64 --seed "${5:-1}" --out "$4" >> "$out/eval.log" 2>&1
}
for task in hsi_follow hsi_sit hsi_carry hsi_climb; do
  evaluate "$out/multi/latest.safetensors" "$task" "$base_groups" "$out/multi/eval_$task.json"
done
adapt() { # name iterations [--set ...]: adapt the stage-1 policy to hsi_follow_carry, then evaluate
  local name=$1 n=$2
  shift 2
  if [ ! -f "$out/$name/latest.safetensors" ]; then
    "$bin" train --preset tiny --task hsi_multi --num-envs "$envs" --iterations "$n" --seed "$seed" "${net[@]}" \
      --set 'env.multi.tasks=["hsi_follow_carry"]' --set 'env.multi.mix=[]' --set "env.multi.groups=$all_groups" \
      --set "ppo.token.adapt_from=\"$out/multi/latest.safetensors\"" "$@" --set run.save_every=50 --out "$out/$name" \
      --no-video > "$out/$name.log" 2>&1
  fi
  for task in hsi_follow hsi_sit hsi_carry hsi_climb hsi_follow_carry; do
    evaluate "$out/$name/latest.safetensors" "$task" "$all_groups" "$out/$name/eval_$task.json"
  done
}
adapt adapt "$adapt_iters"
ungated=${UNGATED_ITERS:-0}
if [ "$ungated" -gt 0 ]; then
  adapt adapt_ungated "$ungated" --set ppo.token.gate_adapters=false
  for task in hsi_follow hsi_sit hsi_carry hsi_climb; do
    evaluate "$out/multi/latest.safetensors" "$task" "$base_groups" "$out/multi/eval_seed2_$task.json" 2
  done
fi
python3 "$(dirname "$0")/hsi_multi_summary.py" "$out"
[ "$ungated" -gt 0 ] && python3 "$(dirname "$0")/hsi_multi_summary.py" "$out" adapt_ungated
exit 0
