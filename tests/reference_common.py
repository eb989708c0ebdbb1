"""Shared part of the pure-numpy reference environment: constants and rotation maths.

Holds the skeleton/scene constants (body counts, key bodies, fingertips,
contact-pair names, reward-term names, default reward weights, variants) and
the quaternion / rotation helpers used by ``reference_reward`` and
``reference_env``.  It depends on numpy only and imports no other reference
module.

Conventions
-----------
* Quaternions are ``(w, x, y, z)`` everywhere.
* All computation is float64; clip arrays and derived reference arrays are
  *stored* as float32 (like the project) and promoted to float64 when used.
* MuJoCo body ids: 0 = world, 1..53 = skeleton bodies (skeleton index
  ``b`` has body id ``b + 1``), the ball body is named ``"Ball"``.
  In the "state" arrays, indices 0..52 are the skeleton and 53 is the ball.
"""

from __future__ import annotations

import math

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
