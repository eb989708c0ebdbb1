#!/usr/bin/env bash
# Learner cost of the two motion-prior schedules (ppo.amp.schedule) at the hsi_follow run's sizes
# (scripts/experiments/hsi_follow_released.sh: 1024 environments, actor/critic [1024, 512], 3
# mini-epochs of 8192, built-in walks): 4 iterations each of
#   A: "per_iteration" (4 steps of 512 + 512 windows per iteration, ring of 8192),
#   B: "per_minibatch", 2048 current + 2048 replay vs 2048 reference windows per PPO minibatch
#      (the released 4096 of 16384, same fraction), replay buffer 200 000,
#   C: "per_minibatch" at the released 4096 windows per step.
# Run it alone on the machine; compare samples_per_s of iterations 2-4 in OUT/<variant>/log.jsonl.
# Usage: scripts/experiments/amp_schedule_cost.sh OUT [THREADS]
set -u
out=${1:?output folder}
threads=${2:-2}
bin=${SKILLMIMIC:-$(dirname "$0")/../../target/release/skillmimic}
for v in A B C; do
  case $v in
    A) extra=() ;;
    B) extra=(--set 'ppo.amp.schedule="per_minibatch"' --set ppo.amp.batch=2048 --set ppo.amp.buffer=200000) ;;
    C) extra=(--set 'ppo.amp.schedule="per_minibatch"' --set ppo.amp.batch=4096 --set ppo.amp.buffer=200000) ;;
  esac
  "$bin" train --preset small --task hsi_follow --num-envs 1024 --threads "$threads" \
    --learner-threads "$threads" --seed 0 --iterations 4 \
    --set 'env.hsi.style_motion=["builtin:walks"]' --set ppo.amp.enabled=true --set ppo.amp.logit_reg=0.01 \
    --set 'ppo.hidden=[1024, 512]' --set ppo.mini_epochs=3 --set ppo.minibatch=8192 --set run.save_every=10 \
    "${extra[@]}" --out "$out/$v" --no-video > "$out/$v.log" 2>&1
  echo "$v exit $?"
done
