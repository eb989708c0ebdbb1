"""The four TokenHSI foundational tasks (``hsi_follow``, ``hsi_sit``, ``hsi_climb``, ``hsi_carry``)
against ``reference_hsi``, an independent numpy statement of the supplementary's equations (§A
proprioception, §B.2 Eqs. 1-15) written from the paper, not from the Rust code.

For each task, 4 environments (2 object variants) are reset and stepped with random actions (one
rollout from the start, two from "staged" states that move the character or the box to both sides
of every distance case of the piecewise rewards and beyond the path distance); after the reset and
after every step, each environment's state (``get_state``) is put into PyPI mujoco
with its own scene (``mjcf_xml_of``), and the 222-d proprioception, the task observation, the
reward terms, the reward and the metrics computed here must equal the Rust ones to 1e-5. The
goals the task information reports are checked against the scene's geometry where the paper fixes
them (sit / climb targets above the seat / top, bounding boxes, the box's size), the follow
waypoints against themselves over time (0.1 s = 3 policy steps, in the supplementary's form of the
observation), and the proprioception's groups separately, plus its invariance to a rotation of the
world about +z.

The environments run with the power penalty off (``power_coefficient = 0``: the drive torques it
needs are not part of the state this test reads) and the follow observation in the
supplementary's form (waypoints 0.1 s apart). What the released code does differently — the
trajectory's interpolation, the power penalty, the fall rule, the success rule — is checked against
the released functions themselves (crates/skillmimic-env/tests/hsi_released_follow.rs and its
golden fixture).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import reference_hsi as R
import skillmimic_rs
from reference_common import quat_mul, quat_to_mat, tan_norm

TASKS = ["hsi_follow", "hsi_sit", "hsi_climb", "hsi_carry"]
# each task's own terms, then the shared power penalty and the total reward
TERM_NAMES = {
    "hsi_follow": ["follow", "power", "total_reward"],
    "hsi_sit": ["near", "far", "speed", "turn", "sit", "power", "total_reward"],
    "hsi_climb": ["near", "far", "foot", "speed", "climb", "power", "total_reward"],
    "hsi_carry": ["walk", "carry", "pick", "put", "box_speed", "total", "power", "total_reward"],
}
# Tab. A: episode lengths 10 s (carry 20 s) at 30 Hz
EPISODE_STEPS = {"hsi_follow": 300, "hsi_sit": 300, "hsi_climb": 300, "hsi_carry": 600}
OBJECT = {"hsi_sit": "seat", "hsi_climb": "platform", "hsi_carry": "box"}
ABOVE = {"hsi_sit": R.SIT_TARGET_ABOVE_SEAT, "hsi_climb": R.CLIMB_TARGET_ABOVE_TOP}
NUM_ENVS, STEPS = 4, 40
FOLLOW_FAIL, FOLLOW_SUCCESS_STEP = 4.0, 294   # [env.hsi.follow] defaults: success is judged from 0.98 x 300 steps on
IET_DISTANCE, IET_STEPS, SUCCESS_DISTANCE = 0.2, 60, 0.2          # facts §2.2; the IET ends at 59 steps, as released
CARRY_DROP = 0.05                                                  # [env.hsi.carry] drop_height
TOL = dict(rtol=1e-5, atol=1e-5)


class MaxDiff:
    """Largest |Rust − reference| per quantity."""

    def __init__(self):
        self.d: dict[str, float] = {}

    def check(self, what, got, want, msg=""):
        got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
        np.testing.assert_allclose(got, want, **TOL, err_msg=f"{what} {msg}")
        self.d[what] = max(self.d.get(what, 0.0), float(np.abs(got - want).max()) if got.size else 0.0)


def col(names, info_row, *keys):
    return np.array([info_row[names.index(k)] for k in keys], dtype=np.float64)


class Goal:
    """The episode's goal as the task information reports it (world)."""

    def __init__(self, task, names, row):
        self.task = task
        if task == "hsi_follow":
            self.waypoints = np.array([col(names, row, f"waypoint{k}_x", f"waypoint{k}_y") for k in range(R.NUM_WAYPOINTS)])
        elif task in ("hsi_sit", "hsi_climb"):
            self.target = col(names, row, "target_x", "target_y", "target_z")
            self.obj_pos = col(names, row, "object_x", "object_y", "object_z")
            self.yaw = float(row[names.index("object_yaw")])
            self.lo = col(names, row, "box_lo_x", "box_lo_y", "box_lo_z")
            self.hi = col(names, row, "box_hi_x", "box_hi_y", "box_hi_z")
        else:
            self.target = col(names, row, "target_x", "target_y", "target_z")
            self.start = col(names, row, "start_x", "start_y", "start_z")
            self.half = col(names, row, "half_x", "half_y", "half_z")


def load(m, qpos, qvel):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    return d


def check_static_goal(task, m, g, mx):
    """Sit / climb: the reported target and bounding box follow from the object's geometry in the
    scene (§B.2.2 / §B.2.3): the object stands on the floor; its target is 0.10 m (sit) / 0.94 m
    (climb) above the centre of the seat's / top's surface. Returns (target, bounds) computed here."""
    name = OBJECT[task]
    lo, hi = R.object_bounds(m, name)
    mx.check("object bounds (info vs MJCF)", np.concatenate([g.lo, g.hi]), np.concatenate([lo, hi]))
    assert abs(g.obj_pos[2]) < 1e-6 and abs(lo[2]) < 1e-6, "the object stands on the floor"
    rot = R.rot_z(g.yaw)
    target = g.obj_pos + rot @ R.top_target_local(m, name, ABOVE[task])
    mx.check("target (info vs geometry)", g.target, target)
    return target, rot, lo, hi


def task_obs(task, m, d, g, static):
    if task == "hsi_follow":
        return R.follow_obs(m, d, g.waypoints)
    if task == "hsi_carry":
        return R.carry_obs(m, d, g.target)
    target, rot, lo, hi = static
    if task == "hsi_sit":
        return R.sit_obs(m, d, target, g.obj_pos, rot, lo, hi)
    return R.climb_obs(m, d, target, g.obj_pos, rot, lo, hi)


def check_obs(task, m, d, obs_row, g, static, mx):
    groups = R.proprioception_groups(m, d)
    for k, sl in R.PROPRIO_SLICES.items():
        mx.check(f"proprio.{k}", obs_row[sl], np.ravel(groups[k]))
    mx.check("proprio", obs_row[:222], R.proprioception(m, d))
    mx.check("task obs", obs_row[222:], task_obs(task, m, d, g, static))


def rotated_state(m, qpos, qvel, yaw):
    """The same state with the whole world rotated by ``yaw`` about +z (free joints: position,
    orientation and world linear velocity rotate; their local angular velocity does not)."""
    q, v = qpos.copy(), qvel.copy()
    rz = R.rot_z(yaw)
    qz = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    for j in range(m.njnt):
        if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE:
            continue
        a, b = m.jnt_qposadr[j], m.jnt_dofadr[j]
        q[a:a + 3] = rz @ qpos[a:a + 3]
        q[a + 3:a + 7] = quat_mul(qz, qpos[a + 3:a + 7])
        v[b:b + 3] = rz @ qvel[b:b + 3]
    return q, v



def free_joint(m, name):
    j = m.joint(name).id
    assert m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    return int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])


def staged_state(task, i, stage, m, qpos, qvel, g, static):
    """A state that puts environment ``i`` where random rollouts from the start rarely go: on both
    sides of each distance case of the piecewise rewards, and beyond the path distance. The
    character is at rest, moved; ``stage`` 1 or 2 picks one of two sets of distances."""
    q, v = qpos.copy(), np.zeros_like(qvel)
    ra, _ = free_joint(m, "root")
    if task == "hsi_follow":
        # away from the path: beyond the 4 m path distance (envs 0, 2) or not
        q[ra + stage - 1] += [4.5, 3.5, 4.2, 3.8][i]
    elif task in ("hsi_sit", "hsi_climb"):
        # standing on (or dropped beside) the seat / platform at the height of its top, at these
        # distances from the object's origin: either side of 0.5 m (Eq. 2) and 0.7 m (Eq. 5)
        off = [[0.0, 0.3, 0.55, 0.75], [0.45, 0.52, 0.65, 0.72]][stage - 1][i]
        target = static[0]
        top = target[2] - ABOVE[task]
        q[ra:ra + 3] = [target[0] + off, target[1], top + 0.93]
    else:
        ba, _ = free_joint(m, "box")
        x_axis = quat_to_mat(qpos[ra + 3:ra + 7])[:, 0]
        fwd = np.array([x_axis[0], x_axis[1], 0.0]) / math.hypot(x_axis[0], x_axis[1])
        # in front of the character at hip height, at these distances: either side of 0.5 m
        # (Eq. 9), inside 0.7 m (Eq. 13)
        front = {(1, 0): 0.4, (1, 2): 0.6, (2, 0): 0.53, (2, 2): 0.68}
        # near its target: either side of 0.1 m (Eq. 14) and of 0.5 m (Eq. 10); lifted 0.35 m
        # above the target (Eq. 14's height term)
        at_target = {(1, 1): [0.04, -0.03, 0.003], (1, 3): [0.12, 0.05, 0.003], (2, 1): [0.03, 0.02, 0.35], (2, 3): [0.55, 0.0, 0.003]}
        if (stage, i) in front:
            q[ba:ba + 3] = qpos[ra:ra + 3] + front[stage, i] * fwd + [0.0, 0.0, 0.1]
        else:
            q[ba:ba + 3] = g.target + at_target[stage, i]
    return q, v


def branches(task, root, g, static, obj=None):
    """The case of each piecewise reward (Eqs. 2, 5, 9, 10, 13, 14) this state falls in."""
    dist = lambda a, b: math.hypot(a[0] - b[0], a[1] - b[1])  # noqa: E731
    if task == "hsi_sit":
        return [f"Eq.2 {'far' if dist(g.obj_pos, root) > 0.5 else 'near'}"]
    if task == "hsi_climb":
        return [f"Eq.5 {'far' if dist(g.obj_pos, root) > 0.7 else 'near'}"]
    if task == "hsi_carry":
        return [f"Eq.9 {'near' if dist(obj, root) < 0.5 else 'far'}", f"Eq.10 {'far' if dist(obj, g.target) > 0.5 else 'near'}",
                f"Eq.13 {'off' if dist(obj, root) > 0.7 else 'on'}", f"Eq.14 {'off' if dist(obj, g.target) > 0.1 else 'on'}"]
    return ["Eq.1"]


def rollout(env, task, models, names, seed, staged, mx, cases):
    """Reset (then, if ``staged`` (1 or 2), move the environments with ``staged_state``) and step with random
    actions, checking every environment against the reference after each step until it ends."""
    obs, _ = env.reset(seed=seed)
    info = env.task_info()
    goals, statics, prev_root, prev_obj, waypoints = [], [], [], [], []
    for i in range(NUM_ENVS):
        m = models[i]
        qpos, qvel = env.get_state(i)
        d = load(m, qpos, qvel)
        g = Goal(task, names, info[i])
        static = check_static_goal(task, m, g, mx) if task in ("hsi_sit", "hsi_climb") else None
        if task == "hsi_carry":
            # the box (its size from the scene) starts 0.05 m above its platform (the released drop)
            mx.check("box half sizes (info vs MJCF)", g.half, R.object_bounds(m, "box")[1])
            np.testing.assert_allclose(R.body_pos(m, d, "box"), g.start + [0, 0, g.half[2] + CARRY_DROP], atol=2e-3)
        if task == "hsi_follow":
            # the trajectory starts at the character
            mx.check("first waypoint = start root", g.waypoints[0], R.root_pose(m, d)[0][:2])
        if staged:
            qpos, qvel = staged_state(task, i, staged, m, qpos, qvel, g, static)
            obs = env.set_state(i, qpos, qvel)
            d = load(m, qpos, qvel)
        waypoints.append([g.waypoints] if task == "hsi_follow" else None)
        check_obs(task, m, d, obs[i], g, static, mx)
        goals.append(g)
        statics.append(static)
        prev_root.append(R.root_pose(m, d)[0])
        prev_obj.append(R.body_pos(m, d, "box") if task == "hsi_carry" else None)

    rng = np.random.default_rng(seed)
    done = np.zeros(NUM_ENVS, bool)
    steps = np.zeros(NUM_ENVS, int)
    near = np.zeros(NUM_ENVS, int)        # sit / climb: steps within the IET distance (cumulative, as released)
    reached = np.zeros(NUM_ENVS, bool)    # success (the released evaluation): ever within the success distance
    checked = 0
    for _ in range(STEPS if not staged else STEPS // 2):
        a = (0.3 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
        obs, rew, term, trunc, info = env.step(a)
        for i in np.flatnonzero(~done):
            steps[i] += 1
            m = models[i]
            d = load(m, *env.get_state(i))
            root = R.root_pose(m, d)[0]
            g0 = goals[i]
            g = Goal(task, names, info["task_info"][i])
            box = None
            if task == "hsi_follow":
                waypoints[i].append(g.waypoints)
                want = R.follow_reward(root, g.waypoints[0])
                err = math.hypot(root[0] - g.waypoints[0][0], root[1] - g.waypoints[0][1])
                failed = err > FOLLOW_FAIL
                if failed:
                    assert term[i], f"path-distance termination (env {i}, distance {err:.3f} m)"
                    cases["path distance > 4 m: terminated"] += 1
                # success is judged from step 294 on only (the released evaluation)
                assert steps[i] < FOLLOW_SUCCESS_STEP
                success = False
                assert not trunc[i]
            elif task in ("hsi_sit", "hsi_climb"):
                for k in ("target", "obj_pos", "lo", "hi"):
                    np.testing.assert_array_equal(getattr(g, k), getattr(g0, k), err_msg="static goal")
                target = statics[i][0]
                if task == "hsi_sit":
                    want = R.sit_reward(root, prev_root[i], target, g0.obj_pos)
                else:
                    feet = [R.body_pos(m, d, f)[2] for f in R.FEET]
                    want = R.climb_reward(root, prev_root[i], feet, target, g0.obj_pos)
                err = float(np.linalg.norm(target - root))
                near[i] += err <= IET_DISTANCE
                assert trunc[i] == (near[i] >= IET_STEPS - 1 and not term[i]), "interaction early termination"
                reached[i] |= err <= SUCCESS_DISTANCE
                success = reached[i]
            else:
                box = R.body_pos(m, d, "box")
                hands = [R.body_pos(m, d, h) for h in R.HANDS]
                want = R.carry_reward(root, prev_root[i], box, prev_obj[i], hands, g0.target)
                err = float(np.linalg.norm(g0.target - box))
                reached[i] |= err <= SUCCESS_DISTANCE
                success = reached[i]
                prev_obj[i] = box
                assert not trunc[i]
            where = f"(env {i}, step {steps[i]}{', staged' if staged else ''})"
            # also the first step after set_state: its finite-difference velocities start from the
            # edited state (the environment takes the previous root/box positions anew)
            want = [*want, 0.0, want[-1]]  # power (off here), total
            mx.check("reward terms", info["reward_terms"][i], want, where)
            mx.check("reward", rew[i], want[-1], where)
            for c in branches(task, root, g0, statics[i], box):
                cases[c] += 1
            mx.check("metrics", info["frame_metrics"][i][:2], [err, float(success)], where)
            if not (term[i] or trunc[i]):
                check_obs(task, m, d, obs[i], g if task == "hsi_follow" else g0, statics[i], mx)
            prev_root[i] = root
            checked += 1
            done[i] = term[i] or trunc[i]

    if task == "hsi_follow":
        # x_{t+0.1} observed at step s is x_t observed at step s + 3 (0.1 s = 3 steps of 1/30 s)
        for w in waypoints:
            for s in range(len(w) - 3):
                mx.check("waypoint time consistency", w[s][1:], w[s + 3][:-1], f"(step {s})")
                cases["waypoint triples"] += 1
    return checked, int(done.sum())


# the cases of the piecewise rewards that the rollouts must reach
REQUIRED_CASES = {
    "hsi_follow": ["Eq.1", "path distance > 4 m: terminated", "waypoint triples"],
    "hsi_sit": ["Eq.2 far", "Eq.2 near"],
    "hsi_climb": ["Eq.5 far", "Eq.5 near"],
    "hsi_carry": ["Eq.9 near", "Eq.9 far", "Eq.10 near", "Eq.10 far", "Eq.13 on", "Eq.13 off", "Eq.14 on", "Eq.14 off"],
}


@pytest.mark.parametrize("task", TASKS)
def test_task_observation_and_reward_match_the_supplementary_equations(task):
    from collections import Counter

    env = skillmimic_rs.VecEnv(num_envs=NUM_ENVS, task=task, autoreset_mode="disabled", threads=1,
                               hsi={"object_variants": 2, "power_coefficient": 0.0, "form": "supplementary"})
    assert env.single_observation_space.shape == (222 + R.TASK_OBS_DIM[task],)
    assert env.reward_term_names == TERM_NAMES[task]
    assert env.max_episode_length == EPISODE_STEPS[task]
    assert env.frame_metric_names[:2] == ["error_m", "success"]
    names = env.task_info_names
    models, cache = [], {}
    for i in range(NUM_ENVS):
        xml = env.mjcf_xml_of(i)
        if xml not in cache:
            cache[xml] = mujoco.MjModel.from_xml_string(xml)
        models.append(cache[xml])
    assert len(cache) == 2 or task == "hsi_follow", "two object variants"
    mx, cases = MaxDiff(), Counter()

    checked, ended = 0, 0
    for seed, staged in ((11, 0), (12, 1), (13, 2)):
        c, e = rollout(env, task, models, names, seed, staged, mx, cases)
        checked, ended = checked + c, ended + e

    # the proprioception does not change when the world rotates about +z, except the root
    # rotation (world frame), which rotates with it
    m = models[0]
    qpos, qvel = env.get_state(0)
    before = env.set_state(0, qpos, qvel)[0]
    yaw = 0.9
    q2, v2 = rotated_state(m, qpos, qvel, yaw)
    after = env.set_state(0, q2, v2)[0]
    mx.check("proprio (rotated world)", after[:222], R.proprioception(m, load(m, q2, v2)))
    rz = R.rot_z(yaw)
    root_rot = tan_norm(rz @ np.stack([before[42:45], np.zeros(3), before[45:48]], axis=1))
    mx.check("rotation invariance: root rotation rotates", after[42:48], root_rot)
    keep = np.r_[0:42, 48:222]
    mx.check("rotation invariance: other groups", after[keep], before[keep])

    print(f"\n{task}: {checked} environment steps checked, {ended} episodes ended; max |Rust − reference|:")
    for k, v in mx.d.items():
        print(f"    {k:45s} {v:.3e}")
    print("    cases reached: " + ", ".join(f"{k} ×{v}" for k, v in sorted(cases.items())))
    missing = [c for c in REQUIRED_CASES[task] if cases[c] == 0]
    assert not missing, f"the rollouts never reached {missing}"
    assert checked >= 2 * STEPS
    env.close()
