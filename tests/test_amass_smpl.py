"""Issue 39: a user's AMASS-format motion on the SMPL humanoid, without retargeting.

* ``skillmimic_rs.amass_to_smpl`` (``skillmimic retarget --amass F --to smpl``) writes a clip whose
  pose, set into PyPI mujoco's compile of ``mjcf/smpl.xml``, puts every body where SMPL's own
  forward kinematics puts its joint: written here with numpy from the definition (Rodrigues, SMPL's
  kinematic tree, ``x_j = x_parent + R_parent · offset_j``, pelvis at ``trans + J_pelvis``) on the
  rest offsets of PHC's ``smpl_humanoid.xml`` (``tests/fixtures/phc_smpl_humanoid.json``), and
  turns every body like SMPL's joint followed by PHC's upright turn (Y-up (x, y, z) -> Z-up
  (z, x, y)).
* End to end: a synthetic SMPL-H ``.npz`` given as ``env.motion`` trains the tracking task on the
  SMPL humanoid for a few iterations and evaluates with PHC's metrics (E_g-mpjpe, E_mpjpe, velocity
  and acceleration errors, success); files with another joint count, a bad frame rate or
  non-finite values are refused naming the file.
"""

from __future__ import annotations

import json
import math
import pathlib
import subprocess

import mujoco
import numpy as np
from safetensors.numpy import load_file

from conftest import run_cli

REPO = pathlib.Path(__file__).resolve().parent.parent
FIXTURE = json.loads((REPO / "tests" / "fixtures" / "phc_smpl_humanoid.json").read_text())

# SMPL's 24 joints in SMPL's order (the humanoid's body names) and their parents
SMPL_NAMES = ["Pelvis", "L_Hip", "R_Hip", "Torso", "L_Knee", "R_Knee", "Spine", "L_Ankle", "R_Ankle", "Chest", "L_Toe", "R_Toe",
              "Neck", "L_Thorax", "R_Thorax", "Head", "L_Shoulder", "R_Shoulder", "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist",
              "L_Hand", "R_Hand"]
SMPL_PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21]
# PHC's upright turn as a matrix: a Y-up vector (x, y, z) becomes (z, x, y)
P = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def rodrigues(v: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(v))
    if th < 1e-12:
        return np.eye(3)
    k = v / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * kx + (1 - math.cos(th)) * kx @ kx


def smpl_fk(pose72: np.ndarray, trans: np.ndarray):
    """SMPL's joint positions and world rotations for one frame (72 axis-angle values)."""
    off = {b["name"]: np.array(b["pos"]) for b in FIXTURE["bodies"]}  # Y-up rest offsets; Pelvis: J_pelvis
    R, x = [None] * 24, [None] * 24
    for j in range(24):
        local = rodrigues(pose72[3 * j:3 * j + 3])
        p = SMPL_PARENTS[j]
        if p < 0:
            R[j], x[j] = local, trans + off["Pelvis"]
        else:
            R[j], x[j] = R[p] @ local, x[p] + R[p] @ off[SMPL_NAMES[j]]
    return np.array(x), np.array(R)


def random_sequence(rng, frames: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    poses = np.zeros((frames, width))
    poses[:, :66] = rng.uniform(-0.6, 0.6, (frames, 66))
    poses[:, 0:3] = [math.pi / 2, 0.0, 0.0] + rng.uniform(-0.3, 0.3, (frames, 3))  # stood up in the Z-up world
    if width > 66:
        poses[:, 66:] = rng.uniform(-0.6, 0.6, (frames, width - 66))  # SMPL hands / SMPL-H fingers
    trans = rng.uniform(-1, 1, (frames, 3)) + [0, 0, 0.9]
    return poses, trans


def test_smpl_joint_rotations_go_onto_the_humanoid_as_smpl_poses_them(tmp_path):
    import skillmimic_rs

    model = mujoco.MjModel.from_xml_path(str(REPO / "mjcf" / "smpl.xml"))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(39)
    worst_p = worst_r = 0.0
    for width in (72, 156, 165):
        poses, trans = random_sequence(rng, 5, width)
        npz = tmp_path / f"seq{width}.npz"
        np.savez(npz, poses=poses, trans=trans, mocap_framerate=np.array(60.0), betas=np.zeros(16))
        rep = skillmimic_rs.amass_to_smpl(npz, out=tmp_path, no_ground=True)
        assert rep["frames"] == 5 and rep["source_width"] == width and rep["ground_shift"] == 0.0 and rep["betas_ignored"]
        clip = load_file(str(rep["clip"]))
        names = [model.body(b).name for b in range(1, model.nbody)]
        for f in range(5):
            qpos = np.zeros(model.nq)
            qpos[:3], qpos[3:7] = clip["root_pos"][f], clip["root_rot"][f]
            for b, name in enumerate(names[1:]):
                for k, axis in enumerate("xyz"):
                    qpos[model.jnt_qposadr[model.joint(f"{name}_{axis}").id]] = clip["dof_pos"][f, 3 * b + k]
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            pose72 = poses[f, :72].copy() if width == 72 else np.concatenate([poses[f, :66], np.zeros(6)])
            x, R = smpl_fk(pose72, trans[f])
            for b, name in enumerate(names):
                j = SMPL_NAMES.index(name)
                worst_p = max(worst_p, float(np.abs(data.xpos[b + 1] - x[j]).max()))
                worst_r = max(worst_r, float(np.abs(data.xmat[b + 1].reshape(3, 3) - R[j] @ P.T).max()))
            np.testing.assert_allclose(clip["body_pos"][f], data.xpos[1:], atol=1e-5)
    print(f"24 bodies x 5 frames x 3 layouts: positions within {worst_p:.2e} m of SMPL's forward kinematics, "
          f"rotation matrices within {worst_r:.2e}")
    assert worst_p < 2e-4  # the MJCF's offsets are the file's to 0.1 mm; float32 clip storage
    assert worst_r < 1e-5


def _walk(path: pathlib.Path, frames: int = 60, fps: float = 30.0) -> None:
    """A gentle in-place SMPL-H motion: standing, arms swinging, slow turn."""
    t = np.arange(frames) / fps
    poses = np.zeros((frames, 156))
    poses[:, 0] = math.pi / 2
    poses[:, 16 * 3 + 2] = -1.2 + 0.3 * np.sin(2 * math.pi * t)  # left shoulder down from the T-pose
    poses[:, 17 * 3 + 2] = 1.2 + 0.3 * np.sin(2 * math.pi * t)
    poses[:, 18 * 3 + 1] = -0.4
    poses[:, 19 * 3 + 1] = 0.4
    trans = np.tile([0.0, 0.0, 0.93], (frames, 1))
    np.savez(path, poses=poses, trans=trans, mocap_framerate=np.array(fps))


def train_tiny_tracking(skillmimic_bin, npz: pathlib.Path, out: pathlib.Path) -> None:
    """Two iterations of the tracking task on the SMPL humanoid with motion `npz` (8 environments,
    a [32] network) into `out`."""
    run_cli(skillmimic_bin, "train", "--preset", "tiny", "--task", "tracking", "--set", 'env.character="smpl"',
            "--set", f'env.motion=["{npz}"]', "--set", "run.iterations=2", "--set", "env.num_envs=8", "--set", "ppo.minibatch=64",
            "--set", "ppo.hidden=[32]", "--set", "run.eval_episodes=2", "--no-video", "--out", str(out))


def test_amass_file_trains_and_evaluates_on_the_smpl_humanoid(tmp_path, skillmimic_bin):
    npz = tmp_path / "stand.npz"
    _walk(npz)
    out = tmp_path / "run"
    train_tiny_tracking(skillmimic_bin, npz, out)
    assert (out / "latest.safetensors").exists()
    metrics = tmp_path / "m.json"
    r = run_cli(skillmimic_bin, "eval", "--checkpoint", str(out / "latest.safetensors"), "--episodes", "4", "--start-frame", "0",
                "--out", str(metrics))
    m = json.loads(metrics.read_text())
    print(r.stdout.strip().splitlines()[-1] if r.stdout.strip() else m)
    assert m["task"] == "tracking" and m["episodes"] == 4
    names = {"g_mpjpe_mm", "mpjpe_mm", "vel_err_mm", "acc_err_mm", "success"}
    assert names <= set(m["metrics"]) and names <= set(m["final_metrics"])
    assert all(math.isfinite(m["metrics"][k]) for k in names)
    # 60 frames at 30 Hz, one frame per 30 Hz policy step from frame 0
    assert 1 <= m["mean_episode_length"] <= 60
    assert 0.0 <= m["final_metrics"]["success"] <= 1.0
    # PHC's protocol: every motion of a folder once (two AMASS files of 60 and 45 frames)
    amass = tmp_path / "amass"
    amass.mkdir()
    _walk(amass / "a.npz")
    _walk(amass / "b.npz", frames=45)
    each = tmp_path / "each.json"
    r = run_cli(skillmimic_bin, "eval", "--checkpoint", str(out / "latest.safetensors"), "--motion", str(amass),
                "--each-motion", "--out", str(each))
    e = json.loads(each.read_text())
    print(r.stdout.strip().splitlines()[-2])
    assert [pathlib.Path(m["file"]).name for m in e["per_motion"]] == ["a.npz", "b.npz"]
    assert e["motions"] == 2 and e["successes"] == sum(m["success"] for m in e["per_motion"])
    assert e["success_rate"] == e["successes"] / 2 and e["success_distance"] == 0.5
    for m, frames in zip(e["per_motion"], (60, 45)):
        assert 1 <= m["steps"] <= frames - 1 and (m["steps"] == frames - 1 or not m["success"])
    for k, skip in (("g_mpjpe_mm", 0), ("mpjpe_mm", 0), ("vel_err_mm", 1), ("acc_err_mm", 2)):
        # the released bookkeeping: velocity errors from the 2nd step, acceleration from the 3rd
        assert all(m["values"][k] == m["steps"] - skip for m in e["per_motion"]), k
        pooled = sum(m["metrics"][k] * m["values"][k] for m in e["per_motion"]) / sum(m["values"][k] for m in e["per_motion"])
        assert math.isclose(e["metrics_all"][k], pooled, rel_tol=1e-9), k


def test_bad_amass_files_are_refused_naming_the_file(tmp_path, skillmimic_bin):
    cases = {
        "joints": dict(poses=np.zeros((10, 60)), trans=np.zeros((10, 3)), mocap_framerate=np.array(30.0)),
        "rate": dict(poses=np.zeros((10, 156)), trans=np.zeros((10, 3)), mocap_framerate=np.array(-30.0)),
        "nan": dict(poses=np.full((10, 156), np.nan), trans=np.zeros((10, 3)), mocap_framerate=np.array(30.0)),
    }
    needles = {"joints": "60 columns", "rate": "frame rate", "nan": "non-finite"}
    for what, arrays in cases.items():
        npz = tmp_path / f"bad_{what}.npz"
        np.savez(npz, **arrays)
        r = subprocess.run([str(skillmimic_bin), "train", "--preset", "tiny", "--task", "tracking", "--set", 'env.character="smpl"',
                            "--set", f'env.motion=["{npz}"]', "--set", "run.iterations=1", "--no-video", "--out", str(tmp_path / what)],
                           capture_output=True, text=True)
        assert r.returncode != 0 and f"bad_{what}.npz" in r.stderr and needles[what] in r.stderr, r.stderr
    # another character is told how to convert
    npz = tmp_path / "stand.npz"
    _walk(npz)
    r = subprocess.run([str(skillmimic_bin), "train", "--preset", "tiny", "--task", "tracking", "--set", 'env.character="skillmimic"',
                        "--set", f'env.motion=["{npz}"]', "--set", "run.iterations=1", "--no-video", "--out", str(tmp_path / "t")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "smpl" in r.stderr and "retarget --amass" in r.stderr, r.stderr
