#!/usr/bin/env bash
# Run every test of skillmimic-rs: Rust unit/integration tests, then the Python package built with
# `pip install .` and its test-suite (cross-checks against the official `mujoco` package, numpy
# reference, PyTorch, SB3/rsl_rl adapters). Idempotent set-up included.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh --tests  # runtime + test packages (python/requirements-test.txt)
cargo build --release --workspace --bins
cargo test --release --workspace
.venv/bin/python -m pip install --disable-pip-version-check --no-build-isolation -q .
.venv/bin/python -m pytest -q tests
