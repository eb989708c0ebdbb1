"""ONNX export of a policy trained on the SMPL humanoid (the tracking task, ModSkill's character):
the deployment metadata describes the 69-dof SMPL humanoid, not the SkillMimic humanoid it was
built for first (an SMPL export used to list the SkillMimic humanoid's 52 joints, gains and its
2 × 1/120 s step for a 69-wide action at 30 Hz).

Checked against two references written independently of the Rust tables:
* PyPI mujoco's compile of ``mjcf/smpl.xml``: every joint's three position actuators
  ``<joint>_x/_y/_z`` with the metadata's kp, the hinges' damping = kd, the force range
  ± the joint's limit, the physics step;
* the facts of PHC / SMPLSim / ModSkill (``docs/modskill-tokenhsi-facts.md``, the gain table
  ``GAINS_PHC``, the released knee override): joint order = PHC's 23 non-root bodies, kp/kd per
  body group, π · a for every hinge except the knee flexion hinges (5 · a), 1/120 s × 4 = 30 Hz.

And onnxruntime gives our Rust inference on the tracking task's SMPL observations.
"""

from __future__ import annotations

import math

import numpy as np

from test_amass_smpl import FIXTURE, _walk, train_tiny_tracking
from test_hsi_onnx import assert_pd_metadata_matches_model, gentle_observations
from test_onnx_export import export, run

# (kp, kd) by body, SMPLSim's GAINS_PHC as ModSkill uses it (N·m/rad, N·m·s/rad)
GAINS = {
    **{f"{s}_{j}": (800.0, 80.0) for s in "LR" for j in ("Hip", "Knee", "Ankle")},
    **{f"{s}_Toe": (500.0, 50.0) for s in "LR"},
    **{b: (1000.0, 100.0) for b in ("Torso", "Spine", "Chest")},
    **{b: (500.0, 50.0) for b in ("Neck", "Head")},
    **{f"{s}_{j}": (500.0, 50.0) for s in "LR" for j in ("Thorax", "Shoulder", "Elbow")},
    **{f"{s}_{j}": (300.0, 30.0) for s in "LR" for j in ("Wrist", "Hand")},
}


def test_smpl_policy_exports_with_the_smpl_humanoids_metadata(tmp_path, repo_root, skillmimic_bin):
    import mujoco
    import skillmimic_rs

    npz = tmp_path / "walk.npz"
    _walk(npz)
    out = tmp_path / "track"
    train_tiny_tracking(skillmimic_bin, npz, out)
    sess, side = export(skillmimic_bin, out / "latest.safetensors", tmp_path / "track.onnx")
    bodies = [b["name"] for b in FIXTURE["bodies"]]
    assert side["task"] == "tracking" and side["act_dim"] == 69 and side["obs_layout_version"] == "smpl-obs-1"
    assert side["joint_order"] == bodies[1:] and len(bodies) == 24
    assert [(g["joint"], g["kp"], g["kd"], g["force_limit_nm"]) for g in side["pd_gains"]] == [
        (b, *GAINS[b], 500.0) for b in bodies[1:]
    ]
    scales = [5.0 if (b.endswith("Knee") and axis == "y") else math.pi for b in bodies[1:] for axis in "xyz"]
    np.testing.assert_allclose(np.array(side["action_offset_scale"]), np.array([[0.0, s] for s in scales]), rtol=0, atol=1e-12)
    assert (side["sim_dt"], side["substeps"]) == (1 / 120, 4) and abs(side["control_dt"] - 1 / 30) < 1e-15
    assert side["skill_labels"] == {} and side["welded_joints"] == [] and side["hands"] == "" and side["force_limit_nm"] == 500.0
    assert "L_Hip 0-2" in side["action_to_pd_target"] and "R_Hand 66-68" in side["action_to_pd_target"]

    # the simulated model (PyPI mujoco's compile of the shipped MJCF)
    model = mujoco.MjModel.from_xml_path(str(repo_root / "mjcf" / "smpl.xml"))
    assert model.nu == 69
    assert_pd_metadata_matches_model(side, model)

    # onnxruntime against our Rust inference on the task's own observations
    env = skillmimic_rs.VecEnv(num_envs=8, task="tracking", character="smpl", motion=[str(npz)], threads=1)
    x = gentle_observations(env)
    env.close()
    assert x.shape[1] == side["obs_dim"]
    got = run(sess, x)
    mu, _ = skillmimic_rs._core.Policy.load(str(out / "latest.safetensors")).infer(x)
    print(f"onnxruntime on {len(x)} SMPL tracking observations: max |d mu| vs Rust {np.abs(got['mu'] - mu).max():.2e}")
    np.testing.assert_allclose(got["mu"], mu, rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(got["actions"], np.clip(got["mu"], -1, 1))
