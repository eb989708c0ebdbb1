"""Issue 23, SMPL-family input: an AMASS-layout ``.npz`` written by numpy in SMPL's zero pose
(stood up in AMASS's Z-up world) goes through ``skillmimic_rs.retarget_amass`` on the default rest
skeleton, SMPL's neutral mean shape. PyPI mujoco's forward kinematics of the written clip must
point every limb bone along SMPL's neutral rest bone, whose numbers this test carries itself (the
joint offsets of SMPL-based humanoids' MJCF, Z-up x-forward y-left), and put the pelvis at
(trans + J_pelvis) × scale.
"""

from __future__ import annotations

import numpy as np

import reference_env as ref
from conftest import scene_model

# SMPL neutral (beta = 0) joint offsets from the parent, metres, in the Z-up, x-forward, y-left
# frame of SMPL-based humanoid MJCF files
SMPL_MJCF = {
    "L_Hip": (-0.0068, 0.0695, -0.0914), "L_Knee": (-0.0045, 0.0343, -0.3752), "L_Ankle": (-0.0437, -0.0136, -0.3980),
    "R_Hip": (-0.0043, -0.0677, -0.0905), "R_Knee": (-0.0089, -0.0383, -0.3826), "R_Ankle": (-0.0423, 0.0158, -0.3984),
    "L_Elbow": (-0.0275, 0.2596, -0.0128), "L_Wrist": (-0.0012, 0.2492, 0.0090),
    "R_Elbow": (-0.0214, -0.2537, -0.0133), "R_Wrist": (-0.0056, -0.2553, 0.0078),
}
J_PELVIS = np.array([-0.0018, -0.2233, 0.0282])  # SMPL's model frame (Y-up), added to trans as is
BONES = [("L_Hip", "L_Knee"), ("L_Knee", "L_Ankle"), ("R_Hip", "R_Knee"), ("R_Knee", "R_Ankle"),
         ("L_Shoulder", "L_Elbow"), ("L_Elbow", "L_Wrist"), ("R_Shoulder", "R_Elbow"), ("R_Elbow", "R_Wrist")]


def test_amass_zero_pose_follows_smpl_neutral_skeleton(skillmimic_bin, tmp_path):
    import skillmimic_rs

    T = 6
    poses = np.zeros((T, 156))
    poses[:, 0] = np.pi / 2  # root_orient: SMPL's Y-up model stood up in the Z-up world
    trans = np.tile([0.3, -0.1, 0.9], (T, 1))
    npz = tmp_path / "zero.npz"
    np.savez(npz, poses=poses, trans=trans, mocap_framerate=np.array(30.0))
    rep = skillmimic_rs.retarget_amass(npz, out=tmp_path, skill=10, no_ground=True, name="zero")
    assert rep["frames"] == 2 * (T - 1) + 1 and rep["clip"].exists()
    scale = rep["scale"]
    clip = ref.load_clip(rep["clip"])
    mujoco, model = scene_model()
    data = mujoco.MjData(model)
    data.qpos[:] = ref.reset_qpos_qvel(model, clip, ref.derive_reference(clip), 0)[0]
    mujoco.mj_kinematics(model, data)
    pos = {model.body(b).name: np.array(data.xpos[b]) for b in range(1, 54)}
    # SMPL's rest bone in the world: the MJCF frame (x fwd, y left, z up) -> SMPL's model frame
    # (y, z, x) -> Rx(+90 deg) -> world (x, -z, y) of the model frame
    to_world = lambda v: np.array([v[1], -v[0], v[2]])  # noqa: E731
    worst = 0.0
    for a, b in BONES:
        want = to_world(SMPL_MJCF[b])
        got = pos[b] - pos[a]
        worst = max(worst, float(np.arccos(np.clip(want @ got / np.linalg.norm(want) / np.linalg.norm(got), -1, 1))))
    pelvis_want = scale * (trans[0] + J_PELVIS)
    print(f"zero pose: limb bones within {worst:.2e} rad of SMPL's neutral rest bones; pelvis {pos['Pelvis']} vs {pelvis_want}; scale {scale:.4f}")
    assert worst < 1e-4  # float32 clip storage
    assert np.abs(pos["Pelvis"] - pelvis_want).max() < 1e-5
    leg_smpl = sum(np.linalg.norm(SMPL_MJCF[k]) for k in ("L_Knee", "L_Ankle", "R_Knee", "R_Ankle"))
    leg_humanoid = sum(np.linalg.norm(model.body(k).pos) for k in ("L_Knee", "L_Ankle", "R_Knee", "R_Ankle"))
    assert abs(scale - leg_humanoid / leg_smpl) < 1e-6
