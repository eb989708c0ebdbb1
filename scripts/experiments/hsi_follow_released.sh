#!/usr/bin/env bash
# hsi_follow with the released TokenHSI rules (issue 38): reference-state initialisation and style
# references from BallPlay-M run/turn clips retargeted onto the character, the released PPO sizes
# where the machine allows (actor [1024, 512], 3 mini-epochs of 8192), [ppo.amp] with the released
# logit regularisation 0.01; train for TRAIN_S seconds of wall-clock time, then evaluate the last
# checkpoint over 256 deterministic episodes from reference starts (as trained) and from the rest
# pose. docs/results-tokenhsi.md's run: TRAIN_S=400 ENVS=1024 THREADS=16 on a 16-core host.
# Usage: scripts/experiments/hsi_follow_released.sh OUT_DIR [TRAIN_S] [ENVS] [THREADS] [SHARED]
# STYLE=walks: the built-in procedural walks (env.hsi.style_motion = ["builtin:walks"]) instead of
# the retargeted BallPlay-M clips (then SHARED is not needed).
# ITERS=N: train exactly N iterations (no wall-clock limit; TRAIN_S is then ignored), for a budget
# matched in samples across machines of different speeds. A rerun with the same OUT_DIR continues
# from the last checkpoint (--resume latest), exactly, so ITERS can be raised later.
# SEED=N: the training seed (0 by default; docs/results-tokenhsi.md's runs say theirs).
# AMP_SCHEDULE=per_minibatch: the released discriminator schedule (ppo.amp.schedule), with 2048
# current + 2048 replay windows against 2048 reference windows per PPO minibatch of 8192 (the
# released 4096 of 16384, same fraction) and the released 200 000-window replay buffer, keep
# probability 0.01 (checkpoints then hold the buffer: about 1.1 GB each).
set -uo pipefail
out=${1:?output folder}
train_s=${2:-400}
envs=${3:-1024}
threads=${4:-0}
shared=${5:-$(dirname "$0")/../../../shared}
bin=${SKILLMIMIC:-$(dirname "$0")/../../target/release/skillmimic}
mkdir -p "$out"
if [ "${STYLE:-ballplay}" = walks ]; then
  style=builtin:walks
else
  m=()
  for s in run turn lrun rrun; do m+=(--motion "$shared/data/ballplay_m/$s"); done
  "$bin" retarget --to tokenhsi "${m[@]}" --out "$out/clips" > "$out/retarget.log" || exit 1
  style=$out/clips
fi
amp=()
if [ "${AMP_SCHEDULE:-per_iteration}" = per_minibatch ]; then
  amp=(--set 'ppo.amp.schedule="per_minibatch"' --set ppo.amp.batch=2048 --set ppo.amp.buffer=200000
    --set ppo.amp.replay_keep=0.01)
fi
if [ -n "${ITERS:-}" ]; then limit=(); iters=$ITERS; else limit=(timeout "$train_s"); iters=100000; fi
"${limit[@]}" "$bin" train --preset small --task hsi_follow --num-envs "$envs" --threads "$threads" \
  --learner-threads "$threads" --seed "${SEED:-0}" --iterations "$iters" \
  --set "env.hsi.style_motion=[\"$style\"]" --set ppo.amp.enabled=true --set ppo.amp.logit_reg=0.01 \
  --set 'ppo.hidden=[1024, 512]' --set ppo.mini_epochs=3 --set ppo.minibatch=8192 --set run.save_every=10 \
  "${amp[@]}" --out "$out/follow" --no-video --resume latest >> "$out/train.log" 2>&1
echo "train exit $? (124: stopped at ${train_s} s, as intended without ITERS)"
for start in reference rest; do
  extra=(); [ "$start" = rest ] && extra=(--set 'env.hsi.state_init="default"')
  "$bin" eval --checkpoint "$out/follow/latest.safetensors" --episodes 256 --num-envs 256 \
    --threads "$threads" "${extra[@]}" --out "$out/follow/eval_${start}_start.json" 2>&1 | tail -2
done
