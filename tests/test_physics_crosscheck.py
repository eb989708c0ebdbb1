"""Physics cross-check: the Rust batched core and the official ``mujoco`` package from PyPI
(same libmujoco 3.17.0) produce bit-identical trajectories for the same scene, initial state and
control sequence.

The Rust side records a trace with ``skillmimic trace``: the MJCF text, the state after reset,
random actions for every policy step and the raw ``qpos``/``qvel`` after each policy step. This test
loads the *shipped* MJCF file with PyPI mujoco, applies the same state, turns the actions into
controls itself (``ctrl = pi * clip(a, -1, 1)`` mapped by actuator name ``<Body>_<axis>``) and steps
``mj_step`` twice per policy step.
"""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np
import pytest
from safetensors import safe_open

from reference_bounce import FloorBounce
from conftest import find_shared, run_cli, skeleton_dof_index

BODY_ORDER_FILE_HINT = "the skeleton order is the depth-first body order of the MJCF"


def replay(model: mujoco.MjModel, qpos0, qvel0, actions, substeps: int):
    n = qpos0.shape[0]
    datas = [mujoco.MjData(model) for _ in range(n)]
    bounce = [FloorBounce(model) for _ in range(n)]
    for i, d in enumerate(datas):
        d.time = 0.0
        d.qpos[:] = qpos0[i]
        d.qvel[:] = qvel0[i]
        d.ctrl[:] = 0.0
        d.qacc_warmstart[:] = 0.0
        mujoco.mj_forward(model, d)
    idx = skeleton_dof_index(model)
    qpos = np.zeros((actions.shape[0], n, model.nq))
    qvel = np.zeros((actions.shape[0], n, model.nv))
    for k in range(actions.shape[0]):
        for i, d in enumerate(datas):
            d.ctrl[:] = np.clip(actions[k, i].astype(np.float64), -1.0, 1.0)[idx] * np.pi
            for _ in range(substeps):
                mujoco.mj_step(model, d)
                bounce[i].after_substep(d)
            qpos[k, i] = d.qpos
            qvel[k, i] = d.qvel
    return qpos, qvel


@pytest.mark.parametrize("hands", ["full", "box"])
def test_rust_core_and_pypi_mujoco_are_bit_identical(tmp_path: pathlib.Path, repo_root, skillmimic_bin, hands):
    trace = tmp_path / f"trace_{hands}.safetensors"
    args = ["trace", "--out", str(trace), "--envs", "3", "--steps", "500", "--hands", hands, "--seed", "11"]
    shared = find_shared()
    if shared is not None:
        args += ["--clip", str(shared / "data/ballplay_m/layup/031_015pickle_layup_001_001.pt")]
    run_cli(skillmimic_bin, *args)

    with safe_open(str(trace), framework="np") as f:
        meta = f.metadata()
        t = {k: f.get_tensor(k) for k in f.keys()}
    shipped = repo_root / "mjcf" / ("skillmimic_full.xml" if hands == "full" else "skillmimic_boxhand.xml")
    assert shipped.read_text() == meta["xml"], f"{shipped} differs from the generator output: run `skillmimic mjcf`"
    assert meta["unstable_steps"] == "0"

    model = mujoco.MjModel.from_xml_path(str(shipped))
    assert mujoco.__version__ == "3.17.0"
    substeps = int(meta["substeps"])
    qpos, qvel = replay(model, t["qpos0"], t["qvel0"], t["actions"], substeps)

    physics_steps = t["actions"].shape[0] * substeps
    assert physics_steps >= 1000
    # bitwise equality at every policy step, reporting the first divergence if any
    for k in range(qpos.shape[0]):
        if not (np.array_equal(qpos[k], t["qpos"][k]) and np.array_equal(qvel[k], t["qvel"][k])):
            err = max(np.abs(qpos[k] - t["qpos"][k]).max(), np.abs(qvel[k] - t["qvel"][k]).max())
            pytest.fail(f"trajectories diverge at policy step {k} (max abs diff {err:.3e})")
    print(f"{hands}: {qpos.shape[1]} envs x {physics_steps} mj_steps bit-identical")
