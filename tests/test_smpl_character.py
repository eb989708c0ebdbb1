"""The SMPL humanoid (PHC, ModSkill) in PyPI mujoco, against the numbers of PHC's own
``smpl_humanoid.xml`` (``tests/fixtures/phc_smpl_humanoid.json``, read from that file compiled
unchanged with PyPI mujoco; see the fixture's ``source``) and the facts written here from PHC,
SMPLSim and ModSkill:

* the generated ``mjcf/smpl.xml``: 24 bodies in PHC's order with the file's parents, body offsets
  to 1 mm after PHC's upright turn (the Y-up file's (x, y, z) is (z, x, y) in the simulated Z-up
  frame), per-body masses to 0.1 %, three hinges x, y, z per non-root body (69) with
  world-aligned axes, 69 actuators, the file's ten excluded body pairs, SMPLSim's PD gains and
  ModSkill's joint ranges (``has_jt_limit: False``: ±180°, shoulders and elbows ±720°);
* the Rust batch and PyPI mujoco step the same SMPL scene with the same random actions bit for bit,
  with the action -> PD target map written here (π per hinge, 5 rad for knee flexion).
"""

from __future__ import annotations

import json
import math
import pathlib

import mujoco
import numpy as np
import pytest
from safetensors import safe_open

from conftest import run_cli

REPO = pathlib.Path(__file__).resolve().parent.parent
FIXTURE = json.loads((REPO / "tests" / "fixtures" / "phc_smpl_humanoid.json").read_text())

# SMPLSim's GAINS_PHC (kp N m/rad, kd N m s/rad), shared by the three hinges of a body
GAINS = {"Hip": (800, 80), "Knee": (800, 80), "Ankle": (800, 80), "Toe": (500, 50), "Torso": (1000, 100),
         "Spine": (1000, 100), "Chest": (1000, 100), "Neck": (500, 50), "Head": (500, 50), "Thorax": (500, 50),
         "Shoulder": (500, 50), "Elbow": (500, 50), "Wrist": (300, 30), "Hand": (300, 30)}


def zup(v):
    """PHC's upright turn: a Y-up vector (x, y, z) is (z, x, y) Z-up."""
    return np.array([v[2], v[0], v[1]])


def segment(name: str) -> str:
    return name.split("_")[-1]


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(REPO / "mjcf" / "smpl.xml"))


def test_bodies_offsets_and_masses_match_phc(model):
    ref = FIXTURE["bodies"]
    names = [model.body(b).name for b in range(1, model.nbody)]
    assert names == [b["name"] for b in ref], "24 bodies in PHC's depth-first order"
    worst_pos, worst_mass = 0.0, 0.0
    for b in ref:
        body = model.body(b["name"])
        parent = model.body(int(body.parentid[0])).name
        assert parent == ("world" if b["parent"] == "world" else b["parent"]), b["name"]
        if b["parent"] != "world":  # the root's position is the state's, not the file's
            worst_pos = max(worst_pos, np.abs(body.pos - zup(b["pos"])).max())
        worst_mass = max(worst_mass, abs(body.mass[0] - b["mass"]) / b["mass"])
    total = sum(model.body_mass[1:])
    print(f"offsets within {worst_pos * 1e3:.4f} mm, masses within {100 * worst_mass:.5f} %, total {total:.3f} kg "
          f"(PHC {FIXTURE['total_mass']:.3f} kg)")
    assert worst_pos < 1e-3
    assert worst_mass < 1e-3 and abs(total - FIXTURE["total_mass"]) < 0.01


def test_joint_layout_actuators_gains_and_exclusions(model):
    hinges = [j for j in FIXTURE["joints"] if j["type"] == "hinge"]
    assert len(hinges) == 69 and model.nu == FIXTURE["nu"] == 69
    assert model.njnt == 70 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    for j in hinges:
        jj = model.joint(j["name"])
        assert jj.type[0] == mujoco.mjtJoint.mjJNT_HINGE, j["name"]
        # the file's axes are world-aligned x, y, z in its Y-up frame; upright, the hinge called
        # _x turns about Z-up x (forward) as PHC builds its runtime asset: named axes stay x, y, z
        axis = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[j["name"][-1]]
        np.testing.assert_array_equal(jj.axis, axis)
        body = j["name"][:-2]
        wide = segment(body) in ("Shoulder", "Elbow")
        np.testing.assert_allclose(jj.range, [-4 * math.pi, 4 * math.pi] if wide else [-math.pi, math.pi], atol=1e-12)
        kp, kd = GAINS[segment(body)]
        a = model.actuator(j["name"])
        assert a.gainprm[0] == kp and jj.damping[0] == kd and jj.armature[0] == 0.02, j["name"]
        np.testing.assert_allclose(a.forcerange, [-500, 500])
    excluded = {tuple(sorted((model.body(int(model.exclude_signature[k]) >> 16).name,
                              model.body(int(model.exclude_signature[k]) & 0xFFFF).name)))
                for k in range(model.nexclude)}
    assert excluded == {tuple(sorted(p)) for p in FIXTURE["contact_excludes"]}
    assert abs(model.opt.timestep - 1 / 120) < 1e-15


def action_scale(name: str) -> float:
    """PHC's map: min(1.2 * max |range|, pi) per hinge (pi with these ranges); knee flexion 5 rad."""
    return 5.0 if name in ("L_Knee_y", "R_Knee_y") else math.pi


@pytest.fixture(scope="module")
def trace(tmp_path_factory, skillmimic_bin):
    path = tmp_path_factory.mktemp("smpl") / "trace.safetensors"
    run_cli(skillmimic_bin, "trace", "--character", "smpl", "--out", str(path), "--envs", "3", "--steps", "150",
            "--seed", "3", "--amplitude", "0.6")
    with safe_open(str(path), framework="np") as f:
        return f.metadata(), {k: f.get_tensor(k) for k in f.keys()}


def test_rust_batch_and_pypi_mujoco_step_bit_identically(trace):
    meta, t = trace
    assert meta["character"] == "smpl" and meta["substeps"] == "4" and meta["unstable_steps"] == "0"
    m = mujoco.MjModel.from_xml_string(meta["xml"])
    # dof k of the action vector is hinge k in body order (x, y, z per body)
    dof_names = [m.joint(j).name for j in range(1, m.njnt)]
    scale = np.array([action_scale(n) for n in dof_names])
    idx = np.array([dof_names.index(m.actuator(a).name) for a in range(m.nu)])
    for i in range(t["qpos0"].shape[0]):
        d = mujoco.MjData(m)
        d.qpos[:] = t["qpos0"][i]
        d.qvel[:] = t["qvel0"][i]
        mujoco.mj_forward(m, d)
        for k in range(t["actions"].shape[0]):
            a = np.clip(t["actions"][k, i].astype(np.float64), -1.0, 1.0)
            d.ctrl[:] = (0.0 + scale * a)[idx]
            for _ in range(4):
                mujoco.mj_step(m, d)
            if not (np.array_equal(d.qpos, t["qpos"][k, i]) and np.array_equal(d.qvel, t["qvel"][k, i])):
                err = max(np.abs(d.qpos - t["qpos"][k, i]).max(), np.abs(d.qvel - t["qvel"][k, i]).max())
                pytest.fail(f"env {i}: diverges at policy step {k} (max abs diff {err:.3e})")
