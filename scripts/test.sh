#!/usr/bin/env bash
# Run every test of skillmimic-rs: Rust unit/integration tests and the Python test-suite
# (cross-checks against the official `mujoco` package). Idempotent set-up included.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh
cargo build --release --workspace --bins
cargo test --release --workspace
.venv/bin/python -m pytest -q tests
