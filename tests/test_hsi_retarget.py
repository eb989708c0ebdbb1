"""`skillmimic retarget`: real BallPlay-M locomotion clips (run, turn, pick) retargeted onto the
TokenHSI character, replayed kinematically in PyPI mujoco — independently of the Rust forward
kinematics — and measured as a user checks a retarget before training on it:

* the clip's stored body positions are the MuJoCo bodies of its joint coordinates (1e-5 m);
* feet on the floor: the lowest foot-box point over the source's stance frames (m), and no frame
  sinks into the floor;
* bone directions (thigh, shin, upper arm, forearm, spine) follow the source skeleton's;
* the written joint coordinates lie inside every hinge's range (the report counts the clamps).
"""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest
from safetensors import safe_open

import reference_env as ref
import skillmimic_rs
from conftest import run_cli
from test_hsi_character import JOINTS

CLIPS = ["run/013_018pickle_run_3.pt", "turn/042_018pickle_rturnover_30.pt", "pick_40/001_007pickle_pick_000.pt"]
# (target body, its child) ↔ (source body, its child): bones whose directions must agree
BONES = [
    (("right_thigh", "right_shin"), ("R_Hip", "R_Knee")),
    (("right_shin", "right_foot"), ("R_Knee", "R_Ankle")),
    (("left_thigh", "left_shin"), ("L_Hip", "L_Knee")),
    (("left_shin", "left_foot"), ("L_Knee", "L_Ankle")),
    (("right_upper_arm", "right_lower_arm"), ("R_Shoulder", "R_Elbow")),
    (("right_lower_arm", "right_hand"), ("R_Elbow", "R_Wrist")),
    (("left_upper_arm", "left_lower_arm"), ("L_Shoulder", "L_Elbow")),
    (("left_lower_arm", "left_hand"), ("L_Elbow", "L_Wrist")),
    (("pelvis", "head"), ("Pelvis", "Head")),
]
FEET = ("right_foot", "left_foot")


def _read(path):
    with safe_open(str(path), framework="numpy") as f:
        return f.metadata(), {k: f.get_tensor(k).astype(np.float64) for k in f.keys()}


def _qpos(m, clip, t):
    """MuJoCo qpos of frame t: free root, the 3-DoF joints' hinges (x, y, z), elbow hinges."""
    q = np.zeros(m.nq)
    q[0:3], q[3:7] = clip["root_pos"][t], clip["root_rot"][t]
    k = 0
    for _, joint, dofs, *_ in JOINTS:
        names = [f"{joint}_{a}" for a in "xyz"] if dofs == 3 else [joint]
        for a, name in enumerate(names):
            q[m.jnt_qposadr[m.joint(name).id]] = clip["dof_pos"][t, k + a]
        k += dofs
    return q


def _lowest_foot_point(m, d):
    z = np.inf
    for body in FEET:
        b = m.body(body).id
        for g in np.flatnonzero(m.geom_bodyid == b):
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
            h, c, r = m.geom_size[g], d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3)
            for s in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T:
                z = min(z, (c + r @ (s * h))[2])
    return z


def _violations(dof):
    """3-DoF axes beyond their per-axis limits (facts table) and elbows outside [−160°, 0°]."""
    axes, elbows, k = 0, 0, 0
    for _, _, dofs, lims, *_ in JOINTS:
        for a in range(dofs):
            lo, hi = np.radians(lims[a])
            bad = int(((dof[:, k + a] < lo - 1e-6) | (dof[:, k + a] > hi + 1e-6)).sum())
            if dofs == 3:
                axes += bad
            else:
                elbows += bad
        k += dofs
    return axes, elbows


def test_retargeted_ballplay_clips_replay_with_feet_on_the_floor(shared_dir, tmp_path, skillmimic_bin):
    root = shared_dir / "data" / "ballplay_m"
    files = [root / c for c in CLIPS if (root / c).exists()]
    assert len(files) == len(CLIPS), f"BallPlay-M clips missing: {CLIPS}"
    out = tmp_path / "hsi_clips"
    args = ["retarget", "--to", "tokenhsi", "--out", str(out)]
    for f in files:
        args += ["--motion", str(f)]
    print(run_cli(skillmimic_bin, *args).stdout)
    reports = {r["name"]: r for r in json.loads((out / "retarget_report.json").read_text())}
    env = skillmimic_rs.VecEnv(num_envs=1, task="hsi_follow")
    m = mujoco.MjModel.from_xml_string(env.mjcf_xml)  # the bare character (follow has no objects)
    d = mujoco.MjData(m)
    src_names = [mujoco.MjModel.from_xml_string(skillmimic_rs.VecEnv(num_envs=1).mjcf_xml).body(b).name for b in range(1, 54)]
    for f in files:
        meta, clip = _read(out / f"{f.stem}.safetensors")
        src = ref.load_clip(f)
        assert meta["format"] == "character-clip" and meta["character"] == "tokenhsi" and float(meta["fps"]) == src["fps"]
        rep = reports[f.stem]
        T = clip["root_pos"].shape[0]
        assert T == src["num_frames"] == rep["frames"]
        soles, fk_err, angles = np.zeros(T), 0.0, {b[0]: [] for b in BONES}
        for t in range(T):
            d.qpos[:] = _qpos(m, clip, t)
            mujoco.mj_kinematics(m, d)
            xpos = d.xpos[1:16]
            fk_err = max(fk_err, np.abs(xpos - clip["body_pos"][t]).max())
            soles[t] = _lowest_foot_point(m, d)
            for (ta, tb), (sa, sb) in BONES:
                u = d.xpos[m.body(tb).id] - d.xpos[m.body(ta).id]
                v = src["body_pos"][t, src_names.index(sb)] - src["body_pos"][t, src_names.index(sa)]
                c = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
                angles[(ta, tb)].append(math.degrees(math.acos(np.clip(c, -1, 1))))
        # stance frames of the source: its lowest foot body within 3 cm of the clip's 10th percentile
        feet = [src_names.index(n) for n in ("L_Ankle", "R_Ankle", "L_Toe", "R_Toe")]
        low = src["body_pos"][:, feet, 2].min(1)
        stance = low - np.sort(low)[T // 10] < 0.03
        err = np.abs(soles[stance])
        bone = {f"{a}->{b}": float(np.mean(v)) for (a, b), v in angles.items()}
        axes, elbows = _violations(clip["dof_pos"])
        print(f"{f.stem}: {T} frames, FK {fk_err:.1e} m; stance {int(stance.sum())} frames, |sole height| mean {1e3 * err.mean():.1f} mm "
              f"max {1e3 * err.max():.1f} mm; lowest sole over the clip {1e3 * soles.min():.1f} mm; "
              f"3-DoF axes beyond limits {axes} ({100 * axes / (T * 30):.1f} % of axis-frames); "
              f"report: constant-offset foot error {1e3 * rep['foot_height_error_mean']:.1f} mm, elbows clamped {rep['elbow_clamped']}")
        print("  mean bone angle to the source (deg): " + ", ".join(f"{k} {v:.1f}" for k, v in bone.items()))
        assert fk_err < 1e-5, "stored body positions are the forward kinematics of the joint coordinates"
        assert stance.sum() >= T // 10 and err.mean() < 0.005 and err.max() < 0.02, "feet on the floor in stance"
        assert soles.min() > -0.03, "no frame sinks a foot into the floor"
        assert max(bone.values()) < 15.0, bone
        assert np.mean(list(bone.values())) < 8.0, bone
        # the written coordinates are clamped into the hinge ranges (the report counts the clamps)
        assert axes == 0 and elbows == 0, (axes, elbows, rep)
        assert rep["stance_frames"] == int(stance.sum())
    env.close()


def test_retarget_refuses_bad_input(tmp_path, skillmimic_bin):
    import subprocess

    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a zip")
    r = subprocess.run([str(skillmimic_bin), "retarget", "--motion", str(bad), "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode != 0 and "bad.pt" in r.stderr, r.stderr
    r = subprocess.run([str(skillmimic_bin), "retarget", "--to", "robot", "--motion", str(bad), "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode != 0 and "tokenhsi" in r.stderr and "smpl" in r.stderr, r.stderr
