"""Issue 23, round trip through a third-party BVH writer: real BallPlay-M clips are written as BVH
files by ``bvhio`` (PyPI; its own Euler conversion and number formatting, not our code), with the
humanoid's hierarchy taken from the MuJoCo model of the scene (PyPI ``mujoco``: body offsets,
centimetres, Y-up skeleton frame), then retargeted back with ``skillmimic retarget --bvh --map
humanoid`` (and ``skillmimic_rs.retarget_bvh``). Body positions must come back within 1 cm of PyPI mujoco's forward kinematics of the
original clip, and every joint rotation within 0.02 rad.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import reference_env as ref
from conftest import require_module, run_cli, scene_model

CLIPS = ["run/013_018pickle_run_3.pt", "layup/031_015pickle_layup_001_001.pt", "pick_40/001_007pickle_pick_000.pt"]


def quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def rotvec_quat(v):
    a = float(np.linalg.norm(v))
    if a < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[np.cos(a / 2)], np.sin(a / 2) * np.asarray(v) / a])


def quat_rotate(q, v):
    qv = np.concatenate([[0.0], v])
    return quat_mul(quat_mul(q, qv), q * np.array([1, -1, -1, -1]))[1:]


def angle_between(a, b):
    return 2 * np.arccos(np.clip(abs(float(np.dot(a, b))), 0.0, 1.0))


def write_with_bvhio(clip, model, path: pathlib.Path):
    bvhio = require_module("bvhio")
    glm = require_module("glm")
    bodies = [model.body(b) for b in range(1, 54)]  # the 53 skeleton bodies, depth-first
    joints = {}
    for b in bodies:
        offset = np.zeros(3) if b.id == 1 else 100.0 * np.asarray(b.pos)  # skeleton offsets, cm; the root is placed by its channels
        j = bvhio.BvhJoint(b.name, glm.vec3(*offset))
        j.Channels = (["Xposition", "Yposition", "Zposition"] if b.id == 1 else []) + ["Zrotation", "Xrotation", "Yrotation"]
        j.EndSite = glm.vec3(1, 0, 0)
        joints[b.id] = j
        if b.id != 1:
            joints[int(model.body_parentid[b.id])].Children.append(j)
    tilt_inv = rotvec_quat([-np.pi / 2, 0.0, 0.0])  # world Z-up -> skeleton Y-up
    T = clip["num_frames"]
    for t in range(T):
        root_q = quat_mul(tilt_inv, np.asarray(clip["root_rot"][t], np.float64))
        root_p = 100.0 * quat_rotate(tilt_inv, np.asarray(clip["root_pos"][t], np.float64))
        for b in bodies:
            if b.id == 1:
                q, p = root_q, root_p
            else:
                q, p = rotvec_quat(np.asarray(clip["dof_rot"][t][b.id - 2], np.float64)), np.zeros(3)
            joints[b.id].Keyframes.append(bvhio.Pose(glm.vec3(*p), glm.quat(*q)))
    container = bvhio.BvhContainer(joints[1], T, 1.0 / clip["fps"])
    bvhio.writeBvh(str(path), container, percision=9)


@pytest.mark.parametrize("rel", CLIPS)
def test_ballplay_clip_round_trips_through_a_third_party_bvh_writer(rel, shared_dir, skillmimic_bin, tmp_path):
    import skillmimic_rs

    mujoco, model = scene_model()
    clip = ref.load_clip(shared_dir / "data" / "ballplay_m" / rel)
    bvh = tmp_path / "clip.bvh"
    write_with_bvhio(clip, model, bvh)
    if rel == CLIPS[0]:  # the Python API (the same Rust code, in this process)
        rep = skillmimic_rs.retarget_bvh(bvh, out=tmp_path, skill=int(clip["skill"]), map="humanoid", no_ground=True, name="back")
        assert rep["frames"] == clip["num_frames"] and rep["clip"].exists()
    else:
        run_cli(skillmimic_bin, "retarget", "--bvh", str(bvh), "--map", "humanoid", "--skill", str(clip["skill"]), "--no-ground", "--name", "back", "--out", str(tmp_path))
    back = ref.load_clip(tmp_path / "back.safetensors")
    assert back["num_frames"] == clip["num_frames"]
    # PyPI mujoco's forward kinematics of both clips (qpos from the clip, ball-free columns kept)
    data = mujoco.MjData(model)
    derived, derived_back = ref.derive_reference(clip), ref.derive_reference(back)
    worst_p = worst_r = 0.0
    for t in range(clip["num_frames"]):
        xs = []
        for c, d in ((clip, derived), (back, derived_back)):
            data.qpos[:] = ref.reset_qpos_qvel(model, c, d, t)[0]
            mujoco.mj_kinematics(model, data)
            xs.append(np.array(data.xpos[1:54]))
        worst_p = max(worst_p, float(np.linalg.norm(xs[0] - xs[1], axis=1).max()))
        worst_r = max(worst_r, angle_between(np.asarray(clip["root_rot"][t], np.float64), np.asarray(back["root_rot"][t], np.float64)))
        for j in range(52):
            qa = rotvec_quat(np.asarray(clip["dof_rot"][t][j], np.float64))
            qb = rotvec_quat(np.asarray(back["dof_rot"][t][j], np.float64))
            worst_r = max(worst_r, angle_between(qa, qb))
    print(f"{rel}: {clip['num_frames']} frames through bvhio: body positions within {100 * worst_p:.3f} cm, rotations within {worst_r:.2e} rad")
    assert worst_p < 0.01 and worst_r < 0.02
