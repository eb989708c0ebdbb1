#!/usr/bin/env bash
# Run every test of skillmimic-rs: Rust unit/integration tests, then the Python package built with
# `pip install .` and its test-suite (cross-checks against the official `mujoco` package, numpy
# reference, PyTorch, SB3/rsl_rl adapters, the guide's tutorials), after building the guide and
# checking its links. Idempotent set-up included.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# Every temporary file of the run (Rust tests' run folders, pytest's tmp_path, pip's builds) goes
# to one fresh folder that is removed when the run ends, pass or fail, so that repeated runs never
# fill the system's temporary disk. A short path under the system's temporary root, not under
# target/, keeps Unix-socket paths (multiprocessing, torch.distributed) within their 107 bytes.
TMPDIR="$(mktemp -d -t skillmimic-test.XXXXXX)"
export TMPDIR
trap 'rm -rf "$TMPDIR"' EXIT
./scripts/setup.sh --tests  # runtime + test packages (python/requirements-test.txt)
# formatting (rustfmt.toml) and lints (the workspace's [workspace.lints]), warnings as errors
cargo fmt --all --check
cargo clippy --release --workspace --all-targets -- -D warnings
cargo build --release --workspace --bins
cargo test --release --workspace
.venv/bin/python -m pip install --disable-pip-version-check --no-build-isolation -q .
# the guide (docs/, mdBook) with its Python and Rust API references; a broken link fails
./scripts/docs.sh
# the 15 slowest tests are listed at the end (CI runs on 2 cores within a time limit)
.venv/bin/python -m pytest -q --durations=15 tests
