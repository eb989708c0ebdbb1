"""Pure-numpy reference implementation of the SkillMimic skill environment.

This module is an *independent* re-statement of the environment maths used by
skillmimic-rs (observation, HOI states, contact graph, imitation reward, frame
metrics, reference-state initialisation).  It only reads a PyPI
``mujoco.MjData`` of the project's scene and never steps physics itself, so a
test can drive the Rust environment and this file from the same MuJoCo state
and compare the results (target tolerance 1e-5).

Conventions
-----------
* Quaternions are ``(w, x, y, z)`` everywhere.
* All computation is float64; clip arrays and derived reference arrays are
  *stored* as float32 (like the project) and promoted to float64 when used.
* MuJoCo body ids: 0 = world, 1..53 = skeleton bodies (skeleton index
  ``b`` has body id ``b + 1``), the ball body is named ``"Ball"``.
  In the "state" arrays, indices 0..52 are the skeleton and 53 is the ball.

Dependencies: numpy, mujoco, safetensors, zipfile, math.
"""

from __future__ import annotations

import math
import os
import zipfile

import mujoco
import numpy as np

# ---------------------------------------------------------------------------
# Constants
# ---------------------------------------------------------------------------

NUM_BODIES = 53                 # skeleton bodies (Pelvis .. R_Thumb3)
NUM_JOINTS = 52                 # non-root skeleton bodies, one 3-dof joint each
NUM_DOF = 3 * NUM_JOINTS        # 156
BALL = 53                       # state index of the ball
NUM_STATE_BODIES = 54           # skeleton + ball
COND_SIZE = 64                  # width of the skill one-hot
OBS_SIZE = 902

KEY_BODIES = [14, 2, 6, 17, 36, 3, 7, 21, 24, 27, 30, 33, 40, 43, 46, 49, 52]
FINGERTIPS = [21, 24, 27, 30, 33, 40, 43, 46, 49, 52]
REFERENCE_BODY_NODE = [0, 1, 2, 5, 6, 9, 10, 11, 12, 13, 14, 15, 16, 17, 34, 35, 36]

HAND_BODIES = frozenset(list(range(18, 34)) + list(range(37, 53)))
FOOT_BODIES = frozenset([3, 4, 7, 8])

# Geom-owner / body-part categories used by the contact-pair flags.
PART_FLOOR = "floor"
PART_BALL = "ball"
PART_HAND = "hand"
PART_FOOT = "foot"
PART_TRUNK = "trunk"

PAIR_NAMES = ["hand_ball", "body_ball", "hand_body", "ball_floor",
              "body_floor", "foot_floor", "hand_floor"]

BALL_FREE_SKILLS = (0, 10)

REWARD_NAMES = ["p", "r", "pv", "rv", "reg", "op", "or", "opv", "orv", "ig", "cg", "total"]
METRIC_NAMES = ["body_err", "ball_err", "cg_match", "cg_sq_err"]

DEFAULT_WEIGHTS = {
    "p": 20.0, "r": 20.0, "pv": 0.0, "rv": 0.0,
    "reg": 0.1, "reg_scale": 1e12,
    "op": 1.0, "or": 0.0, "opv": 0.0, "orv": 0.0,
    "ig": 20.0,
    # exact contact graph: [hand_ball, body_ball, hand_body, body_floor]
    "cg_hand_ball": 5.0, "cg_body_ball": 5.0, "cg_hand_body": 5.0, "cg_body_floor": 5.0,
    # force-threshold contact graph: [ball_node, body_node]
    "cg2_ball": 5.0, "cg1_body": 5.0,
    # "deepmimic" variant (fixed in the spec; overridable through the same dict)
    "dm_p": 40.0, "dm_r": 2.0, "dm_rv": 0.1, "dm_op": 40.0,
}

VARIANTS = ("skillmimic", "no_contact_graph", "additive", "deepmimic")
GRAPH_MODES = ("exact", "force_threshold")

PT_NUM_COLUMNS = 337
DEFAULT_FPS = 60.0


# ---------------------------------------------------------------------------
# Quaternion / rotation helpers (wxyz, float64, vectorised over leading axes)
# ---------------------------------------------------------------------------

def quat_mul(a, b):
    """Hamilton product ``a ⊗ b`` of (..., 4) wxyz quaternions."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def quat_conj(q):
    """Conjugate of a (..., 4) wxyz quaternion."""
    q = np.array(q, dtype=np.float64)
    q[..., 1:] *= -1.0
    return q


def quat_normalize(q):
    """Unit-norm copy of a (..., 4) quaternion."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_to_mat(q):
    """Rotation matrix (..., 3, 3) of a (..., 4) wxyz quaternion (normalised first)."""
    w, x, y, z = np.moveaxis(quat_normalize(q), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=-2)


def quat_rotate(q, v):
    """Rotate vector(s) ``v`` (..., 3) by quaternion(s) ``q`` (..., 4)."""
    return np.einsum("...ij,...j->...i", quat_to_mat(q), np.asarray(v, dtype=np.float64))


def quat_to_rotvec(q):
    """Rotation vector of (..., 4) wxyz quaternion(s), angle wrapped to (-pi, pi].

    v = (x, y, z); s = |v|; s < 1e-15 -> 0; angle = 2 atan2(s, w);
    angle > pi -> angle - 2 pi; result = v / s * angle.  The result does not
    depend on a positive scale of ``q``, so normalising first changes nothing.
    """
    q = np.asarray(q, dtype=np.float64)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    angle = np.where(angle > math.pi, angle - 2.0 * math.pi, angle)
    safe = s >= 1e-15
    factor = np.where(safe, angle / np.where(safe, s, 1.0), 0.0)
    return v * factor[..., None]


def rotvec_to_quat(v):
    """Unit wxyz quaternion of (..., 3) rotation vector(s) (exponential map)."""
    v = np.asarray(v, dtype=np.float64)
    angle = np.linalg.norm(v, axis=-1)
    small = angle < 1e-8
    safe_angle = np.where(small, 1.0, angle)
    # sin(a/2)/a -> 1/2 as a -> 0 (the Taylor remainder is below float64 eps here)
    k = np.where(small, 0.5, np.sin(0.5 * safe_angle) / safe_angle)
    w = np.where(small, 1.0, np.cos(0.5 * safe_angle))
    return np.concatenate([w[..., None], v * k[..., None]], axis=-1)


def quat_sign_continuity(q):
    """Flip q[t] when dot(q[t-1], q[t]) < 0 (sequential pass over axis 0)."""
    q = np.array(q, dtype=np.float64)
    for t in range(1, q.shape[0]):
        if float(np.dot(q[t - 1], q[t])) < 0.0:
            q[t] = -q[t]
    return q


def quat_angle(q_a, q_b):
    """Rotation angle between two quaternions: 2 atan2(|v|, |w|) of conj(a) ⊗ b."""
    d = quat_mul(quat_conj(q_a), q_b)
    return 2.0 * math.atan2(float(np.linalg.norm(d[1:])), abs(float(d[0])))


def heading_angle(root_quat):
    """Heading = atan2(y, x) of R(q)·(1, 0, 0) for the root quaternion."""
    x_axis = quat_to_mat(root_quat)[:, 0]
    return math.atan2(x_axis[1], x_axis[0])


def heading_inverse_matrix(root_quat):
    """3x3 rotation about world z by -heading(root_quat)."""
    h = heading_angle(root_quat)
    c, s = math.cos(-h), math.sin(-h)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def tan_norm(rot_mat):
    """Tan-norm 6D of a rotation: [R·(1,0,0), R·(0,0,1)] (columns 0 and 2)."""
    rot_mat = np.asarray(rot_mat, dtype=np.float64)
    return np.concatenate([rot_mat[..., :, 0], rot_mat[..., :, 2]], axis=-1)


def backward_diff(x, fps):
    """Backward difference times fps along axis 0, frame 0 set to 0 (float64)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros_like(x)
    out[1:] = (x[1:] - x[:-1]) * fps
    return out


def local_angular_velocity(quats, fps):
    """rotvec(conj(q[t-1]) ⊗ q[t]) * fps per frame (body frame), frame 0 = 0."""
    q = np.asarray(quats, dtype=np.float64)
    out = np.zeros((q.shape[0], 3))
    if q.shape[0] > 1:
        out[1:] = quat_to_rotvec(quat_mul(quat_conj(q[:-1]), q[1:])) * fps
    return out


# ---------------------------------------------------------------------------
# Clips
# ---------------------------------------------------------------------------

def _skill_from_name(path):
    """Skill label = int of the first three characters of the file name."""
    return int(os.path.basename(path)[:3])


def _load_pt_rows(path):
    """Read the raw (T, 337) float32 table of a BallPlay-M ``.pt`` zip archive."""
    with zipfile.ZipFile(path) as zf:
        members = [n for n in zf.namelist() if n.endswith("/data/0")]
        if len(members) != 1:
            raise ValueError(f"{path}: expected one '*/data/0' member, found {members}")
        raw = zf.read(members[0])
    rows = np.frombuffer(raw, dtype="<f4").reshape(-1, PT_NUM_COLUMNS)
    return rows.astype(np.float32)


def _clip_from_pt(path):
    """Build the clip dict of a BallPlay-M ``.pt`` file (see load_clip)."""
    rows = _load_pt_rows(path)
    root_q = quat_sign_continuity(rotvec_to_quat(rows[:, 3:6].astype(np.float64)))
    ball_q = rotvec_to_quat(-rows[:, 327:330].astype(np.float64))
    return {
        "root_pos": rows[:, 0:3].copy(),
        "root_rot": root_q.astype(np.float32),
        "dof_rot": rows[:, 9:165].reshape(-1, NUM_JOINTS, 3).copy(),
        "body_pos": rows[:, 165:324].reshape(-1, NUM_BODIES, 3).copy(),
        "ball_pos": rows[:, 324:327].copy(),
        "ball_rot": ball_q.astype(np.float32),
        "contact": np.round(rows[:, 336]).astype(np.float32),
        "fps": DEFAULT_FPS,
        "skill": _skill_from_name(path),
    }


def _clip_from_safetensors(path):
    """Build the clip dict of a project ``.safetensors`` clip (see load_clip)."""
    from safetensors import safe_open

    clip = {}
    with safe_open(path, framework="numpy") as f:
        meta = f.metadata() or {}
        for key in ("root_pos", "root_rot", "dof_rot", "body_pos",
                    "ball_pos", "ball_rot", "contact"):
            clip[key] = np.asarray(f.get_tensor(key), dtype=np.float32)
    clip["dof_rot"] = clip["dof_rot"].reshape(-1, NUM_JOINTS, 3)
    clip["body_pos"] = clip["body_pos"].reshape(-1, NUM_BODIES, 3)
    clip["contact"] = clip["contact"].reshape(-1)
    clip["fps"] = float(meta.get("fps", DEFAULT_FPS))
    clip["skill"] = int(meta["skill"]) if "skill" in meta else _skill_from_name(path)
    return clip


def load_clip(path):
    """Load a clip (``.pt`` BallPlay-M archive or project ``.safetensors``).

    Returns a dict with float32 arrays ``root_pos`` (T,3), ``root_rot`` (T,4 wxyz),
    ``dof_rot`` (T,52,3), ``body_pos`` (T,53,3), ``ball_pos`` (T,3),
    ``ball_rot`` (T,4 wxyz), ``contact`` (T,), plus ``fps`` (float),
    ``skill`` (int) and ``num_frames`` (int).
    """
    path = os.fspath(path)
    if path.endswith(".safetensors"):
        clip = _clip_from_safetensors(path)
    elif path.endswith(".pt"):
        clip = _clip_from_pt(path)
    else:
        raise ValueError(f"unknown clip format: {path}")
    clip["num_frames"] = int(clip["root_pos"].shape[0])
    return clip


def derive_reference(clip):
    """Derived per-frame reference quantities of a clip (float64 maths, float32 storage).

    Keys: root_rotvec (T,3), root_linvel (T,3), root_angvel_local (T,3),
    dof_vel (T,156), key_pos (T,17,3), key_vel (T,17,3), ball_linvel (T,3),
    ball_angvel_local (T,3).  Velocities are backward differences times fps
    with frame 0 = 0; angular velocities are body-frame (see
    ``local_angular_velocity``).
    """
    fps = float(clip["fps"])
    num_frames = clip["root_pos"].shape[0]
    root_rot = np.asarray(clip["root_rot"], dtype=np.float64)
    ball_rot = np.asarray(clip["ball_rot"], dtype=np.float64)
    dof = np.asarray(clip["dof_rot"], dtype=np.float64).reshape(num_frames, NUM_DOF)
    key_pos = np.asarray(clip["body_pos"], dtype=np.float64)[:, KEY_BODIES]
    derived = {
        "root_rotvec": quat_to_rotvec(root_rot),
        "root_linvel": backward_diff(clip["root_pos"], fps),
        "root_angvel_local": local_angular_velocity(root_rot, fps),
        "dof_vel": backward_diff(dof, fps),
        "key_pos": key_pos,
        "key_vel": backward_diff(key_pos, fps),
        "ball_linvel": backward_diff(clip["ball_pos"], fps),
        "ball_angvel_local": local_angular_velocity(ball_rot, fps),
    }
    return {k: v.astype(np.float32) for k, v in derived.items()}


# ---------------------------------------------------------------------------
# State extraction from MuJoCo
# ---------------------------------------------------------------------------

def ball_body_id(m):
    """MuJoCo body id of the ball (body named "Ball")."""
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "Ball")
    if bid < 0:
        raise ValueError("model has no body named 'Ball'")
    return bid


def state_body_ids(m):
    """MuJoCo body ids of the 54 state bodies (skeleton 0..52, then the ball)."""
    return list(range(1, NUM_BODIES + 1)) + [ball_body_id(m)]


def skeleton_joint(m, j):
    """Ball joint id of skeleton joint j, or -1 if its body is welded.

    Skeleton joint j (0..51) belongs to skeleton body j+1, i.e. MuJoCo body j+2.
    """
    body = j + 2
    if m.body_jntnum[body] == 0:
        return -1
    jid = int(m.body_jntadr[body])
    if m.jnt_type[jid] != mujoco.mjtJoint.mjJNT_BALL:
        raise ValueError(f"body {body}: expected a ball joint, got type {m.jnt_type[jid]}")
    return jid


def free_joint_of_body(m, body):
    """Free joint id of a body (root or ball)."""
    jid = int(m.body_jntadr[body])
    if m.body_jntnum[body] != 1 or m.jnt_type[jid] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(f"body {body} has no single free joint")
    return jid


def geom_part(m, g, ball_body):
    """Category of the body owning geom g: floor, ball, hand, foot or trunk."""
    body = int(m.geom_bodyid[g])
    if body == 0:
        return PART_FLOOR
    if body == ball_body:
        return PART_BALL
    k = body - 1
    if k in HAND_BODIES:
        return PART_HAND
    if k in FOOT_BODIES:
        return PART_FOOT
    return PART_TRUNK


def geom_state_index(m, g, ball_body):
    """State index (0..52 skeleton, 53 ball) owning geom g, or -1 for the floor/world."""
    body = int(m.geom_bodyid[g])
    if body == 0:
        return -1
    if body == ball_body:
        return BALL
    return body - 1


def pair_kinds(part1, part2):
    """Contact-pair flag names that a contact between two parts sets."""
    parts = {part1, part2}
    body_like = (PART_TRUNK, PART_FOOT)
    kinds = []
    if parts == {PART_HAND, PART_BALL}:
        kinds.append("hand_ball")
    if PART_BALL in parts and (parts - {PART_BALL}) & set(body_like):
        kinds.append("body_ball")
    if PART_HAND in parts and (parts - {PART_HAND}) & set(body_like):
        kinds.append("hand_body")
    if parts == {PART_BALL, PART_FLOOR}:
        kinds.append("ball_floor")
    if parts == {PART_TRUNK, PART_FLOOR}:
        kinds.append("body_floor")
    if parts == {PART_FOOT, PART_FLOOR}:
        kinds.append("foot_floor")
    if parts == {PART_HAND, PART_FLOOR}:
        kinds.append("hand_floor")
    return kinds


def contact_world_force(m, d, i, frame):
    """World-frame force of contact i (force on geom2's body; geom1's body gets -F).

    ``frame`` is the contact's 9-number frame (rows: normal, tangent1, tangent2).
    """
    f6 = np.zeros(6)
    mujoco.mj_contactForce(m, d, i, f6)
    rows = np.asarray(frame, dtype=np.float64).reshape(3, 3)
    return f6[0] * rows[0] + f6[1] * rows[1] + f6[2] * rows[2]


def extract_contacts(m, d):
    """Net contact force per state body (54,3) and the contact-pair flags.

    Reads ``d.contact`` as left by the last physics sub-step; contacts with
    ``efc_address < 0`` are skipped.
    """
    ball_body = ball_body_id(m)
    forces = np.zeros((NUM_STATE_BODIES, 3))
    pairs = {name: 0 for name in PAIR_NAMES}
    ncon = int(d.ncon)
    contacts = d.contact
    efc = np.array(contacts.efc_address[:ncon])
    geoms = np.array(contacts.geom[:ncon]).reshape(ncon, 2)
    frames = np.array(contacts.frame[:ncon], dtype=np.float64).reshape(ncon, 9)
    for i in range(ncon):
        if int(efc[i]) < 0:
            continue
        g1, g2 = int(geoms[i, 0]), int(geoms[i, 1])
        for kind in pair_kinds(geom_part(m, g1, ball_body), geom_part(m, g2, ball_body)):
            pairs[kind] = 1
        force = contact_world_force(m, d, i, frames[i])
        s1 = geom_state_index(m, g1, ball_body)
        s2 = geom_state_index(m, g2, ball_body)
        if s2 >= 0:
            forces[s2] += force
        if s1 >= 0:
            forces[s1] -= force
    return forces, pairs


def body_velocity(m, d, body):
    """(linear COM velocity, angular velocity), both in world orientation."""
    res = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, res, 0)
    return res[3:6].copy(), res[0:3].copy()


def extract_joints(m, d):
    """dof_pos (156,) = rotvecs of the ball joints, dof_vel (156,) = their qvel."""
    dof_pos = np.zeros(NUM_DOF)
    dof_vel = np.zeros(NUM_DOF)
    for j in range(NUM_JOINTS):
        jid = skeleton_joint(m, j)
        if jid < 0:
            continue
        qa, va = int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])
        quat = quat_normalize(np.asarray(d.qpos[qa:qa + 4], dtype=np.float64))
        dof_pos[3 * j:3 * j + 3] = quat_to_rotvec(quat)
        dof_vel[3 * j:3 * j + 3] = d.qvel[va:va + 3]
    return dof_pos, dof_vel


def extract_state(m, d):
    """Simulated state from a MuJoCo model/data of the project's scene.

    Does not call ``mj_forward``: kinematics/velocities are read from the
    current ``xpos/xquat/cvel`` and contacts from ``d.contact``.
    Returns a dict with body_pos (54,3), body_quat (54,4), body_linvel (54,3),
    body_angvel (54,3) (world frame; linear = centre-of-mass velocity),
    dof_pos (156,), dof_vel (156,), contact_force (54,3) and pairs (dict).
    """
    ids = state_body_ids(m)
    lin = np.zeros((NUM_STATE_BODIES, 3))
    ang = np.zeros((NUM_STATE_BODIES, 3))
    for k, body in enumerate(ids):
        lin[k], ang[k] = body_velocity(m, d, body)
    dof_pos, dof_vel = extract_joints(m, d)
    forces, pairs = extract_contacts(m, d)
    return {
        "body_pos": np.array(d.xpos[ids], dtype=np.float64),
        "body_quat": np.array(d.xquat[ids], dtype=np.float64),
        "body_linvel": lin,
        "body_angvel": ang,
        "dof_pos": dof_pos,
        "dof_vel": dof_vel,
        "contact_force": forces,
        "pairs": pairs,
    }


# ---------------------------------------------------------------------------
# Observation
# ---------------------------------------------------------------------------

def skill_one_hot(skill):
    """64-wide one-hot of the skill label."""
    skill = int(skill)
    if not 0 <= skill < COND_SIZE:
        raise ValueError(f"skill label {skill} outside [0, {COND_SIZE})")
    out = np.zeros(COND_SIZE)
    out[skill] = 1.0
    return out


def _humanoid_obs(state, hinv):
    """Observation entries 0:793 (root height, local pos/rot/vel/angvel)."""
    pos = state["body_pos"][:NUM_BODIES]
    root = pos[0]
    local_pos = (pos[1:] - root) @ hinv.T
    local_rot = hinv @ quat_to_mat(state["body_quat"][:NUM_BODIES])   # (53,3,3)
    local_vel = state["body_linvel"][:NUM_BODIES] @ hinv.T
    local_ang = state["body_angvel"][:NUM_BODIES] @ hinv.T
    return np.concatenate([
        [root[2]],
        local_pos.reshape(-1),
        tan_norm(local_rot).reshape(-1),
        local_vel.reshape(-1),
        local_ang.reshape(-1),
    ])


def _ball_obs(state, hinv):
    """Observation entries 823:838 (ball pos/rot/vel/angvel in the heading frame)."""
    root = state["body_pos"][0]
    ball = state["body_pos"][BALL]
    rel = np.array([ball[0] - root[0], ball[1] - root[1], ball[2]])
    return np.concatenate([
        hinv @ rel,
        tan_norm(hinv @ quat_to_mat(state["body_quat"][BALL])),
        hinv @ state["body_linvel"][BALL],
        hinv @ state["body_angvel"][BALL],
    ])


def observation(state, skill):
    """902-float skill-policy observation (computed in float64, returned as float32)."""
    hinv = heading_inverse_matrix(state["body_quat"][0])
    obs = np.concatenate([
        _humanoid_obs(state, hinv),
        state["contact_force"][FINGERTIPS].reshape(-1),
        _ball_obs(state, hinv),
        skill_one_hot(skill),
    ])
    assert obs.shape == (OBS_SIZE,), obs.shape
    return obs.astype(np.float32)


# ---------------------------------------------------------------------------
# HOI states
# ---------------------------------------------------------------------------

def hoi_sim(state):
    """Simulated HOI dict (float64) from an extracted state."""
    return {
        "root_pos": state["body_pos"][0].copy(),
        "root_rotvec": quat_to_rotvec(quat_normalize(state["body_quat"][0])),
        "dof_pos": state["dof_pos"].copy(),
        "dof_vel": state["dof_vel"].copy(),
        "ball_pos": state["body_pos"][BALL].copy(),
        "ball_quat": state["body_quat"][BALL].copy(),
        "ball_linvel": state["body_linvel"][BALL].copy(),
        "ball_angvel": state["body_angvel"][BALL].copy(),
        "key_pos": state["body_pos"][KEY_BODIES].copy(),
        "key_vel": state["body_linvel"][KEY_BODIES].copy(),
    }


def hoi_ref(clip, ref, t):
    """Reference HOI dict (float64) of clip frame t; ``ref`` = derive_reference(clip).

    Also carries ``contact`` = the clip's hand-ball label at frame t.
    """
    f64 = lambda a: np.array(a, dtype=np.float64)  # noqa: E731
    ball_quat = f64(clip["ball_rot"][t])
    return {
        "root_pos": f64(clip["root_pos"][t]),
        "root_rotvec": f64(ref["root_rotvec"][t]),
        "dof_pos": f64(clip["dof_rot"][t]).reshape(NUM_DOF),
        "dof_vel": f64(ref["dof_vel"][t]).reshape(NUM_DOF),
        "ball_pos": f64(clip["ball_pos"][t]),
        "ball_quat": ball_quat,
        "ball_linvel": f64(ref["ball_linvel"][t]),
        "ball_angvel": quat_rotate(ball_quat, f64(ref["ball_angvel_local"][t])),
        "key_pos": f64(ref["key_pos"][t]),
        "key_vel": f64(ref["key_vel"][t]),
        "contact": float(clip["contact"][t]),
    }


# ---------------------------------------------------------------------------
# Contact graph
# ---------------------------------------------------------------------------

def contact_graph(state, mode="exact", thr=0.1):
    """Simulated contact graph.

    exact: [hand_ball, body_ball, hand_body, body_floor] flags.
    force_threshold: [ball_node, body_node] with ball_node = |F_ball x| > thr or
    |F_ball y| > thr, body_node = any |component| >= thr over REFERENCE_BODY_NODE.
    """
    if mode == "exact":
        p = state["pairs"]
        return np.array([p["hand_ball"], p["body_ball"], p["hand_body"], p["body_floor"]],
                        dtype=np.float64)
    if mode == "force_threshold":
        f = state["contact_force"]
        ball_node = float(abs(f[BALL, 0]) > thr or abs(f[BALL, 1]) > thr)
        body_node = float(np.any(np.abs(f[REFERENCE_BODY_NODE]) >= thr))
        return np.array([ball_node, body_node])
    raise ValueError(f"unknown contact-graph mode {mode!r}")


def reference_graph(label, mode="exact"):
    """Reference contact graph: [label, 0, 0, 0] (exact) or [label, 0] (force_threshold)."""
    if mode == "exact":
        return np.array([float(label), 0.0, 0.0, 0.0])
    if mode == "force_threshold":
        return np.array([float(label), 0.0])
    raise ValueError(f"unknown contact-graph mode {mode!r}")


# ---------------------------------------------------------------------------
# Reward
# ---------------------------------------------------------------------------

def _mse(a, b):
    """Mean of squared component differences (float64)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    b = np.asarray(b, dtype=np.float64).reshape(-1)
    return float(np.mean((a - b) ** 2))


def _interaction_vectors(hoi):
    """The 18 vectors (root - ball), (key_k - ball), shape (18, 3)."""
    points = np.concatenate([hoi["root_pos"][None], hoi["key_pos"].reshape(-1, 3)])
    return points - hoi["ball_pos"][None]


def reward_errors(sim, prev_dof_vel, ref, reg_scale=1e12):
    """The ten error terms e_* (means of squared differences), as a dict."""
    sim_dv = np.asarray(sim["dof_vel"], dtype=np.float64)
    prev = np.asarray(prev_dof_vel, dtype=np.float64).reshape(-1)
    ref_dv = np.asarray(ref["dof_vel"], dtype=np.float64)
    return {
        "p": _mse(np.concatenate([sim["root_pos"], sim["key_pos"].reshape(-1)]),
                  np.concatenate([ref["root_pos"], ref["key_pos"].reshape(-1)])),
        "r": _mse(np.concatenate([sim["root_rotvec"], sim["dof_pos"]]),
                  np.concatenate([ref["root_rotvec"], ref["dof_pos"]])),
        "pv": _mse(sim["key_vel"], ref["key_vel"]),
        "rv": _mse(sim_dv, ref_dv),
        "reg": float(np.mean((sim_dv - prev) ** 2 / (1.0 + reg_scale * ref_dv ** 2))),
        "op": _mse(sim["ball_pos"], ref["ball_pos"]),
        "or": quat_angle(sim["ball_quat"], ref["ball_quat"]) ** 2,
        "opv": _mse(sim["ball_linvel"], ref["ball_linvel"]),
        "orv": _mse(sim["ball_angvel"], ref["ball_angvel"]),
        "ig": _mse(_interaction_vectors(sim), _interaction_vectors(ref)),
    }


def _graph_weights(w, mode):
    """Per-entry contact-graph weights for the given mode."""
    if mode == "exact":
        return np.array([w["cg_hand_ball"], w["cg_body_ball"], w["cg_hand_body"],
                         w["cg_body_floor"]])
    if mode == "force_threshold":
        return np.array([w["cg2_ball"], w["cg1_body"]])
    raise ValueError(f"unknown contact-graph mode {mode!r}")


def contact_graph_reward(cg_sim, cg_ref, weights, mode="exact"):
    """prod_k exp(-w_k |sim_k - ref_k|)."""
    diff = np.abs(np.asarray(cg_sim, np.float64) - np.asarray(cg_ref, np.float64))
    return float(np.prod(np.exp(-_graph_weights(weights, mode) * diff)))


def _deepmimic_terms(e, w, ball_free):
    """Term dict of the "deepmimic" variant."""
    terms = {k: 1.0 for k in REWARD_NAMES}
    terms["p"] = math.exp(-w["dm_p"] * e["p"])
    terms["r"] = math.exp(-w["dm_r"] * e["r"])
    terms["rv"] = math.exp(-w["dm_rv"] * e["rv"])
    terms["op"] = 1.0 if ball_free else math.exp(-w["dm_op"] * e["op"])
    terms["total"] = (terms["p"] + terms["r"] + terms["rv"] + terms["op"]) / 4.0
    return terms


def _skillmimic_terms(e, w, cg, ball_free, variant):
    """Term dict of the skillmimic / no_contact_graph / additive variants."""
    terms = {k: math.exp(-w[k] * e[k]) for k in
             ("p", "r", "pv", "rv", "reg", "op", "or", "opv", "orv", "ig")}
    terms["cg"] = cg
    if ball_free:
        for k in ("op", "or", "opv", "orv", "ig", "cg"):
            terms[k] = 1.0
    body = terms["p"] * terms["r"] * terms["pv"] * terms["rv"] * terms["reg"]
    ball = terms["op"] * terms["or"] * terms["opv"] * terms["orv"]
    if variant == "skillmimic":
        terms["total"] = body * ball * terms["ig"] * terms["cg"]
    elif variant == "no_contact_graph":
        terms["total"] = body * ball * terms["ig"]
    else:  # additive
        terms["total"] = (body + ball + terms["ig"] + terms["cg"]) / 4.0
    return terms


def reward_terms(sim_hoi, prev_dof_vel, ref_hoi, cg_sim, cg_ref, skill,
                 variant="skillmimic", mode="exact", weights=None):
    """The 12 reward values in REWARD_NAMES order (float64 array).

    ``weights`` optionally overrides entries of DEFAULT_WEIGHTS.  Skills 0 and
    10 are "ball free": op, or, opv, orv, ig and cg are 1.  In the
    ``no_contact_graph`` variant the cg entry is still reported but is not
    part of the total.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown reward variant {variant!r}")
    w = dict(DEFAULT_WEIGHTS)
    if weights:
        w.update(weights)
    e = reward_errors(sim_hoi, prev_dof_vel, ref_hoi, reg_scale=w["reg_scale"])
    ball_free = int(skill) in BALL_FREE_SKILLS
    if variant == "deepmimic":
        terms = _deepmimic_terms(e, w, ball_free)
    else:
        cg = contact_graph_reward(cg_sim, cg_ref, w, mode)
        terms = _skillmimic_terms(e, w, cg, ball_free, variant)
    return np.array([terms[k] for k in REWARD_NAMES], dtype=np.float64)


def step_reward(state, prev_dof_vel, clip, ref, t, variant="skillmimic",
                mode="exact", thr=0.1, weights=None):
    """Convenience: (12 reward values, cg_sim, cg_ref) for a state vs clip frame t."""
    sim = hoi_sim(state)
    target = hoi_ref(clip, ref, t)
    cg_sim = contact_graph(state, mode, thr)
    cg_ref = reference_graph(target["contact"], mode)
    terms = reward_terms(sim, prev_dof_vel, target, cg_sim, cg_ref, clip["skill"],
                         variant=variant, mode=mode, weights=weights)
    return terms, cg_sim, cg_ref


# ---------------------------------------------------------------------------
# Frame metrics
# ---------------------------------------------------------------------------

def frame_metrics(sim_hoi, ref_hoi, cg_sim, cg_ref):
    """[body_err, ball_err, cg_match, cg_sq_err] for one frame.

    body_err = mean Euclidean distance over root + 17 key bodies (m);
    ball_err = ball distance; cg_match = 1 if all graph entries equal;
    cg_sq_err = mean squared graph difference.
    """
    def points(h):
        return np.concatenate([np.asarray(h["root_pos"], np.float64)[None],
                               np.asarray(h["key_pos"], np.float64).reshape(-1, 3)])

    body_err = float(np.mean(np.linalg.norm(points(sim_hoi) - points(ref_hoi), axis=1)))
    ball_err = float(np.linalg.norm(np.asarray(sim_hoi["ball_pos"], np.float64)
                                    - np.asarray(ref_hoi["ball_pos"], np.float64)))
    diff = np.asarray(cg_sim, np.float64) - np.asarray(cg_ref, np.float64)
    cg_match = float(np.all(diff == 0.0))
    cg_sq_err = float(np.mean(diff ** 2))
    return np.array([body_err, ball_err, cg_match, cg_sq_err])


# ---------------------------------------------------------------------------
# Reference-state initialisation
# ---------------------------------------------------------------------------

def reset_qpos_qvel(m, clip, ref, t):
    """(qpos, qvel) of the reference-state initialisation at clip frame t.

    Root: position and quaternion from the clip, linear velocity (world) and
    angular velocity (root frame, MuJoCo's free-joint convention) from the
    derived reference.  Each skeleton ball joint: quaternion = exp(dof triple),
    qvel = dof-velocity triple (welded joints skipped).  Ball: position, the
    clip quaternion, the reference linear velocity and zero angular velocity.
    Entries of the model not covered here keep ``m.qpos0`` / zero.
    """
    qpos = np.array(m.qpos0, dtype=np.float64)
    qvel = np.zeros(m.nv)
    f64 = lambda a: np.asarray(a, dtype=np.float64)  # noqa: E731

    root = free_joint_of_body(m, 1)
    qa, va = int(m.jnt_qposadr[root]), int(m.jnt_dofadr[root])
    qpos[qa:qa + 3] = f64(clip["root_pos"][t])
    qpos[qa + 3:qa + 7] = f64(clip["root_rot"][t])
    qvel[va:va + 3] = f64(ref["root_linvel"][t])
    qvel[va + 3:va + 6] = f64(ref["root_angvel_local"][t])

    dofs = f64(clip["dof_rot"][t]).reshape(NUM_JOINTS, 3)
    dof_vel = f64(ref["dof_vel"][t]).reshape(NUM_JOINTS, 3)
    for j in range(NUM_JOINTS):
        jid = skeleton_joint(m, j)
        if jid < 0:
            continue
        qa, va = int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])
        qpos[qa:qa + 4] = rotvec_to_quat(dofs[j])
        qvel[va:va + 3] = dof_vel[j]

    ball = free_joint_of_body(m, ball_body_id(m))
    qa, va = int(m.jnt_qposadr[ball]), int(m.jnt_dofadr[ball])
    qpos[qa:qa + 3] = f64(clip["ball_pos"][t])
    qpos[qa + 3:qa + 7] = f64(clip["ball_rot"][t])
    qvel[va:va + 3] = f64(ref["ball_linvel"][t])
    qvel[va + 3:va + 6] = 0.0
    return qpos, qvel
