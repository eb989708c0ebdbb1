"""Self-checks of tests/reference_env.py (the pure-numpy reference environment).

These tests check the reference against hand-computed values and physical
invariances; they do not involve the Rust environment.
"""

import math
import os
import sys
import zipfile
from pathlib import Path

import mujoco
import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_env as R  # noqa: E402
from conftest import find_shared  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
FULL_XML = REPO / "mjcf" / "skillmimic_full.xml"
BOXHAND_XML = REPO / "mjcf" / "skillmimic_boxhand.xml"
MOTIONS = REPO / "motions"
SHARED_CLIPS = (find_shared() or Path("<shared folder not found>")) / "data" / "ballplay_m"
PASS_CLIP = SHARED_CLIPS / "pass" / "004_016pickle_pass_001.pt"


def _model(path=FULL_XML):
    m = mujoco.MjModel.from_xml_path(str(path))
    return m, mujoco.MjData(m)


def _require_shared(path):
    if not path.exists():
        if os.environ.get("CI"):
            pytest.fail(f"{path} is missing on CI")
        pytest.skip(f"{path} not available")


def _random_pose(m, d, seed=0):
    """A random but valid humanoid + ball configuration with random velocities."""
    rng = np.random.default_rng(seed)
    d.qpos[:] = m.qpos0
    root = R.free_joint_of_body(m, 1)
    qa = m.jnt_qposadr[root]
    d.qpos[qa:qa + 3] = [0.3, -0.2, 1.6]
    d.qpos[qa + 3:qa + 7] = R.quat_normalize(rng.normal(size=4))
    for j in range(R.NUM_JOINTS):
        jid = R.skeleton_joint(m, j)
        if jid >= 0:
            a = m.jnt_qposadr[jid]
            d.qpos[a:a + 4] = R.rotvec_to_quat(rng.uniform(-0.6, 0.6, size=3))
    ball = R.free_joint_of_body(m, R.ball_body_id(m))
    qa = m.jnt_qposadr[ball]
    d.qpos[qa:qa + 3] = [1.5, 0.7, 2.5]
    d.qpos[qa + 3:qa + 7] = R.quat_normalize(rng.normal(size=4))
    d.qvel[:] = rng.normal(size=m.nv)
    mujoco.mj_forward(m, d)


def _transform_scene(m, d, q_world, shift):
    """Apply a world rotation q_world then an xy shift to both free bodies (in place)."""
    rot = R.quat_to_mat(q_world)
    for body in (1, R.ball_body_id(m)):
        jid = R.free_joint_of_body(m, body)
        qa, va = m.jnt_qposadr[jid], m.jnt_dofadr[jid]
        d.qpos[qa:qa + 3] = rot @ d.qpos[qa:qa + 3] + shift
        d.qpos[qa + 3:qa + 7] = R.quat_mul(q_world, d.qpos[qa + 3:qa + 7])
        d.qvel[va:va + 3] = rot @ d.qvel[va:va + 3]   # world linear velocity
        # angular velocity of a free joint is body-frame: unchanged
    mujoco.mj_forward(m, d)


# ---------------------------------------------------------------------------
# quaternion helpers
# ---------------------------------------------------------------------------

def test_rotvec_roundtrip_and_wrap():
    rng = np.random.default_rng(1)
    v = rng.normal(size=(100, 3))
    v *= (rng.uniform(0, 3.1, size=100) / np.linalg.norm(v, axis=1))[:, None]
    np.testing.assert_allclose(R.quat_to_rotvec(R.rotvec_to_quat(v)), v, atol=1e-12)
    # negated quaternion is the same rotation: same rotvec
    np.testing.assert_allclose(R.quat_to_rotvec(-R.rotvec_to_quat(v)), v, atol=1e-12)
    # angle > pi wraps to the short way round
    q = R.rotvec_to_quat([0.0, 0.0, 1.5 * math.pi])
    np.testing.assert_allclose(R.quat_to_rotvec(q), [0, 0, -0.5 * math.pi], atol=1e-12)
    assert np.all(R.quat_to_rotvec([1.0, 0, 0, 0]) == 0.0)


def test_quat_mul_matches_matrix_product():
    rng = np.random.default_rng(2)
    a, b = R.quat_normalize(rng.normal(size=(2, 4)))
    np.testing.assert_allclose(R.quat_to_mat(R.quat_mul(a, b)),
                               R.quat_to_mat(a) @ R.quat_to_mat(b), atol=1e-12)
    mj = np.zeros(4)
    mujoco.mju_mulQuat(mj, a, b)
    np.testing.assert_allclose(R.quat_mul(a, b), mj, atol=1e-14)


# ---------------------------------------------------------------------------
# observation
# ---------------------------------------------------------------------------

def test_rest_pose_observation_hand_values():
    m, d = _model()
    mujoco.mj_forward(m, d)   # qpos0: root (0,0,0.95), +90 deg about x; ball (0,0.6,0.12)
    obs = R.observation(R.extract_state(m, d), skill=5)
    assert obs.dtype == np.float32 and obs.shape == (902,)
    assert obs[0] == pytest.approx(0.95, abs=1e-7)
    # L_Hip (skeleton 1): Y-up offset (0.109716, -0.0365719, 0) -> (x, -z, y)
    np.testing.assert_allclose(obs[1:4], [0.109716, 0.0, -0.0365719], atol=1e-7)
    # R_Hip (skeleton 5)
    np.testing.assert_allclose(obs[13:16], [-0.109716, 0.0, -0.0365719], atol=1e-7)
    # Torso (skeleton 9): (0, 0.0877726, -0.0279775) -> (0, 0.0279775, 0.0877726)
    np.testing.assert_allclose(obs[25:28], [0.0, 0.0279775, 0.0877726], atol=1e-7)
    # root tan-norm: R x = (1,0,0), R z = (0,-1,0)
    np.testing.assert_allclose(obs[157:163], [1, 0, 0, 0, -1, 0], atol=1e-7)
    # all bodies share the root orientation at the zero pose
    np.testing.assert_allclose(obs[157:475].reshape(53, 6),
                               np.tile([1, 0, 0, 0, -1, 0], (53, 1)), atol=1e-7)
    np.testing.assert_allclose(obs[475:793], 0.0)          # qvel = 0
    np.testing.assert_allclose(obs[823:826], [0.0, 0.6, 0.12], atol=1e-7)
    np.testing.assert_allclose(obs[826:832], [1, 0, 0, 0, 0, 1], atol=1e-7)
    np.testing.assert_allclose(obs[832:838], 0.0)
    onehot = obs[838:]
    assert onehot[5] == 1.0 and onehot.sum() == 1.0


def test_observation_heading_frame_with_yaw():
    """Root yawed by +30 deg about world z: local positions are the unyawed ones."""
    m, d = _model()
    mujoco.mj_forward(m, d)
    base = R.observation(R.extract_state(m, d), 0)
    yaw = R.rotvec_to_quat([0, 0, math.radians(30)])
    _transform_scene(m, d, yaw, np.zeros(3))
    state = R.extract_state(m, d)
    assert R.heading_angle(state["body_quat"][0]) == pytest.approx(math.radians(30))
    obs = R.observation(state, 0)
    np.testing.assert_allclose(obs[1:793], base[1:793], atol=1e-6)
    np.testing.assert_allclose(obs[823:838], base[823:838], atol=1e-6)


def test_observation_yaw_translation_invariance():
    m, d = _model()
    _random_pose(m, d, seed=3)
    state0 = R.extract_state(m, d)
    obs0 = R.observation(state0, 13)
    assert np.abs(obs0[475:793]).max() > 0.1   # velocities really are non-zero

    yaw = R.rotvec_to_quat([0, 0, 2.3])
    _transform_scene(m, d, yaw, np.array([1.3, -2.1, 0.0]))
    obs1 = R.observation(R.extract_state(m, d), 13)
    mask = np.ones(902, bool)
    mask[793:823] = False
    np.testing.assert_allclose(obs1[mask], obs0[mask], atol=2e-5)

    # a pitch rotation is not an invariance: the check above can fail
    _random_pose(m, d, seed=3)
    _transform_scene(m, d, R.rotvec_to_quat([0.4, 0, 0]), np.zeros(3))
    obs2 = R.observation(R.extract_state(m, d), 13)
    assert np.abs(obs2[mask] - obs0[mask]).max() > 1e-2


def test_body_velocities_world_frame():
    m, d = _model()
    _random_pose(m, d, seed=4)
    state = R.extract_state(m, d)
    root_q = d.qpos[3:7]
    # pelvis geom is centred on the body origin, so its COM velocity is qvel[0:3]
    np.testing.assert_allclose(state["body_linvel"][0], d.qvel[0:3], atol=1e-10)
    np.testing.assert_allclose(state["body_angvel"][0], R.quat_rotate(root_q, d.qvel[3:6]),
                               atol=1e-10)
    bq = d.qpos[m.jnt_qposadr[R.free_joint_of_body(m, 54)] + 3:][:4]
    bv = d.qvel[m.jnt_dofadr[R.free_joint_of_body(m, 54)]:][:6]
    np.testing.assert_allclose(state["body_linvel"][R.BALL], bv[:3], atol=1e-10)
    np.testing.assert_allclose(state["body_angvel"][R.BALL], R.quat_rotate(bq, bv[3:]),
                               atol=1e-10)
    # COM velocity of a limb = finite difference of its COM position
    h = 1e-7
    d2 = mujoco.MjData(m)
    d2.qpos[:] = d.qpos
    mujoco.mj_integratePos(m, d2.qpos, d.qvel, h)
    mujoco.mj_kinematics(m, d2)
    fd = (d2.xipos[3] - d.xipos[3]) / h
    np.testing.assert_allclose(state["body_linvel"][2], fd, atol=1e-5)


def test_dof_extraction_and_boxhand():
    m, d = _model()
    _random_pose(m, d, seed=5)
    state = R.extract_state(m, d)
    jid = R.skeleton_joint(m, 0)   # L_Hip
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jid) == "L_Hip"
    q = d.qpos[m.jnt_qposadr[jid]:m.jnt_qposadr[jid] + 4]
    np.testing.assert_allclose(state["dof_pos"][:3], R.quat_to_rotvec(q), atol=1e-12)
    np.testing.assert_allclose(state["dof_vel"][:3], d.qvel[m.jnt_dofadr[jid]:][:3])

    mb, db = _model(BOXHAND_XML)
    _random_pose(mb, db, seed=5)
    sb = R.extract_state(mb, db)
    welded = [j for j in range(R.NUM_JOINTS) if R.skeleton_joint(mb, j) < 0]
    assert len(welded) == 30
    for j in welded:
        assert np.all(sb["dof_pos"][3 * j:3 * j + 3] == 0.0)
        assert np.all(sb["dof_vel"][3 * j:3 * j + 3] == 0.0)


# ---------------------------------------------------------------------------
# contacts
# ---------------------------------------------------------------------------

def test_ball_on_floor_force_balances_weight():
    """The ball chatters on its bouncy floor contact; over whole periods the mean
    net contact force equals its weight, and it is purely vertical."""
    m, d = _model()
    ball = R.free_joint_of_body(m, R.ball_body_id(m))
    d.qpos[m.jnt_qposadr[ball]:][:3] = [4.0, 4.0, 0.15]
    for _ in range(240):
        mujoco.mj_step(m, d)
    forces, floor_flags = [], []
    for _ in range(60):
        mujoco.mj_step(m, d)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        state = R.extract_state(m, d)
        assert state["pairs"]["hand_ball"] == 0 and state["pairs"]["body_ball"] == 0
        assert R.contact_graph(state, "force_threshold")[0] == 0.0   # vertical only
        forces.append(state["contact_force"][R.BALL])
        floor_flags.append(state["pairs"]["ball_floor"])
    forces = np.array(forces)
    assert max(floor_flags) == 1
    assert np.abs(forces[:, :2]).max() < 0.1
    weight = m.body_mass[R.ball_body_id(m)] * 9.81
    assert forces[:, 2].mean() == pytest.approx(weight, rel=0.01)
    assert forces[:, 2].min() >= 0.0      # the floor only pushes the ball up


def test_hand_ball_contact_flags_and_forces():
    m, d = _model()
    mujoco.mj_forward(m, d)
    tip = d.xpos[1 + 24].copy()   # L_Middle3
    ball = R.free_joint_of_body(m, R.ball_body_id(m))
    d.qpos[m.jnt_qposadr[ball]:][:3] = tip + [-0.02, 0.0, -0.12]
    mujoco.mj_forward(m, d)
    state = R.extract_state(m, d)
    assert state["pairs"]["hand_ball"] == 1
    assert state["pairs"]["body_ball"] == 0 and state["pairs"]["ball_floor"] == 0
    g = R.contact_graph(state, "exact")
    assert g[0] == 1.0 and g[1] == 0.0
    f_ball = state["contact_force"][R.BALL]
    assert f_ball[2] < -1e-3            # pushed down, away from the fingers above it
    hand = sorted(R.HAND_BODIES)
    # third law: the forces on the hand bodies from the ball balance the ball's force
    # (the feet touch the floor, hand-hand contacts cancel internally)
    np.testing.assert_allclose(state["contact_force"][hand].sum(0), -f_ball, atol=1e-8)
    fg = R.contact_graph(state, "force_threshold")
    assert fg.shape == (2,)


def test_pair_kinds_table():
    H, B, F, T, FL = R.PART_HAND, R.PART_BALL, R.PART_FOOT, R.PART_TRUNK, R.PART_FLOOR
    assert R.pair_kinds(B, H) == ["hand_ball"]
    assert R.pair_kinds(F, B) == ["body_ball"]
    assert R.pair_kinds(T, B) == ["body_ball"]
    assert R.pair_kinds(H, F) == ["hand_body"]
    assert R.pair_kinds(H, H) == []
    assert R.pair_kinds(T, T) == []
    assert R.pair_kinds(FL, B) == ["ball_floor"]
    assert R.pair_kinds(T, FL) == ["body_floor"]
    assert R.pair_kinds(F, FL) == ["foot_floor"]
    assert R.pair_kinds(FL, H) == ["hand_floor"]


def test_force_threshold_graph():
    state = {"contact_force": np.zeros((54, 3)), "pairs": {}}
    assert list(R.contact_graph(state, "force_threshold")) == [0, 0]
    state["contact_force"][R.BALL] = [0.0, 0.0, 50.0]
    assert list(R.contact_graph(state, "force_threshold")) == [0, 0]
    state["contact_force"][R.BALL] = [0.0, -0.2, 0.0]
    state["contact_force"][3] = [0.0, 0.0, 500.0]     # foot: not in the body node
    assert list(R.contact_graph(state, "force_threshold")) == [1, 0]
    state["contact_force"][36] = [0.0, 0.1, 0.0]      # R_Elbow, exactly the threshold
    assert list(R.contact_graph(state, "force_threshold")) == [1, 1]
    assert list(R.reference_graph(1.0, "force_threshold")) == [1, 0]
    assert list(R.reference_graph(0.0, "exact")) == [0, 0, 0, 0]


# ---------------------------------------------------------------------------
# clips and derived reference
# ---------------------------------------------------------------------------

def _synthetic_clip():
    base = R.rotvec_to_quat([math.pi / 2, 0, 0])
    a = np.array([0.0, 0.01, 0.03])          # root yaw about local z
    b = np.array([0.0, 0.02, 0.02])          # ball spin about local y
    root_rot = np.stack([R.quat_mul(base, R.rotvec_to_quat([0, 0, x])) for x in a])
    ball_rot = np.stack([R.quat_mul(base, R.rotvec_to_quat([0, x, 0])) for x in b])
    body_pos = np.zeros((3, 53, 3))
    body_pos[:, 14] = [[0, 0, 1.5], [0, 0.01, 1.5], [0, 0.03, 1.52]]   # Head = key 0
    dof = np.zeros((3, 52, 3))
    dof[:, 0, 0] = [0.0, 0.1, 0.15]
    return {
        "root_pos": np.array([[0, 0, 1], [0.1, 0, 1], [0.1, 0.2, 1]], np.float32),
        "root_rot": root_rot.astype(np.float32),
        "dof_rot": dof.astype(np.float32),
        "body_pos": body_pos.astype(np.float32),
        "ball_pos": np.array([[1, 0, 1], [1, 0, 0.9], [1, 0, 0.8]], np.float32),
        "ball_rot": ball_rot.astype(np.float32),
        "contact": np.array([1, 0, 1], np.float32),
        "fps": 60.0, "skill": 4, "num_frames": 3,
    }


def test_derive_reference_synthetic():
    clip = _synthetic_clip()
    ref = R.derive_reference(clip)
    for v in ref.values():
        assert v.dtype == np.float32 and v.shape[0] == 3
    np.testing.assert_allclose(ref["root_linvel"], [[0, 0, 0], [6, 0, 0], [0, 12, 0]], atol=1e-5)
    # body-frame angular velocity about local z (world would be -y for this root)
    np.testing.assert_allclose(ref["root_angvel_local"], [[0, 0, 0], [0, 0, 0.6], [0, 0, 1.2]],
                               atol=1e-4)
    np.testing.assert_allclose(ref["root_rotvec"][0], [math.pi / 2, 0, 0], atol=1e-6)
    assert ref["dof_vel"].shape == (3, 156)
    np.testing.assert_allclose(ref["dof_vel"][:, 0], [0, 6, 3], atol=1e-5)
    assert np.all(ref["dof_vel"][:, 1:] == 0)
    assert ref["key_pos"].shape == (3, 17, 3) and ref["key_vel"].shape == (3, 17, 3)
    np.testing.assert_allclose(ref["key_pos"][:, 0], clip["body_pos"][:, 14])
    np.testing.assert_allclose(ref["key_vel"][:, 0], [[0, 0, 0], [0, 0.6, 0], [0, 1.2, 1.2]],
                               atol=1e-5)
    np.testing.assert_allclose(ref["ball_linvel"], [[0, 0, 0], [0, 0, -6], [0, 0, -6]], atol=1e-5)
    np.testing.assert_allclose(ref["ball_angvel_local"], [[0, 0, 0], [0, 1.2, 0], [0, 0, 0]],
                               atol=1e-4)
    # reference HOI: ball angular velocity rotated to world (local y -> world z)
    hoi = R.hoi_ref(clip, ref, 1)
    np.testing.assert_allclose(hoi["ball_angvel"], [0, 0, 1.2], atol=1e-4)
    assert hoi["dof_pos"].shape == (156,) and hoi["dof_pos"].dtype == np.float64
    assert hoi["contact"] == 0.0


def _write_fake_pt(path, rows):
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("archive/data.pkl", b"not used")
        zf.writestr("archive/data/0", np.asarray(rows, "<f4").tobytes())
        zf.writestr("archive/version", b"3\n")


def test_load_pt_synthetic_sign_continuity(tmp_path):
    rows = np.zeros((3, 337), np.float32)
    rows[:, 0:3] = [0.0, 0.0, 1.0]
    rows[0, 3:6] = [0, 0, 3.1]
    rows[1, 3:6] = [0, 0, -3.1]      # same neighbourhood, opposite hemisphere
    rows[2, 3:6] = [0, 0, -3.0]
    rows[:, 327:330] = [0.2, 0.0, 0.0]   # stored negated
    rows[:, 336] = [0.9, 0.2, 1.0]
    path = tmp_path / "042_fake_clip.pt"
    _write_fake_pt(path, rows)
    clip = R.load_clip(path)
    assert clip["skill"] == 42 and clip["fps"] == 60.0 and clip["num_frames"] == 3
    q = clip["root_rot"].astype(np.float64)
    assert np.all(np.sum(q[1:] * q[:-1], axis=1) >= 0)
    np.testing.assert_allclose(q[1], [-math.cos(1.55), 0, 0, math.sin(1.55)], atol=1e-7)
    np.testing.assert_allclose(clip["ball_rot"][0], R.rotvec_to_quat([-0.2, 0, 0]), atol=1e-7)
    assert list(clip["contact"]) == [1.0, 0.0, 1.0]
    ref = R.derive_reference(clip)
    np.testing.assert_allclose(ref["root_angvel_local"][1], [0, 0, (2 * math.pi - 6.2) * 60],
                               rtol=1e-4)
    np.testing.assert_allclose(ref["root_rotvec"][1], [0, 0, -3.1], atol=1e-6)


def test_load_real_pt_clip():
    _require_shared(PASS_CLIP)
    clip = R.load_clip(PASS_CLIP)
    T = clip["num_frames"]
    assert T == 51 and clip["skill"] == 4 and clip["fps"] == 60.0
    assert clip["dof_rot"].shape == (T, 52, 3) and clip["body_pos"].shape == (T, 53, 3)
    for k in ("root_pos", "root_rot", "dof_rot", "body_pos", "ball_pos", "ball_rot", "contact"):
        assert clip[k].dtype == np.float32, k
    q = clip["root_rot"].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
    assert np.all(np.sum(q[1:] * q[:-1], axis=1) >= 0)
    np.testing.assert_allclose(clip["ball_rot"], np.tile([1, 0, 0, 0], (T, 1)))
    assert set(np.unique(clip["contact"])) <= {0.0, 1.0}
    assert 0.95 < clip["root_pos"][:, 2].min() and clip["root_pos"][:, 2].max() < 0.96
    # root rotvec recovers the stored exp map (norms are < pi here)
    with zipfile.ZipFile(PASS_CLIP) as zf:
        raw = np.frombuffer(zf.read("archive/data/0"), "<f4").reshape(-1, 337)
    ref = R.derive_reference(clip)
    np.testing.assert_allclose(ref["root_rotvec"], raw[:, 3:6], atol=2e-6)
    np.testing.assert_allclose(ref["key_pos"], clip["body_pos"][:, R.KEY_BODIES])


def test_load_motions_clip_matches_pt_layout():
    path = MOTIONS / "050_synth_stand_dribble_right.safetensors"
    clip = R.load_clip(path)
    assert clip["skill"] == 50 and clip["fps"] == 60.0
    T = clip["num_frames"]
    assert T == 180
    shapes = {"root_pos": (3,), "root_rot": (4,), "dof_rot": (52, 3), "body_pos": (53, 3),
              "ball_pos": (3,), "ball_rot": (4,), "contact": ()}
    for k, s in shapes.items():
        assert clip[k].shape == (T,) + s and clip[k].dtype == np.float32, k
    if PASS_CLIP.exists():
        pt = R.load_clip(PASS_CLIP)
        assert set(pt) == set(clip)
        for k in shapes:
            assert pt[k].shape[1:] == clip[k].shape[1:] and pt[k].dtype == clip[k].dtype


# ---------------------------------------------------------------------------
# reset, HOI, reward, metrics
# ---------------------------------------------------------------------------

def _clip_for_reset():
    if PASS_CLIP.exists():
        return R.load_clip(PASS_CLIP)
    if os.environ.get("CI"):
        pytest.fail(f"{PASS_CLIP} is missing on CI")
    return R.load_clip(MOTIONS / "050_synth_stand_dribble_right.safetensors")


@pytest.mark.parametrize("xml", [FULL_XML, BOXHAND_XML])
def test_reset_state_matches_reference(xml):
    clip = _clip_for_reset()
    ref = R.derive_reference(clip)
    m, d = _model(xml)
    t = 10
    d.qpos[:], d.qvel[:] = R.reset_qpos_qvel(m, clip, ref, t)
    mujoco.mj_forward(m, d)
    state = R.extract_state(m, d)
    sim, target = R.hoi_sim(state), R.hoi_ref(clip, ref, t)
    np.testing.assert_allclose(sim["root_pos"], target["root_pos"], atol=1e-12)
    np.testing.assert_allclose(sim["root_rotvec"], target["root_rotvec"], atol=2e-6)
    np.testing.assert_allclose(sim["ball_pos"], target["ball_pos"], atol=1e-12)
    np.testing.assert_allclose(sim["ball_linvel"], target["ball_linvel"], atol=1e-12)
    np.testing.assert_allclose(state["body_linvel"][0], ref["root_linvel"][t], atol=1e-6)
    jointed = np.array([R.skeleton_joint(m, j) >= 0 for j in range(52)]).repeat(3)
    np.testing.assert_allclose(sim["dof_pos"][jointed], target["dof_pos"][jointed], atol=2e-6)
    np.testing.assert_allclose(sim["dof_vel"][jointed], target["dof_vel"][jointed], atol=1e-12)
    cg = R.contact_graph(state)
    terms = R.reward_terms(sim, sim["dof_vel"], target, cg, R.reference_graph(target["contact"]),
                           clip["skill"])
    if xml == FULL_XML:
        assert terms[R.REWARD_NAMES.index("r")] > 1 - 1e-8
    assert terms[R.REWARD_NAMES.index("op")] == pytest.approx(1.0, abs=1e-12)
    assert terms[R.REWARD_NAMES.index("reg")] == 1.0
    assert 0.0 < terms[-1] <= 1.0


@pytest.mark.parametrize("variant", list(R.VARIANTS))
@pytest.mark.parametrize("mode", list(R.GRAPH_MODES))
def test_reference_against_itself_scores_one(variant, mode):
    clip = _synthetic_clip()
    ref = R.derive_reference(clip)
    hoi = R.hoi_ref(clip, ref, 2)
    g = R.reference_graph(hoi["contact"], mode)
    terms = R.reward_terms(hoi, hoi["dof_vel"], hoi, g, g, clip["skill"], variant, mode)
    assert terms.shape == (12,)
    np.testing.assert_allclose(terms, 1.0, atol=1e-12)
    np.testing.assert_allclose(R.frame_metrics(hoi, hoi, g, g), [0, 0, 1, 0])


def test_reward_hand_computed():
    clip = _synthetic_clip()
    ref = R.derive_reference(clip)
    target = R.hoi_ref(clip, ref, 2)
    sim = {k: (np.array(v, dtype=np.float64) if k != "contact" else v) for k, v in target.items()}
    sim["root_pos"] = sim["root_pos"] + [0.1, 0.0, 0.0]     # moves root and root-ball vector
    sim["ball_pos"] = sim["ball_pos"] + [0.0, 0.0, 0.3]     # moves ball and all 18 ig vectors
    prev = sim["dof_vel"].copy()
    prev[5] += 2.0                                           # dof 5 has zero reference velocity
    cg_sim = np.array([0.0, 1.0, 0.0, 0.0])
    cg_ref = R.reference_graph(1.0)
    terms = dict(zip(R.REWARD_NAMES,
                     R.reward_terms(sim, prev, target, cg_sim, cg_ref, skill=4)))
    e_p = 0.01 / 54
    e_op = 0.09 / 3
    # ig: root vector changes by (0.1,0,-0.3), the 17 key vectors by (0,0,-0.3)
    e_ig = (0.01 + 0.09 + 17 * 0.09) / 54
    e_reg = 4.0 / 156
    assert terms["p"] == pytest.approx(math.exp(-20 * e_p), rel=1e-12)
    assert terms["r"] == 1.0 and terms["pv"] == 1.0 and terms["rv"] == 1.0
    assert terms["reg"] == pytest.approx(math.exp(-0.1 * e_reg), rel=1e-12)
    assert terms["op"] == pytest.approx(math.exp(-e_op), rel=1e-12)
    assert terms["ig"] == pytest.approx(math.exp(-20 * e_ig), rel=1e-12)
    assert terms["cg"] == pytest.approx(math.exp(-10.0), rel=1e-12)
    body, ball = terms["p"] * terms["reg"], terms["op"]
    assert terms["total"] == pytest.approx(body * ball * terms["ig"] * terms["cg"], rel=1e-12)

    ncg = R.reward_terms(sim, prev, target, cg_sim, cg_ref, 4, variant="no_contact_graph")
    assert ncg[-1] == pytest.approx(body * ball * terms["ig"], rel=1e-12)
    add = R.reward_terms(sim, prev, target, cg_sim, cg_ref, 4, variant="additive")
    assert add[-1] == pytest.approx((body + ball + terms["ig"] + terms["cg"]) / 4, rel=1e-12)
    dm = dict(zip(R.REWARD_NAMES,
                  R.reward_terms(sim, prev, target, cg_sim, cg_ref, 4, variant="deepmimic")))
    assert dm["p"] == pytest.approx(math.exp(-40 * e_p)) and dm["op"] == pytest.approx(
        math.exp(-40 * e_op))
    assert dm["reg"] == 1.0 and dm["ig"] == 1.0 and dm["cg"] == 1.0
    assert dm["total"] == pytest.approx((dm["p"] + 1.0 + 1.0 + dm["op"]) / 4)

    # ball-free skills ignore every ball / interaction / contact term
    free = dict(zip(R.REWARD_NAMES, R.reward_terms(sim, prev, target, cg_sim, cg_ref, 10)))
    for k in ("op", "or", "opv", "orv", "ig", "cg"):
        assert free[k] == 1.0
    assert free["total"] == pytest.approx(body, rel=1e-12)
    dm_free = R.reward_terms(sim, prev, target, cg_sim, cg_ref, 0, variant="deepmimic")
    assert dm_free[R.REWARD_NAMES.index("op")] == 1.0

    # weight override and force-threshold weights
    heavy = R.reward_terms(sim, prev, target, cg_sim, cg_ref, 4, weights={"p": 40.0})
    assert heavy[0] == pytest.approx(math.exp(-40 * e_p), rel=1e-12)
    ft = R.reward_terms(sim, prev, target, np.array([0.0, 1.0]), R.reference_graph(1.0, "force_threshold"),
                        4, mode="force_threshold", weights={"cg1_body": 2.0})
    assert ft[R.REWARD_NAMES.index("cg")] == pytest.approx(math.exp(-5.0 - 2.0), rel=1e-12)


def test_ball_rotation_error_term():
    clip = _synthetic_clip()
    ref = R.derive_reference(clip)
    target = R.hoi_ref(clip, ref, 0)
    sim = dict(target)
    sim["ball_quat"] = -R.quat_mul(target["ball_quat"], R.rotvec_to_quat([0, 0, 0.3]))
    terms = R.reward_terms(sim, sim["dof_vel"], target, np.zeros(4), np.zeros(4), 4,
                           weights={"or": 2.0})
    assert terms[R.REWARD_NAMES.index("or")] == pytest.approx(math.exp(-2.0 * 0.09), rel=1e-9)


def test_frame_metrics_hand_computed():
    clip = _synthetic_clip()
    ref = R.derive_reference(clip)
    target = R.hoi_ref(clip, ref, 1)
    sim = dict(target)
    sim["key_pos"] = target["key_pos"] + [0.0, 0.3, 0.4]    # 17 points moved by 0.5 m
    sim["ball_pos"] = target["ball_pos"] + [0.0, 0.0, 0.2]
    met = R.frame_metrics(sim, target, [1, 0, 1, 0], [1, 0, 0, 0])
    np.testing.assert_allclose(met, [17 * 0.5 / 18, 0.2, 0.0, 0.25], atol=1e-12)
