"""The TokenHSI character (TokenHSI supplementary §A; ../shared/docs/modskill-tokenhsi-facts.md §2.1)
in PyPI mujoco: the table below is written from the facts file and the original MJCF's numbers,
independently of the Rust generator, and checked against the generated model; then the Rust batch
and PyPI mujoco step the same scene (character + a free carry box + two mocap supports) with the
same random actions, bit for bit, with the action -> PD-target map computed here from the joint
limits (ASE's rule).
"""

from __future__ import annotations

import math
import pathlib

import mujoco
import numpy as np
import pytest
from safetensors import safe_open

from conftest import run_cli

# body, joint, dofs, per-axis limits (deg), kp, kd, torque limit (original motor gear)
JOINTS = [
    ("torso", "abdomen", 3, [(-60, 60), (-60, 90), (-50, 50)], 1000, 100, 200),
    ("head", "neck", 3, [(-50, 50), (-40, 60), (-45, 45)], 100, 10, 50),
    ("right_upper_arm", "right_shoulder", 3, [(-180, 45), (-180, 60), (-90, 90)], 400, 40, 100),
    ("right_lower_arm", "right_elbow", 1, [(-160, 0)], 300, 30, 70),
    ("left_upper_arm", "left_shoulder", 3, [(-45, 180), (-180, 60), (-90, 90)], 400, 40, 100),
    ("left_lower_arm", "left_elbow", 1, [(-160, 0)], 300, 30, 70),
    ("right_thigh", "right_hip", 3, [(-60, 15), (-140, 60), (-60, 35)], 500, 50, 200),
    ("right_shin", "right_knee", 3, [(-5.625, 5.625), (0, 160), (-5.625, 5.625)], 500, 50, 150),
    ("right_foot", "right_ankle", 3, [(-30, 30), (-55, 55), (-40, 40)], 400, 40, 90),
    ("left_thigh", "left_hip", 3, [(-15, 60), (-140, 60), (-35, 60)], 500, 50, 200),
    ("left_shin", "left_knee", 3, [(-5.625, 5.625), (0, 160), (-5.625, 5.625)], 500, 50, 150),
    ("left_foot", "left_ankle", 3, [(-30, 30), (-55, 55), (-40, 40)], 400, 40, 90),
]
BODIES = ["pelvis", "torso", "head", "right_upper_arm", "right_lower_arm", "right_hand", "left_upper_arm",
          "left_lower_arm", "left_hand", "right_thigh", "right_shin", "right_foot", "left_thigh", "left_shin", "left_foot"]
# SMPL-matched lower-body offsets of supplementary §A (original MJCF), parent frame, metres
LOWER_BODY_OFFSETS = {
    "right_thigh": (-0.0043, -0.0677, -0.0905), "right_shin": (-0.0089, -0.0383, -0.3826), "right_foot": (-0.0423, 0.0158, -0.3984),
    "left_thigh": (-0.0068, 0.0695, -0.0914), "left_shin": (-0.0045, 0.0343, -0.3752), "left_foot": (-0.0437, -0.0136, -0.3980),
}


def action_maps():
    """Per action entry (offset, scale) in radians: ASE's rule, from the limits above."""
    out = []
    for _, _, dofs, lims, *_ in JOINTS:
        if dofs == 3:
            s = min(1.2 * max(max(abs(lo), abs(hi)) for lo, hi in lims), 180.0)
            out += [(0.0, math.radians(s))] * 3
        else:
            lo, hi = lims[0]
            out.append((math.radians(0.5 * (lo + hi)), math.radians(0.7 * (hi - lo))))
    return np.array(out)


def actuator_action_index(model):
    idx, k = {}, 0
    for _, joint, dofs, *_ in JOINTS:
        if dofs == 3:
            for a, axis in enumerate("xyz"):
                idx[f"{joint}_{axis}"] = k + a
        else:
            idx[joint] = k
        k += dofs
    return np.array([idx[model.actuator(a).name] for a in range(model.nu)])


@pytest.fixture(scope="module")
def trace(tmp_path_factory, skillmimic_bin):
    path = tmp_path_factory.mktemp("hsi") / "trace.safetensors"
    run_cli(skillmimic_bin, "trace", "--character", "tokenhsi", "--out", str(path), "--envs", "3", "--steps", "300", "--seed", "5", "--amplitude", "0.8")
    with safe_open(str(path), framework="np") as f:
        return f.metadata(), {k: f.get_tensor(k) for k in f.keys()}


def test_the_character_matches_the_facts(trace):
    meta, _ = trace
    m = mujoco.MjModel.from_xml_string(meta["xml"])
    names = [m.body(b).name for b in range(m.nbody)]
    assert names[1:16] == BODIES, "15 bodies in depth-first order"
    assert m.nu == 32 and sum(j[2] for j in JOINTS) == 32
    balls = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
    hinges = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert len(balls) == 0 and len(hinges) == 32, "3-DoF joints are three limited hinges, as released"
    for body, off in LOWER_BODY_OFFSETS.items():
        np.testing.assert_allclose(m.body(body).pos, off, atol=1e-12)
    for body, joint, dofs, lims, kp, kd, effort in JOINTS:
        names = [f"{joint}_{a}" for a in "xyz"] if dofs == 3 else [joint]
        for a, (name, lim) in enumerate(zip(names, lims)):
            j = m.joint(name)
            assert m.jnt_bodyid[j.id] == m.body(body).id
            assert m.jnt_stiffness[j.id] == 0.0, "gains are actuators, not springs"
            assert m.jnt_limited[j.id], f"{name} is limited"
            np.testing.assert_allclose(m.jnt_range[j.id], np.radians(lim), atol=1e-12, err_msg=name)
            axis = np.zeros(3)
            axis[a if dofs == 3 else 1] = 1.0
            np.testing.assert_allclose(m.jnt_axis[j.id], axis, err_msg=name)
            np.testing.assert_allclose(m.dof_damping[j.dofadr[0]], kd)
            act = m.actuator(name)
            assert act.gainprm[0] == kp and act.biasprm[1] == -kp
            np.testing.assert_allclose(act.forcerange, [-effort, effort])
    assert abs(m.opt.timestep - 1 / 120) < 1e-15 and meta["substeps"] == "4", "30 Hz control over a 1/120 s step"
    mass = sum(m.body_mass[m.body(b).id] for b in BODIES)
    print(f"character mass {mass:.2f} kg")
    assert 50.0 < mass < 80.0


ASSET = pathlib.Path(__file__).parent / "fixtures" / "tokenhsi_box_foot_asset.json"


def test_the_character_matches_the_released_asset(trace):
    """Per-axis joint ranges, per-body masses and the foot boxes against the released
    phys_humanoid_v3_box_foot.xml as PyPI mujoco compiles it (tests/fixtures, see its note)."""
    import json

    ref = json.loads(ASSET.read_text())
    meta, _ = trace
    m = mujoco.MjModel.from_xml_string(meta["xml"])
    for b in ref["bodies"]:
        body = m.body(b["name"])
        assert m.body(m.body_parentid[body.id]).name == (b["parent"] if b["parent"] != "world" else "world")
        if b["name"] != "pelvis":
            np.testing.assert_allclose(body.pos, b["pos"], atol=1e-12, err_msg=b["name"])
        np.testing.assert_allclose(m.body_mass[body.id], b["mass"], rtol=1e-9, err_msg=b["name"])
    mass = sum(m.body_mass[m.body(b["name"]).id] for b in ref["bodies"])
    np.testing.assert_allclose(mass, ref["total_mass"], rtol=1e-9)
    for j in ref["joints"]:
        jj = m.joint(j["name"])
        assert m.body(m.jnt_bodyid[jj.id]).name == j["body"]
        np.testing.assert_allclose(m.jnt_axis[jj.id], j["axis"])
        np.testing.assert_allclose(np.degrees(m.jnt_range[jj.id]), j["range_deg"], atol=1e-9, err_msg=j["name"])
        np.testing.assert_allclose(m.dof_armature[jj.dofadr[0]], j["armature"])
        # the released stiffness/damping are Isaac Gym's PD gains: our position actuator and damping
        assert m.actuator(j["name"]).gainprm[0] == j["stiffness"]
        np.testing.assert_allclose(m.dof_damping[jj.dofadr[0]], j["damping"])
    for a in ref["actuators"]:
        # the released motor gear is the torque limit of the PD drive
        np.testing.assert_allclose(m.actuator(a["joint"]).forcerange, [-a["gear"], a["gear"]])
    for g in ref["foot_geoms"]:
        geom = m.geom(g["name"])
        assert m.body(m.geom_bodyid[geom.id]).name == g["body"] and geom.type == mujoco.mjtGeom.mjGEOM_BOX
        np.testing.assert_allclose(geom.size, g["size"], atol=1e-12)
        np.testing.assert_allclose(geom.pos, g["pos"], atol=1e-12)
        q = np.array(g["quat_wxyz"]) / np.linalg.norm(g["quat_wxyz"])
        np.testing.assert_allclose(geom.quat, q, atol=1e-12)
    feet = [m.geom(g).id for g in range(m.ngeom) if m.body(m.geom_bodyid[g]).name in ("left_foot", "right_foot")]
    assert len(feet) == 2, "one box per foot (the released box-foot variant), no toe boxes"
    # rest pose: pelvis at the released spawn height, lowest foot corner at the floor
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    pelvis = d.xpos[m.body("pelvis").id][2]
    np.testing.assert_allclose(pelvis, ref["released_spawn_height"], atol=1e-12)
    signs = [np.array(c) * 2.0 - 1.0 for c in np.ndindex(2, 2, 2)]  # the eight box corners
    lowest = min((d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ (s * m.geom_size[g]))[2] for g in feet for s in signs)
    np.testing.assert_allclose(pelvis - lowest, ref["standing_root_height"], atol=1e-9)


def test_rust_batch_and_pypi_mujoco_step_bit_identically(trace):
    meta, t = trace
    assert meta["unstable_steps"] == "0"
    m = mujoco.MjModel.from_xml_string(meta["xml"])
    maps = action_maps()
    idx = actuator_action_index(m)
    substeps = int(meta["substeps"])
    n = t["qpos0"].shape[0]
    for i in range(n):
        d = mujoco.MjData(m)
        d.qpos[:] = t["qpos0"][i]
        d.qvel[:] = t["qvel0"][i]
        d.mocap_pos[:] = t["mocap_pos"][i]
        d.mocap_quat[:] = t["mocap_quat"][i]
        mujoco.mj_forward(m, d)
        for k in range(t["actions"].shape[0]):
            a = np.clip(t["actions"][k, i].astype(np.float64), -1.0, 1.0)
            d.ctrl[:] = (maps[:, 0] + maps[:, 1] * a)[idx]
            for _ in range(substeps):
                mujoco.mj_step(m, d)
            if not (np.array_equal(d.qpos, t["qpos"][k, i]) and np.array_equal(d.qvel, t["qvel"][k, i])):
                err = max(np.abs(d.qpos - t["qpos"][k, i]).max(), np.abs(d.qvel - t["qvel"][k, i]).max())
                pytest.fail(f"env {i}: diverges at policy step {k} (max abs diff {err:.3e})")
    # the free box moved under gravity/contacts: the check covered object dynamics too
    box = m.joint("box").qposadr[0]
    assert np.abs(t["qpos"][-1, :, box:box + 3] - t["qpos0"][:, box:box + 3]).max() > 1e-3
    print(f"{n} envs x {t['actions'].shape[0] * substeps} mj_steps bit-identical")
