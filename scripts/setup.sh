#!/usr/bin/env bash
# One-time (and idempotent) set-up of a checkout:
#   1. a project virtual environment .venv with the pinned Python packages:
#        ./scripts/setup.sh           runtime only (python/requirements.txt: mujoco==3.17.0, the
#                                     source of libmujoco for both Rust and Python) - the main job;
#        ./scripts/setup.sh --tests   runtime + everything the tests need
#                                     (python/requirements-test.txt: maturin, pytest, PyTorch, ...)
#                                     and the guide's generator mdBook (built into .tools);
#   2. .mujoco/lib/libmujoco.so -> the wheel's libmujoco.so.3.17.0, which .cargo/config.toml hands
#      to the mujoco-rs build script, and which the crates' build script bakes in as run-time path.
# Each part installs once (a stamp per part, keyed on the requirement files' contents); a second
# run only compares the stamps and returns in well under a second.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

usage() { sed -n '2,11s/^# \{0,1\}//p' "${BASH_SOURCE[0]}"; }
tests=0
for arg in "$@"; do
  case "$arg" in
    --tests) tests=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "setup: unknown argument '$arg' (use --tests for the test requirements, --help for help)" >&2; exit 2 ;;
  esac
done

python_bin=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  if ! command -v "$python_bin" >/dev/null 2>&1; then
    echo "setup: '$python_bin' not found; install Python >= 3.10 or set PYTHON=/path/to/python" >&2
    exit 1
  fi
  echo "setup: creating .venv with $("$python_bin" --version 2>&1)"
  "$python_bin" -m venv .venv
  .venv/bin/python -m pip install --disable-pip-version-check -q --upgrade pip
fi

# install requirement file $1 unless the stamp $2 holds the checksum of the files $3...
install_once() {
  local req=$1 stamp=$2 want
  shift 2
  want=$(cat "$@" | sha1sum | cut -d' ' -f1)
  if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
    echo "setup: installing Python packages from $req (once; this may take a while)"
    .venv/bin/python -m pip install --disable-pip-version-check -q -r "$req"
    echo "$want" > "$stamp"
    installed=1
  fi
}

runtime_req=python/requirements.txt
test_req=python/requirements-test.txt
installed=0
if [ "$tests" = 1 ]; then
  # the test file includes the runtime file (-r), so one install covers both
  install_once "$test_req" .venv/.skillmimic-tests.sha1 "$runtime_req" "$test_req"
  if [ "$installed" = 1 ]; then
    sha1sum < "$runtime_req" | cut -d' ' -f1 > .venv/.skillmimic-runtime.sha1
  fi
else
  install_once "$runtime_req" .venv/.skillmimic-runtime.sha1 "$runtime_req"
fi

# link the wheel's libmujoco for cargo (checked again only after an install or when the link is broken)
link=.mujoco/lib/libmujoco.so.3.17.0
if [ "$installed" = 1 ] || [ ! -e "$link" ] || [ ! -e .mujoco/lib/libmujoco.so ]; then
  lib=$(.venv/bin/python - <<'PY'
import os, mujoco
assert mujoco.__version__ == "3.17.0", f"mujoco {mujoco.__version__} installed, 3.17.0 required"
print(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so.3.17.0"))
PY
  )
  [ -f "$lib" ] || { echo "setup: $lib missing from the mujoco wheel" >&2; exit 1; }
  mkdir -p .mujoco/lib
  if [ "$(readlink "$link" 2>/dev/null || true)" != "$lib" ] || [ ! -e .mujoco/lib/libmujoco.so ]; then
    ln -sfn "$lib" "$link"
    ln -sfn libmujoco.so.3.17.0 .mujoco/lib/libmujoco.so
    echo "setup: linked .mujoco/lib/libmujoco.so -> $lib"
  fi
fi

# test data shipped inside crates.io packages (tests/data-crates/Cargo.toml: sources only, never
# built), fetched into the cargo registry once per manifest version
if [ "$tests" = 1 ]; then
  want=$(cat tests/data-crates/Cargo.toml tests/data-crates/Cargo.lock | sha1sum | cut -d' ' -f1)
  if [ "$(cat .venv/.skillmimic-data-crates.sha1 2>/dev/null || true)" != "$want" ]; then
    echo "setup: fetching the test-data crates (tests/data-crates)"
    cargo fetch --locked --manifest-path tests/data-crates/Cargo.toml
    echo "$want" > .venv/.skillmimic-data-crates.sha1
  fi
fi

# the guide's generator (docs/book.toml; scripts/docs.sh), built from crates.io into .tools once
# per pinned version: mdBook with its search index, without the file watcher and local server
mdbook_version=0.5.4
if [ "$tests" = 1 ] && [ "$(.tools/bin/mdbook --version 2>/dev/null || true)" != "mdbook v$mdbook_version" ]; then
  echo "setup: building mdBook $mdbook_version into .tools (once, about 2 min)"
  cargo install --quiet mdbook --version "$mdbook_version" --locked --no-default-features \
    --features search --root .tools
fi
