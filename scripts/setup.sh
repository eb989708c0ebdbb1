#!/usr/bin/env bash
# One-time (and idempotent) set-up of a checkout:
#   1. a project virtual environment .venv with the pinned Python packages
#      (mujoco==3.17.0 is the source of libmujoco for both Rust and Python);
#   2. .mujoco/lib/libmujoco.so -> the wheel's libmujoco.so.3.17.0, which .cargo/config.toml hands
#      to the mujoco-rs build script, and which the crates' build script bakes in as run-time path.
# A second run only checks two stamps and returns in well under a second.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

python_bin=${PYTHON:-python3}
if ! command -v "$python_bin" >/dev/null 2>&1; then
  echo "setup: '$python_bin' not found; install Python >= 3.10 or set PYTHON=/path/to/python" >&2
  exit 1
fi
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $("$python_bin" --version 2>&1)"
  "$python_bin" -m venv .venv
fi

req=python/requirements-dev.txt
stamp=.venv/.skillmimic-requirements.sha1
want=$(sha1sum "$req" | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
  echo "setup: installing Python packages from $req (first run only)"
  .venv/bin/python -m pip install --disable-pip-version-check -q --upgrade pip
  .venv/bin/python -m pip install --disable-pip-version-check -q -r "$req"
  echo "$want" > "$stamp"
fi

lib=$(.venv/bin/python - <<'PY'
import os, mujoco
assert mujoco.__version__ == "3.17.0", f"mujoco {mujoco.__version__} installed, 3.17.0 required"
print(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so.3.17.0"))
PY
)
[ -f "$lib" ] || { echo "setup: $lib missing from the mujoco wheel" >&2; exit 1; }
mkdir -p .mujoco/lib
if [ "$(readlink .mujoco/lib/libmujoco.so.3.17.0 2>/dev/null || true)" != "$lib" ]; then
  ln -sfn "$lib" .mujoco/lib/libmujoco.so.3.17.0
  ln -sfn libmujoco.so.3.17.0 .mujoco/lib/libmujoco.so
  echo "setup: linked .mujoco/lib/libmujoco.so -> $lib"
fi
