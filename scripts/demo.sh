#!/usr/bin/env bash
# The main job on shipped defaults (idempotent set-up included).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh
cargo run --release -p skillmimic-cli --bin skillmimic -- demo "$@"
