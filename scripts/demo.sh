#!/usr/bin/env bash
# The main job on the shipped defaults: a short PPO training run on the demo clips in motions/
# (tiny network preset, 400 iterations, about 1–2 minutes), writing a checkpoint, logs, a metrics JSON, a learning
# curve, a short video and a summary into runs/demo/. Idempotent set-up included.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh          # runtime packages only (python/requirements.txt)
cargo build --release -p skillmimic-cli --bin skillmimic
"${CARGO_TARGET_DIR:-target}/release/skillmimic" train --preset tiny --iterations 400 --num-envs 32 --out runs/demo "$@"
