#!/usr/bin/env bash
# Cost of the two task assignments of hsi_multi (env.multi.assign): 6 iterations each of TokenHSI's
# four tasks (mix 0.1/0.3/0.3/0.3) on NUM_ENVS environments, preset tiny (horizon 16), seed 0:
#   fixed:       a block of environments per task (one MuJoCo data per environment),
#   per_episode: each episode's task drawn at its reset (released); every task's batch keeps a
#                row per environment and pauses the others' rows (one data per task and environment).
# Records each run's log and peak memory (/usr/bin/time -v); summarise with
#   python3 scripts/experiments/multi_assign_cost.py OUT
# Run it alone on the machine. Usage: scripts/experiments/multi_assign_cost.sh OUT [NUM_ENVS] [THREADS]
set -u
out=${1:?output folder}
envs=${2:-256}
threads=${3:-2}
bin=${SKILLMIMIC:-$(dirname "$0")/../../target/release/skillmimic}
mkdir -p "$out"
for v in fixed per_episode; do
  /usr/bin/time -v "$bin" train --preset tiny --task hsi_multi --num-envs "$envs" --threads "$threads" \
    --learner-threads "$threads" --seed 0 --iterations 6 --set "env.multi.assign=\"$v\"" \
    --set run.save_every=100 --out "$out/$v" --no-video > "$out/$v.log" 2> "$out/$v.time"
  echo "$v exit $?"
done
