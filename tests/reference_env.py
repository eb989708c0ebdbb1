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

Layout
------
* ``reference_common``: constants, conventions and quaternion / rotation helpers.
* ``reference_reward``: HOI states, contact graph, reward terms, frame metrics.
* this module: clip loading and derived reference, state extraction from
  MuJoCo, the observation and the reference-state initialisation.  It
  re-exports every public name of the two modules above, so
  ``import reference_env as R`` reaches the whole reference
  (imports go one way: common <- reward <- env).

Dependencies: numpy, mujoco, safetensors, zipfile, math.
"""

from __future__ import annotations

import os
import zipfile

import mujoco
import numpy as np

# Re-exported: the whole reference is reachable as ``reference_env.<name>``.
from reference_common import *  # noqa: F401,F403
from reference_reward import *  # noqa: F401,F403
from reference_common import (
    BALL,
    COND_SIZE,
    DEFAULT_FPS,
    FINGERTIPS,
    FOOT_BODIES,
    HAND_BODIES,
    KEY_BODIES,
    NUM_BODIES,
    NUM_DOF,
    NUM_JOINTS,
    NUM_STATE_BODIES,
    OBS_SIZE,
    PAIR_NAMES,
    PART_BALL,
    PART_FLOOR,
    PART_FOOT,
    PART_HAND,
    PART_TRUNK,
    PT_NUM_COLUMNS,
    backward_diff,
    heading_inverse_matrix,
    local_angular_velocity,
    quat_normalize,
    quat_sign_continuity,
    quat_to_mat,
    quat_to_rotvec,
    rotvec_to_quat,
    tan_norm,
)

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
    """Id of the joint whose ``qpos``/``qvel`` block is the body's free-body state (position,
    quaternion wxyz / world linear velocity, local angular velocity): a single free joint (the
    root), or, for the ball, three world-axis slide joints (absolute positions through their
    ``ref``) followed by a ball joint — the layout of a free joint, with separate linear and
    angular damping (MuJoCo's free joint has one damping for all six dofs)."""
    jid = int(m.body_jntadr[body])
    n = int(m.body_jntnum[body])
    J = mujoco.mjtJoint
    if n == 1 and m.jnt_type[jid] == J.mjJNT_FREE:
        return jid
    slides_then_ball = n == 4 and all(m.jnt_type[jid + k] == J.mjJNT_SLIDE for k in range(3)) and m.jnt_type[jid + 3] == J.mjJNT_BALL
    if slides_then_ball and all(np.array_equal(m.jnt_axis[jid + k], np.eye(3)[k]) for k in range(3)):
        return jid
    raise ValueError(f"body {body} has neither a free joint nor x/y/z slides + a ball joint")


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

    Conventions (reference-facts §1.5, §6.1; where the facts leave a choice,
    the one named here):

    * every velocity is the *backward* difference of frames t-1 and t times
      the clip's fps, and 0 at frame 0 (``derive_reference``);
    * the root angular velocity is rotvec(conj(q[t-1]) ⊗ q[t]) · fps, a
      body-frame vector, which is exactly what MuJoCo's free-joint qvel[3:6]
      holds (the original writes this body-frame value into Isaac Gym's
      world-frame slot; in MuJoCo no frame change is needed);
    * the root quaternion of a ``.pt`` clip is exp(root exp map) after the
      sign-continuity pass of ``load_clip``; joint quaternions are
      exp(dof triple) with w >= 0, unnormalised beyond float64 rounding;
    * derived velocities are stored as float32 (like the project) before use;
    * the ball keeps the clip's orientation (identity in every shipped clip,
      where the facts say "identity rotation").  For clips without a ball
      (labels 0 and 10) the environment places the ball at random: only the
      humanoid part of the result applies there.
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
