"""More checks of the skill-composition tasks (``hsi_follow_carry``, ``hsi_sit_carry``,
``hsi_climb_carry``; TokenHSI supplementary §B.3) beyond ``test_hsi_compose.py``:

* over many resets the box never starts on the character (2-D distance 0.55 m);
* sit / climb: the box never starts inside the seat / platform (MuJoCo contacts between the box
  and the primary object, the object put where the task information says);
* sit / climb: the interaction early termination (truncation once ``iet_steps`` − 1 steps, counted
  over the episode as released, were within ``success_distance`` of the target) and the
  composition's success (the primary's success — within the distance at some step, as released —
  AND the box within 0.7 m, 2-D), with the character staged at the target and the box on
  both sides of 0.7 m (``iet_steps`` / ``success_distance`` configured so that a few steps reach
  them).
"""

from __future__ import annotations

import math
from collections import Counter

import mujoco
import numpy as np
import pytest

import reference_hsi as R
from test_hsi_compose import (RADIUS, SPECS, TASKS, MaxDiff, Goal, check_obs, free_adr, goal_of, load, make_env,
                              models_of, reference_terms)


@pytest.mark.parametrize("task", TASKS)
def test_box_never_starts_on_the_character(task):
    """The box starts 0.55 m from the root (compose.rs, WithBox::plan): along the path's first
    move (follow; the path may start at rest), towards the target (sit / climb), never inside the
    character."""
    n, seeds = 16, range(60)
    env = make_env(task, num_envs=n)
    m = mujoco.MjModel.from_xml_string(env.mjcf_xml_of(0))
    ra, _ = free_adr(m, "root")
    ba, _ = free_adr(m, "box")
    names = env.task_info_names
    bad, still, dmin, dmax = [], 0, np.inf, 0.0
    for seed in seeds:
        env.reset(seed=seed)
        info = env.task_info()
        for i in range(n):
            q, _ = env.get_state(i)
            g = Goal(task, names, info[i])
            if task == "hsi_follow_carry":
                still += np.linalg.norm(g.waypoints[1] - g.waypoints[0]) < 1e-9
            dist = math.hypot(*(q[ba:ba + 2] - q[ra:ra + 2]))
            dmin, dmax = min(dmin, dist), max(dmax, dist)
            if dist < 0.3 or dist > RADIUS:
                bad.append((seed, i, round(dist, 4)))
    env.close()
    rest = f" ({still} with the path at rest at its start)" if task == "hsi_follow_carry" else ""
    print(f"\n{task} resets: {len(seeds) * n} episodes{rest}; box–root 2-D distance in [{dmin:.4f}, {dmax:.4f}] m")
    assert not bad, f"the box starts < 0.3 m (on the character) or > 0.7 m (reward dead) from the root: (seed, env, distance) {bad[:6]}"


def put_objects(m, d, names, row, obj):
    """Put the static (mocap) primary object where the task information says (the state that
    get_state returns holds the movable bodies only)."""
    g = dict(zip(names, row))
    mid = m.body_mocapid[m.body(obj).id]
    assert mid >= 0, f"{obj} is a mocap body"
    d.mocap_pos[mid] = [g["object_x"], g["object_y"], g["object_z"]]
    d.mocap_quat[mid] = [math.cos(g["object_yaw"] / 2), 0.0, 0.0, math.sin(g["object_yaw"] / 2)]
    mujoco.mj_forward(m, d)


@pytest.mark.parametrize("task", ["hsi_sit_carry", "hsi_climb_carry"])
def test_box_never_starts_inside_the_primary_object(task):
    """At a reset the box rests on its support 0.55 m from the root towards the target unless that
    would touch the seat / platform (1–5 m from the root, half extents up to 0.3 / 0.6 m + a
    backrest), then left, right or behind. The box must not start penetrating the object (MuJoCo
    contacts between the box's and the object's geoms deeper than 1 mm)."""
    obj = SPECS[task].obj
    n, seeds = 16, range(20)
    env = make_env(task, num_envs=n)
    models, _ = models_of(env)
    names = env.task_info_names
    bad, total, moved = [], 0, []
    for seed in seeds:
        env.reset(seed=seed)
        info = env.task_info()
        states = [env.get_state(i) for i in range(n)]
        hits = {}
        for i in range(n):
            m = models[i]
            d = load(m, *states[i])
            put_objects(m, d, names, info[i], obj)
            bb, ob = m.body("box").id, m.body(obj).id
            depth = [d.contact[k].dist for k in range(d.ncon)
                     if {int(m.geom_bodyid[d.contact[k].geom1]), int(m.geom_bodyid[d.contact[k].geom2])} == {bb, ob}]
            total += 1
            if depth and min(depth) < -1e-3:
                hits[i] = R.body_pos(m, d, "box")
                bad.append((seed, i, round(-min(depth), 3)))
        if hits:
            # what the penetration does: the box is pushed out in the first step
            env.step(np.zeros(env.action_space.shape, np.float32))
            for i, before in hits.items():
                after = R.body_pos(models[i], load(models[i], *env.get_state(i)), "box")
                moved.append(float(np.linalg.norm(after - before)))
    env.close()
    worst = max((b[2] for b in bad), default=0.0)
    print(f"\n{task}: {len(bad)} of {total} resets start the box inside the {obj} (deepest {worst:.3f} m; "
          f"the box then moves up to {max(moved, default=0.0):.3f} m in the first step)")
    assert not bad, (
        f"the box starts inside the {obj} in {len(bad)} of {total} resets, up to {worst:.3f} m "
        f"deep, and is ejected (up to {max(moved, default=0.0):.3f} m) in the first step; (seed, env, depth m): {bad[:6]}")


@pytest.mark.parametrize("task", ["hsi_sit_carry", "hsi_climb_carry"])
def test_interaction_early_termination_and_success(task):
    s = SPECS[task]
    key = "sit" if task == "hsi_sit_carry" else "climb"
    # the character stands on the top (root 0.93 m above it): 0.83 m below the sit target, 0.01 m
    # below the climb target; these success distances put the first two environments within it
    iet, sd = 4, (0.95 if key == "sit" else 0.35)
    env = make_env(task, **{key: {"iet_steps": iet, "success_distance": sd}})
    models, _ = models_of(env)
    names = env.task_info_names
    mx, cases = MaxDiff(), Counter()
    for seed in (41, 42):
        env.reset(seed=seed)
        info = env.task_info()
        goals, prev_root = [], []
        for i in range(env.num_envs):
            m = models[i]
            q, v = env.get_state(i)
            q, v = q.copy(), np.zeros_like(v)
            g = goal_of(task, m, names, info[i], mx)
            target, rot = g.static[0], g.static[1]
            front = rot[:, 0]
            ra, _ = free_adr(m, "root")
            ba, _ = free_adr(m, "box")
            # character: at the target, 0.3 m in front of it, 0.55 m, 1.5 m; box: near, far, near, far
            q[ra:ra + 3] = target + [0.0, 0.3, 0.55, 1.5][i] * front
            q[ra + 2] = target[2] - s.above + 0.93
            q[ba:ba + 3] = q[ra:ra + 3] + [0.5, 1.0, 0.5, 1.0][i] * front
            q[ba + 2] = target[2] - s.above + g.half[2] + 0.02
            obs = env.set_state(i, q, v)
            d = load(m, q, v)
            check_obs(task, m, d, obs[i], g, mx, f"(seed {seed}, staged env {i})")
            goals.append(g)
            prev_root.append(R.root_pose(m, d)[0])
        done = np.zeros(env.num_envs, bool)
        steps, near_steps = np.zeros(env.num_envs, int), np.zeros(env.num_envs, int)
        reached = np.zeros(env.num_envs, bool)
        for _ in range(2 * iet):
            obs, rew, term, trunc, info = env.step(np.zeros(env.action_space.shape, np.float32))
            for i in np.flatnonzero(~done):
                steps[i] += 1
                m = models[i]
                d = load(m, *env.get_state(i))
                g = goals[i]
                where = f"(seed {seed}, env {i}, step {steps[i]})"
                want, near, root, box, err = reference_terms(task, m, d, g, prev_root[i])
                mx.check("reward terms", info["reward_terms"][i], want, where)
                mx.check("reward", rew[i], want[-1], where)
                near_steps[i] += err <= sd
                ends = near_steps[i] >= iet - 1 and not term[i]
                assert trunc[i] == ends, f"interaction early termination: truncated {trunc[i]}, {near_steps[i]} steps within {sd} m {where}"
                cases["truncated (interaction early termination)"] += ends
                reached[i] |= err <= sd
                primary = bool(reached[i])
                success = primary and near
                mx.check("metrics [error_m, success]", info["frame_metrics"][i][:2], [err, float(success)], where)
                cases[f"primary success {primary}, box {'near' if near else 'far'}"] += 1
                if not (term[i] or trunc[i]):
                    check_obs(task, m, d, obs[i], g, mx, where)
                prev_root[i] = root
                done[i] = term[i] or trunc[i]
    env.close()
    mx.report(f"{task} (iet_steps {iet}, success_distance {sd})")
    print("    cases: " + ", ".join(f"{k} ×{v}" for k, v in sorted(cases.items())))
    for c in ("truncated (interaction early termination)", "primary success True, box near", "primary success True, box far",
              "primary success False, box near"):
        assert cases[c] > 0, f"never reached: {c}"
