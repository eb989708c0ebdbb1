"""Shared fixtures of the Python test-suite (run by scripts/test.sh with the project's .venv).

* ``repo_root``: the checkout;
* ``skillmimic_bin``: the release CLI built by scripts/test.sh;
* ``shared_dir``: the reference data folder (``$SKILLMIMIC_SHARED`` or ``<repo>/../shared``); tests
  that need it skip with a message when it is absent, and fail instead when ``CI`` is set.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:  # numpy is imported where used, so numpy-free tests (test_architecture) run on any python
    import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo_root() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def skillmimic_bin() -> pathlib.Path:
    exe = REPO / "target" / "release" / "skillmimic"
    if not exe.exists():
        pytest.fail(f"{exe} not found: build it with `cargo build --release -p skillmimic-cli` (scripts/test.sh does)")
    return exe


def find_shared() -> pathlib.Path | None:
    d = pathlib.Path(os.environ.get("SKILLMIMIC_SHARED", REPO.parent / "shared"))
    return d if (d / "data").is_dir() else None


@pytest.fixture(scope="session")
def shared_dir() -> pathlib.Path:
    d = find_shared()
    if d is None:
        msg = "reference data not found (set SKILLMIMIC_SHARED or place the shared folder next to the checkout)"
        if os.environ.get("CI"):
            pytest.fail(msg + " and CI is set, so this test may not be skipped")
        pytest.skip(msg)
    return d


def require_module(name: str):
    """Import an optional test dependency: skip the test (or module) where it is missing, but fail
    when ``CI`` is set, where every test dependency is installed and a skip would hide a broken
    install (``pytest.importorskip`` alone skips silently even on CI)."""
    if os.environ.get("CI"):
        import importlib

        return importlib.import_module(name)
    return pytest.importorskip(name)


def scene_model():
    """PyPI mujoco and an ``MjModel`` of our default scene (humanoid + ball), built by PyPI mujoco
    from the MJCF the environment itself loads."""
    mujoco = require_module("mujoco")
    import skillmimic_rs

    env = skillmimic_rs.VecEnv(num_envs=1, autoreset_mode="disabled", threads=1)
    try:
        return mujoco, mujoco.MjModel.from_xml_string(env.mjcf_xml)
    finally:
        env.close()


def run_cli(exe: pathlib.Path, *args: str) -> subprocess.CompletedProcess:
    """Run the CLI, failing the test with its stderr on a non-zero exit."""
    r = subprocess.run([str(exe), *args], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"skillmimic {' '.join(args)} failed ({r.returncode}):\n{r.stderr}")
    return r


def skeleton_dof_index(model) -> np.ndarray:
    """For each actuator of a `mujoco.MjModel` of our scene, its index in the 156-wide action
    vector (3 * (body - 1) + axis), the skeleton bodies being MuJoCo body ids 1..53 (depth-first
    MJCF order)."""
    import numpy as np

    names = [model.body(b).name for b in range(1, 54)]
    out = []
    for a in range(model.nu):
        body, axis = model.actuator(a).name.rsplit("_", 1)
        out.append(3 * (names.index(body) - 1) + "xyz".index(axis))
    return np.array(out)
