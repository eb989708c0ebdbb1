"""Scoring part of the pure-numpy reference environment.

HOI states (simulated and reference), the contact graph (exact and
force-threshold modes), the imitation reward of every variant and the
per-frame metrics.  Works on plain dicts (an extracted state, a clip and its
derived reference); it never touches MuJoCo.  Depends only on
``reference_common``; ``reference_env`` re-exports everything here.
"""

from __future__ import annotations

import math

import numpy as np

from reference_common import (
    BALL,
    BALL_FREE_SKILLS,
    DEFAULT_WEIGHTS,
    KEY_BODIES,
    NUM_DOF,
    REFERENCE_BODY_NODE,
    REWARD_NAMES,
    VARIANTS,
    quat_angle,
    quat_normalize,
    quat_rotate,
    quat_to_rotvec,
)

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
