"""Pure-numpy reference of the high-level (HLC) tasks: heading, circling, throwing, scoring, and
ModSkill's steering and reach (written from seed 001's supplementary "Steering" and "Reach" and
the tasks' documented choices: a bounded velocity-error reward, the command turned into the heading
frame; the hand = the base of the right middle finger).

Written independently from the task description of the reference facts (section 8) and the
skill observation of ``reference_env`` (section 4.1). Like ``reference_env`` it only reads a
state extracted from a PyPI ``mujoco.MjData`` of the project's scene (``reference_env.extract_state``)
and never steps physics, so a test can drive the Rust environment and this file from the same
MuJoCo state.

Conventions: world frame z-up, metres, float64 maths; "root" = skeleton body 0 (the pelvis), the
ball = state index ``BALL``; linear velocities are the centre-of-mass velocities of
``extract_state`` (the same definition the skill observation uses); the ball's contact force is
its net contact force of ``extract_state`` (sum over its contacts, world frame, last sub-step).

Per-environment bookkeeping (goal, latches, low-level step counter) lives in ``HLCReference``;
one call of ``HLCReference.step`` = one low-level (simulation-policy) step.
"""

from __future__ import annotations

import math

import numpy as np

import reference_env as ref
from reference_common import BALL, heading_inverse_matrix

STATE_OBS = 838                       # skill observation without the 64-wide one-hot
TASKS = ("heading", "circling", "throwing", "scoring")
TASK_OBS = {"heading": 4, "circling": 5, "throwing": 0, "scoring": 5, "steering": 3, "reach": 3}
TERM_NAMES = {
    "heading": ["heading"],
    "circling": ["ring", "speed_gate", "circling"],
    "throwing": ["throwing"],
    "scoring": ["speed_gate", "basket", "bonus", "height", "scoring"],
    "steering": ["steering"],
    "reach": ["reach"],
}
STEERING_ERROR_SCALE = 0.25
REACH_SCALE = 5.0
REACH_HAND = 41                       # R_Middle1 in skeleton order (R_Wrist 37, R_Index1-3 38-40)
GRAVITY = 9.8

# defaults of the facts (section 8)
HEADING_TARGET_Z = 1.0
BASKET_Z = 2.5
THROW_TARGET_Z = 2.5
REACH_HEIGHT = 2.0
REACH_RADIUS = 0.3
CONTACT_FORCE = 0.1
SPEED_THRESHOLD = 0.5
SLOW_FACTOR = 0.1
TERMINATION_HEIGHT = 0.25
EPISODE_STEPS = 799                   # truncation after this many low-level steps


# ---------------------------------------------------------------------------
# Observation
# ---------------------------------------------------------------------------

def state_observation(state):
    """The 838 state entries of the skill observation (float64 copy of reference_env's float32)."""
    return ref.observation(state, 0)[:STATE_OBS].astype(np.float64)


def loc_bearing(state, goal_xy):
    """(loc, bearing): goal − root in the heading frame (xy), and (cos θ, sin θ) of the world-frame
    direction root → goal."""
    root = state["body_pos"][0]
    dx, dy = float(goal_xy[0]) - root[0], float(goal_xy[1]) - root[1]
    hinv = heading_inverse_matrix(state["body_quat"][0])
    loc = (hinv @ np.array([dx, dy, 0.0]))[:2]
    theta = math.atan2(dy, dx)
    return loc, np.array([math.cos(theta), math.sin(theta)])


def task_observation(task, state, goal, reached=False):
    """Task part of the HL observation. ``goal``: heading/scoring (gx, gy), circling (cx, cy, r),
    steering (world direction x, y, speed m/s)."""
    if task == "throwing":
        return np.zeros(0)
    if task == "reach":
        hinv = heading_inverse_matrix(state["body_quat"][0])
        return hinv @ (np.asarray(goal[:3], np.float64) - state["body_pos"][0])
    if task == "steering":
        hinv = heading_inverse_matrix(state["body_quat"][0])
        d = hinv @ np.array([float(goal[0]), float(goal[1]), 0.0])
        return np.array([d[0], d[1], float(goal[2])])
    loc, bearing = loc_bearing(state, goal[:2])
    if task == "heading":
        return np.concatenate([loc, bearing])
    if task == "circling":
        return np.concatenate([loc, bearing, [float(goal[2])]])
    if task == "scoring":
        return np.concatenate([loc, bearing, [1.0 if reached else 0.0]])
    raise ValueError(f"unknown task {task!r}")


def observation(task, state, goal, reached=False):
    """Full HL observation: 838 state entries then the task part (float32 like the env)."""
    obs = np.concatenate([state_observation(state), task_observation(task, state, goal, reached)])
    assert obs.shape == (STATE_OBS + TASK_OBS[task],)
    return obs.astype(np.float32)


# ---------------------------------------------------------------------------
# Rewards (each returns the list of terms, the last one being the task reward)
# ---------------------------------------------------------------------------

def _ball(state):
    return state["body_pos"][BALL], state["body_linvel"][BALL]


def steering_terms(state, goal, k=STEERING_ERROR_SCALE):
    """[exp(-k |speed * dir - v_root,xy|^2)]: the commanded planar velocity against the pelvis's
    centre-of-mass velocity (world)."""
    want = float(goal[2]) * np.array([float(goal[0]), float(goal[1])])
    err = want - state["body_linvel"][0][:2]
    return [math.exp(-k * float(err @ err))]


def reach_terms(state, goal, k=REACH_SCALE):
    """[exp(-k |p_hand - c|^2)] with c = (target_x, target_y, target_z) (world, m)."""
    d = state["body_pos"][REACH_HAND] - np.asarray(goal[:3], np.float64)
    return [math.exp(-k * float(d @ d))]


def heading_terms(state, goal, mode="code"):
    """exp(−‖ball − (gx, gy, 1)‖) (code) or exp(−‖ball − (gx, gy, 1)‖²) (paper)."""
    ball, _ = _ball(state)
    dist = float(np.linalg.norm(ball - np.array([goal[0], goal[1], HEADING_TARGET_Z])))
    r = math.exp(-dist) if mode == "code" else math.exp(-dist * dist)
    return [r]


def circling_terms(state, goal, mode="code"):
    """[ring, speed_gate, ring·gate]; d = ‖ball_xy − centre‖, v = ‖ball velocity‖ (3D).

    code: ring = exp(−|d − r|), gate = 1 if v ≥ 0.5 else 0.1;
    paper: ring = exp(−|d² − r|), gate = 1 if v² > 0.5 else 0.1."""
    ball, vel = _ball(state)
    d = math.hypot(ball[0] - goal[0], ball[1] - goal[1])
    v = float(np.linalg.norm(vel))
    radius = float(goal[2])
    if mode == "code":
        ring = math.exp(-abs(d - radius))
        gate = 1.0 if v >= SPEED_THRESHOLD else SLOW_FACTOR
    else:
        ring = math.exp(-abs(d * d - radius))
        gate = 1.0 if v * v > SPEED_THRESHOLD else SLOW_FACTOR
    return [ring, gate, ring * gate]


def throwing_terms(state):
    """exp(−|z_ball − 2.5|)."""
    ball, _ = _ball(state)
    return [math.exp(-abs(ball[2] - THROW_TARGET_Z))]


def scoring_terms(state, goal, reached, scored, mode="code"):
    """[speed_gate, basket, bonus, height, total]; total = gate·(basket + bonus + 0.2·height).

    code: gate on the root speed (‖v_root‖ ≥ 0.5), basket = exp(−0.5‖ball − B‖), bonus = reached;
    paper: gate on the ball speed (‖v_ball‖² > 0.5), basket = exp(−‖ball − B‖²), bonus = scored.
    height = exp(−|z_ball − 2.5|) in both."""
    ball, vel = _ball(state)
    dist = float(np.linalg.norm(ball - np.array([goal[0], goal[1], BASKET_Z])))
    height = math.exp(-abs(ball[2] - BASKET_Z))
    if mode == "code":
        speed = float(np.linalg.norm(state["body_linvel"][0]))
        gate = 1.0 if speed >= SPEED_THRESHOLD else SLOW_FACTOR
        basket = math.exp(-0.5 * dist)
        bonus = 1.0 if reached else 0.0
    else:
        speed2 = float(np.dot(vel, vel))
        gate = 1.0 if speed2 > SPEED_THRESHOLD else SLOW_FACTOR
        basket = math.exp(-dist * dist)
        bonus = 1.0 if scored else 0.0
    return [gate, basket, bonus, height, gate * (basket + bonus + 0.2 * height)]


# ---------------------------------------------------------------------------
# Scoring latches
# ---------------------------------------------------------------------------

def predict_crossing(pos, vel, mode="code", h=REACH_HEIGHT, g=GRAVITY):
    """Predicted xy where the ball crosses height ``h`` (None when there is none).

    code (as in the reference code): if the apex z + v_z²/(2g) is below h, h becomes 0; then
    t = (sqrt(v_z² + 2g(z − h)) − v_z)/g.
    ballistic: no crossing when the apex is below h; else the descending crossing
    t = (v_z + sqrt(v_z² + 2g(z − h)))/g."""
    x, y, z = (float(c) for c in pos)
    vx, vy, vz = (float(c) for c in vel)
    apex = z + vz * vz / (2.0 * g)
    if mode == "code":
        if apex < h:
            h = 0.0
        t = (math.sqrt(max(vz * vz + 2.0 * g * (z - h), 0.0)) - vz) / g
    elif mode == "ballistic":
        if apex < h:
            return None
        t = (vz + math.sqrt(max(vz * vz + 2.0 * g * (z - h), 0.0))) / g
    else:
        raise ValueError(f"unknown prediction mode {mode!r}")
    return np.array([x + vx * t, y + vy * t])


def ball_touches_nothing(state):
    """True when every component of the ball's net contact force is ≤ 0.1 N in magnitude."""
    return bool(np.all(np.abs(state["contact_force"][BALL]) <= CONTACT_FORCE))


def reached_check(state, goal, prediction="code"):
    """One evaluation of the 'reached' condition (ball high, free, predicted landing on the goal)."""
    ball, vel = _ball(state)
    if not (ball[2] > REACH_HEIGHT and ball_touches_nothing(state)):
        return False
    xy = predict_crossing(ball, vel, prediction)
    if xy is None:
        return False
    return bool(np.hypot(xy[0] - goal[0], xy[1] - goal[1]) < REACH_RADIUS)


def scored_check(state, goal):
    """Paper bonus condition: ball above 2.5 m and within 0.3 m (3D) of the basket point."""
    ball, _ = _ball(state)
    dist = float(np.linalg.norm(ball - np.array([goal[0], goal[1], BASKET_Z])))
    return bool(ball[2] > BASKET_Z and dist < REACH_RADIUS)


# ---------------------------------------------------------------------------
# Per-environment episode bookkeeping
# ---------------------------------------------------------------------------

class HLCReference:
    """One environment of a HL task: goal, latches, step counter, observation and reward.

    ``options``: ``reward`` ("code"/"paper", heading/circling/scoring), ``prediction``
    ("code"/"ballistic", scoring) and ``timing``: "released" — the released loop computes an
    episode's first observation before it draws the new goal and clears the latches, so that
    observation shows the previous episode's goal and "reached" flag (the first episode: a zero
    goal), and after every step it observes before the reward updates the latches; "cut" — the
    new goal at once, and the latches of the step itself."""

    def __init__(self, task, reward="code", prediction="code", timing="released"):
        if task not in TASKS:
            raise ValueError(f"unknown task {task!r}")
        if timing not in ("released", "cut"):
            raise ValueError(f"unknown timing {timing!r}")
        self.task, self.reward, self.prediction, self.timing = task, reward, prediction, timing
        self.goal = np.zeros(3)
        self.reached = self.scored = False
        self.progress = 0
        self.shown = None

    def reset(self, goal):
        """New episode with ``goal`` (a row of the env's task_info); latches and counter cleared."""
        if self.timing == "released":
            self.shown = (self.goal, self.reached)
        self.goal = np.asarray(goal, dtype=np.float64).copy()
        self.reached = self.scored = False
        self.progress = 0

    def observe(self, state):
        goal, reached = self.shown if self.shown is not None else (self.goal, self.reached)
        return observation(self.task, state, goal, reached)

    def terms(self, state):
        if self.task == "heading":
            return heading_terms(state, self.goal, self.reward)
        if self.task == "circling":
            return circling_terms(state, self.goal, self.reward)
        if self.task == "throwing":
            return throwing_terms(state)
        return scoring_terms(state, self.goal, self.reached, self.scored, self.reward)

    def step(self, state):
        """After one low-level step (``state`` = post-step): update latches, then return
        (obs, terms, terminated, truncated)."""
        self.progress += 1
        self.shown = None
        before = self.observe(state) if self.timing == "released" else None
        if self.task == "scoring":
            if not self.reached:
                self.reached = reached_check(state, self.goal, self.prediction)
            if not self.scored:
                self.scored = scored_check(state, self.goal)
        terms = np.array(self.terms(state))
        terminated = bool(state["body_pos"][0][2] < TERMINATION_HEIGHT and self.progress > 1)
        truncated = bool(not terminated and self.progress >= EPISODE_STEPS)
        obs = before if before is not None else self.observe(state)
        return obs, terms, terminated, truncated
