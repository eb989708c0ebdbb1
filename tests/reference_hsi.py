"""Independent numpy reference of the four TokenHSI foundational tasks (path following, sitting,
climbing, carrying): the character's 222-d proprioception, the task observations and the task
rewards, written from the TokenHSI supplementary material (§A "The Proprioception s_t"; §B.2,
Eqs. 1-15), not from the Rust implementation.

It reads a PyPI ``mujoco.MjData`` of an environment's scene after ``mj_forward`` and never steps
physics, so a test can put the Rust environment's state into MuJoCo and compare the numbers.

Conventions (where the supplementary leaves them open, they are the ones the implementation
documents; each is named where it is used):

* Quaternions are ``(w, x, y, z)``; everything is float64.
* The character's local ("heading") frame: origin at the root (pelvis) position, rotated about the
  world +z axis by −heading, heading = yaw of the pelvis's x axis.
* Body positions are the bodies' frame origins (``xpos``); body linear velocities those of their
  centres of mass; angular velocities world vectors expressed in the heading frame.
* Rotations are the 6D tan-norm representation [R·e_x, R·e_z].
* Velocities in the rewards (ẋ_root, ẋ_obj) are finite differences of positions over one policy
  step of 1/30 s; the reward of a step uses the state after the step.
* Bounding-box corners are in the released order: the bottom face (+x +y), (−x +y), (−x −y), (+x −y),
  then the top face.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from reference_common import heading_inverse_matrix, quat_to_mat, tan_norm

# ---------------------------------------------------------------------------
# Constants of the supplementary
# ---------------------------------------------------------------------------

# The 15 rigid bodies of the TokenHSI character (supplementary §A, Fig. A), root first.
BODY_NAMES = ["pelvis", "torso", "head", "right_upper_arm", "right_lower_arm", "right_hand", "left_upper_arm",
              "left_lower_arm", "left_hand", "right_thigh", "right_shin", "right_foot", "left_thigh", "left_shin", "left_foot"]
HANDS = ("right_hand", "left_hand")
FEET = ("right_foot", "left_foot")
PROPRIO_DIM = 222                 # §A: s_t ∈ R^222
POLICY_DT = 1.0 / 30.0            # 30 Hz control
NUM_WAYPOINTS = 10                # §B.2.1: 10 future waypoints ...
WAYPOINT_DT = 0.1                 # ... 0.1 s apart
SIT_TARGET_ABOVE_SEAT = 0.10      # §B.2.2: target 10 cm above the centre of the seat's top surface
CLIMB_TARGET_ABOVE_TOP = 0.94     # §B.2.3: target 94 cm above the centre of the object's top surface
TASK_OBS_DIM = {"hsi_follow": 20, "hsi_sit": 38, "hsi_climb": 27, "hsi_carry": 42}


# ---------------------------------------------------------------------------
# Reading the MuJoCo state
# ---------------------------------------------------------------------------

def body_ids(m):
    """MuJoCo body ids of the 15 character bodies in ``BODY_NAMES`` order."""
    return [m.body(n).id for n in BODY_NAMES]


def body_velocity(m, d, body):
    """(linear velocity of the body's centre of mass, angular velocity), world frame."""
    res = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, res, 0)
    return res[3:6].copy(), res[0:3].copy()


def root_pose(m, d):
    """(position, quaternion) of the character's root (pelvis frame), world."""
    b = m.body("pelvis").id
    return np.array(d.xpos[b]), np.array(d.xquat[b])


def body_pos(m, d, name):
    return np.array(d.xpos[m.body(name).id])


class Heading:
    """The character's local frame: origin at the root, rotated about +z by −heading."""

    def __init__(self, m, d):
        self.root, q = root_pose(m, d)
        self.inv = heading_inverse_matrix(q)

    def point(self, p):
        return self.inv @ (np.asarray(p, dtype=np.float64) - self.root)

    def vector(self, v):
        return self.inv @ np.asarray(v, dtype=np.float64)

    def rotation(self, rot_mat):
        return tan_norm(self.inv @ rot_mat)


# ---------------------------------------------------------------------------
# §A: the 222-d proprioception
# ---------------------------------------------------------------------------

def proprioception_groups(m, d):
    """The feature groups of s_t (supplementary §A, following ASE): positions, rotations, linear
    and angular velocities of all rigid bodies, in the character's local frame, "except for the
    root joint rotation, which is represented in the world coordinate frame"; "the root joint
    position is excluded". Rotations use the 6D representation.

    Returns a dict: ``pos`` (14×3, bodies 1…14 relative to the root), ``root_rot`` (6, world),
    ``rot`` (14×6, heading-local), ``linvel`` (15×3), ``angvel`` (15×3).
    """
    ids = body_ids(m)
    h = Heading(m, d)
    pos = np.array([h.point(d.xpos[b]) for b in ids[1:]])
    root_rot = tan_norm(quat_to_mat(d.xquat[ids[0]]))          # world frame
    rot = np.array([h.rotation(quat_to_mat(d.xquat[b])) for b in ids[1:]])
    vel = [body_velocity(m, d, b) for b in ids]
    linvel = np.array([h.vector(v) for v, _ in vel])
    angvel = np.array([h.vector(w) for _, w in vel])
    return {"pos": pos, "root_rot": root_rot, "rot": rot, "linvel": linvel, "angvel": angvel}


# Slices of the groups in the 222-d vector: positions 42 | rotations 90 (root first) | linear
# velocities 45 | angular velocities 45.
PROPRIO_SLICES = {"pos": slice(0, 42), "root_rot": slice(42, 48), "rot": slice(48, 132), "linvel": slice(132, 177), "angvel": slice(177, 222)}


def proprioception(m, d):
    """s_t ∈ R^222 (supplementary §A): 14·3 + 15·6 + 15·3 + 15·3."""
    g = proprioception_groups(m, d)
    out = np.concatenate([g["pos"].ravel(), g["root_rot"], g["rot"].ravel(), g["linvel"].ravel(), g["angvel"].ravel()])
    assert out.shape == (PROPRIO_DIM,)
    return out


# ---------------------------------------------------------------------------
# Objects
# ---------------------------------------------------------------------------

def rot_z(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def object_boxes(m, name):
    """(centre, half size) of each box geom of body ``name`` in the body frame (the procedural
    objects are unions of axis-aligned boxes)."""
    b = m.body(name).id
    out = []
    for g in range(m.ngeom):
        if m.geom_bodyid[g] != b:
            continue
        assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        assert np.allclose(m.geom_quat[g], [1, 0, 0, 0]), "axis-aligned boxes"
        out.append((np.array(m.geom_pos[g]), np.array(m.geom_size[g])))
    return out


def object_bounds(m, name):
    """Bounding box (lo, hi) of the object in its own frame."""
    boxes = object_boxes(m, name)
    lo = np.min([c - h for c, h in boxes], axis=0)
    hi = np.max([c + h for c, h in boxes], axis=0)
    return lo, hi


def top_target_local(m, name, above):
    """A target ``above`` m over the centre of the top surface of the object's seat / top: the box
    with the lowest top (a chair's seat rather than its backrest; a platform's only box), object
    frame (§B.2.2: "10 cm above the center of the top surface of the chair seat"; §B.2.3: "94 cm
    above the center of the top surface of the object")."""
    c, h = min(object_boxes(m, name), key=lambda ch: ch[0][2] + ch[1][2])
    return np.array([c[0], c[1], c[2] + h[2] + above])


def box_corners(pos, rot_mat, lo, hi):
    """The 8 world corners of the box [lo, hi] (object frame) of an object at pos / rot_mat, in the
    released code's order (the text gives none): the bottom face (+x +y), (−x +y), (−x −y), (+x −y),
    then the top face in the same order."""
    out = []
    for z in (lo[2], hi[2]):
        for x, y in ((hi[0], hi[1]), (lo[0], hi[1]), (lo[0], lo[1]), (hi[0], lo[1])):
            out.append(np.asarray(pos, dtype=np.float64) + rot_mat @ np.array([x, y, z]))
    return np.array(out)


# ---------------------------------------------------------------------------
# Task observations (§B.2), all in the character's local frame
# ---------------------------------------------------------------------------

def follow_obs(m, d, waypoints):
    """g^f_t ∈ R^{2×10} (§B.2.1): the 2-D coordinates of the waypoints x_t, x_{t+0.1}, …, x_{t+0.9}
    (``waypoints``: 10 × 2 world), relative to the root in its local frame."""
    h = Heading(m, d)
    out = []
    for w in np.asarray(waypoints, dtype=np.float64):
        p = h.point([w[0], w[1], h.root[2]])
        out += [p[0], p[1]]
    return np.array(out)


def sit_obs(m, d, target, obj_pos, obj_rot, lo, hi):
    """g^s_t ∈ R^38 (§B.2.2): target sitting position (3) | object root position (3) | object root
    rotation, 6D (6) | object front-facing direction, 2D (2) | the 8 bounding-box corners (24).
    The front of the object is its +x axis."""
    h = Heading(m, d)
    facing = h.vector(obj_rot @ np.array([1.0, 0.0, 0.0]))[:2]
    corners = [h.point(c) for c in box_corners(obj_pos, obj_rot, lo, hi)]
    return np.concatenate([h.point(target), h.point(obj_pos), h.rotation(obj_rot), facing, *corners])


def climb_obs(m, d, target, obj_pos, obj_rot, lo, hi):
    """g^m_t ∈ R^27 (§B.2.3): target root position (3) | the 8 bounding-box corners (24)."""
    h = Heading(m, d)
    corners = [h.point(c) for c in box_corners(obj_pos, obj_rot, lo, hi)]
    return np.concatenate([h.point(target), *corners])


def carry_obs(m, d, target, box="box"):
    """g^c_t ∈ R^42 (§B.2.4): target location of the box (3) | box root position (3) | box root
    rotation, 6D (6) | box linear velocity (3) | box angular velocity (3) | the 8 corners of its
    bounding box (24). The box's half sizes come from its geom in the model."""
    h = Heading(m, d)
    b = m.body(box).id
    pos, rot = np.array(d.xpos[b]), quat_to_mat(d.xquat[b])
    v, w = body_velocity(m, d, b)
    lo, hi = object_bounds(m, box)
    corners = [h.point(c) for c in box_corners(pos, rot, lo, hi)]
    return np.concatenate([h.point(target), h.point(pos), h.rotation(rot), h.vector(v), h.vector(w), *corners])


# ---------------------------------------------------------------------------
# Task rewards (§B.2)
# ---------------------------------------------------------------------------

def _dist2d(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def _unit2d(frm, to):
    """Horizontal unit vector from ``frm`` to ``to`` (d*, d#)."""
    v = np.array([to[0] - frm[0], to[1] - frm[1]])
    n = np.linalg.norm(v)
    return v / n if n > 1e-9 else np.zeros(2)


def _vel2d(now, before, dt=POLICY_DT):
    """Horizontal velocity as the finite difference of positions over a policy step."""
    return np.array([now[0] - before[0], now[1] - before[1]]) / dt


def follow_reward(root, waypoint):
    """[r^f] — Eq. (1): r^f_t = exp(−2.0 ‖x^root_2d − x^τ_t‖²)."""
    e = _dist2d(root, waypoint)
    return np.array([math.exp(-2.0 * e * e)])


def sit_reward(root, prev_root, target, obj_pos):
    """[r^near, r^far, speed penalty, turning penalty, r^s] of the sitting task (the penalties are
    the released code's, not the text's: 0 here; r^far counts as 1 within 0.5 m, as Eq. 2 uses it)."""
    root, target = np.asarray(root, dtype=np.float64), np.asarray(target, dtype=np.float64)
    d_star = _unit2d(root, obj_pos)
    # Eq. (3): r^far = exp(−2.0 ‖1.5 − d*·ẋ^root_2d‖²)
    r_far = math.exp(-2.0 * (1.5 - d_star @ _vel2d(root, prev_root)) ** 2)
    # Eq. (4): r^near = exp(−10.0 ‖x^tar − x^root‖²)
    r_near = math.exp(-10.0 * float(np.sum((target - root) ** 2)))
    # Eq. (2): 0.7 r^near + 0.3 r^far if ‖x^obj_2d − x^root_2d‖ > 0.5, else 0.7 r^near + 0.3
    r = 0.7 * r_near + 0.3 * r_far if _dist2d(obj_pos, root) > 0.5 else 0.7 * r_near + 0.3
    return np.array([r_near, r_far if _dist2d(obj_pos, root) > 0.5 else 1.0, 0.0, 0.0, r])


def climb_reward(root, prev_root, feet_heights, target, obj_pos, offset=CLIMB_TARGET_ABOVE_TOP):
    """[r^near, r^far, r^foot, speed penalty, r^m] of the climbing task (the penalty is the released
    code's, not the text's: 0 here)."""
    root, target = np.asarray(root, dtype=np.float64), np.asarray(target, dtype=np.float64)
    d_star = _unit2d(root, obj_pos)
    # Eq. (6): r^far = exp(−2.0 ‖1.5 − d*·ẋ^root_2d‖²)
    r_far = math.exp(-2.0 * (1.5 - d_star @ _vel2d(root, prev_root)) ** 2)
    # Eq. (7): r^near = exp(−10.0 ‖x^tar − x^root‖²)
    r_near = math.exp(-10.0 * float(np.sum((target - root) ** 2)))
    # Eq. (8): r^foot = exp(−50.0 ‖(x^tar_h − 0.94) − x^foot_h‖²), x^foot_h = mean height of the feet
    foot_h = float(np.mean(feet_heights))
    r_foot = math.exp(-50.0 * ((target[2] - offset) - foot_h) ** 2)
    # Eq. (5): 0.5 r^near + 0.2 r^far if ‖x^obj_2d − x^root_2d‖ > 0.7, else 0.5 r^near + 0.2 + 0.3 r^foot
    r = 0.5 * r_near + 0.2 * r_far if _dist2d(obj_pos, root) > 0.7 else 0.5 * r_near + 0.2 + 0.3 * r_foot
    return np.array([r_near, r_far, r_foot, 0.0, r])


def carry_reward(root, prev_root, obj, prev_obj, hands, target):
    """[r^c_walk, r^c_carry, r^c_pick, r^c_put, box-speed penalty, r^c] of the carrying task
    (InterPhys's multi-stage reward; the penalty is the released code's, not the text's: 0 here). ``hands``: the two hands' positions; ``target``: the box's 3-D target location."""
    root, obj, target = (np.asarray(x, dtype=np.float64) for x in (root, obj, target))
    # Eq. (9): 0.2 if ‖x^obj_2d − x^root_2d‖ < 0.5, else 0.2 exp(−5.0 ‖1.5 − d*·ẋ^root_2d‖²), d*: root → object
    if _dist2d(obj, root) < 0.5:
        r_walk = 0.2
    else:
        r_walk = 0.2 * math.exp(-5.0 * (1.5 - _unit2d(root, obj) @ _vel2d(root, prev_root)) ** 2)
    # Eq. (12): r^near = exp(−10.0 ‖x^tar − x^obj‖²)
    r_near = math.exp(-10.0 * float(np.sum((target - obj) ** 2)))
    # Eq. (11): r^far = exp(−5.0 ‖1.5 − d#·ẋ^obj_2d‖²), d#: object → target
    r_far = math.exp(-5.0 * (1.5 - _unit2d(obj, target) @ _vel2d(obj, prev_obj)) ** 2)
    # Eq. (10): 0.2 r^near + 0.2 r^far if ‖x^obj_2d − x^tar_2d‖ > 0.5, else 0.2 r^near + 0.2
    r_carry = 0.2 * r_near + 0.2 * r_far if _dist2d(obj, target) > 0.5 else 0.2 * r_near + 0.2
    # Eq. (13): 0 if ‖x^obj_2d − x^root_2d‖ > 0.7, else 0.2 exp(−5.0 ‖x^obj − x^hand‖²), x^hand = mean of the hands
    hand = np.mean(np.asarray(hands, dtype=np.float64), axis=0)
    r_pick = 0.0 if _dist2d(obj, root) > 0.7 else 0.2 * math.exp(-5.0 * float(np.sum((obj - hand) ** 2)))
    # Eq. (14): 0 if ‖x^obj_2d − x^tar_2d‖ > 0.1, else 0.2 exp(−10.0 ‖x^obj_h − x^tar_h‖²)
    r_put = 0.0 if _dist2d(obj, target) > 0.1 else 0.2 * math.exp(-10.0 * (obj[2] - target[2]) ** 2)
    # Eq. (15): r^c = r^c_walk + r^c_carry + r^c_pick + r^c_put
    return np.array([r_walk, r_carry, r_pick, r_put, 0.0, r_walk + r_carry + r_pick + r_put])
