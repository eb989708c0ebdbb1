"""The multi-task environment (``hsi_multi``, ``[env.multi]``): the batch of a mix of tasks against
single-task environments seeded as the multi-task environment seeds its sub-batches
(``seed + first row``: row r of the batch draws from the stream ``seed + r``), stepped with the same actions: the observation layout [shared 222 | groups |
mask K], the rows, rewards, flags, terminal observations, the rescaled per-task terms, metrics and
task information; MuJoCo state access routed to each row's task; the split of the environments over
the mix (largest remainder, at least one each); named groups (extra groups zero, a composition task
activating several); the configuration errors.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import reference_hsi as R
import skillmimic_rs

PROPRIO = R.PROPRIO_DIM
TOL = dict(rtol=1e-5, atol=1e-5)


from test_hsi_compose import MaxDiff  # noqa: E402  (the shared max-difference recorder)

TASK_GROUPS = {
    "hsi_follow": [("hsi_follow", 20)],
    "hsi_sit": [("hsi_sit", 38)],
    "hsi_climb": [("hsi_climb", 27)],
    "hsi_carry": [("hsi_carry", 42)],
    "hsi_follow_carry": [("hsi_follow", 20), ("hsi_carry", 42), ("hsi_follow_carry", 59)],
}
HSI = {"object_variants": 2}


def split_reference(n, mix):
    """Largest remainder with at least one environment per task (ties: the earlier task)."""
    k = len(mix)
    w = np.asarray(mix, dtype=np.float64)
    exact = w / w.sum() * (n - k)
    counts = np.floor(exact).astype(int)
    rem = exact - counts
    order = sorted(range(k), key=lambda j: (-rem[j], j))
    for j in order[: (n - k) - counts.sum()]:
        counts[j] += 1
    return [int(c) + 1 for c in counts]


def layout(tasks, groups=None):
    """(group offsets by name, mask column, width) of [shared 222 | groups | mask K]."""
    if groups is None:
        groups = []
        for t in tasks:
            for name, _ in TASK_GROUPS[t]:
                if name not in groups:
                    groups.append(name)
    widths = {name: w for t in TASK_GROUPS.values() for name, w in t}
    at, offsets = PROPRIO, {}
    for name in groups:
        offsets[name] = (at, widths[name])
        at += widths[name]
    return groups, offsets, at, at + len(groups)


def mapped_row(task, single_row, groups, offsets, mask_at, width):
    """A single-task observation row laid out in the multi-task observation."""
    out = np.zeros(width, np.float32)
    out[:PROPRIO] = single_row[:PROPRIO]
    src = PROPRIO
    for name, w in TASK_GROUPS[task]:
        at, gw = offsets[name]
        assert gw == w
        out[at:at + w] = single_row[src:src + w]
        out[mask_at + groups.index(name)] = 1.0
        src += w
    assert src == single_row.shape[0]
    return out


def make(task, n, seed, mode="disabled", **kw):
    return skillmimic_rs.VecEnv(num_envs=n, task=task, autoreset_mode=mode, threads=1, seed=seed, hsi=HSI, **kw)


class MultiCheck:
    """A multi-task environment and the single-task environments of its sub-batches."""

    def __init__(self, tasks, mix, n, seed, mode="disabled", groups=None):
        multi = {"tasks": tasks, "mix": mix}
        if groups is not None:
            multi["groups"] = groups
        self.env = make("hsi_multi", n, seed, mode, multi=multi)
        self.tasks, self.n = tasks, n
        self.counts = split_reference(n, mix)
        self.starts = np.concatenate([[0], np.cumsum(self.counts)[:-1]]).astype(int)
        # sub-batch k: env.seed + its first row, its own number of environments
        self.singles = [make(t, c, seed + int(s0), mode) for t, c, s0 in zip(tasks, self.counts, self.starts)]
        self.groups, self.offsets, self.mask_at, self.width = layout(tasks, groups)
        self.mx = MaxDiff()
        self.ended = 0
        self.last = None  # the single-task environments' latest observations

    def rows(self, k):
        return slice(self.starts[k], self.starts[k] + self.counts[k])

    def check_spaces(self):
        e = self.env
        assert e.single_observation_space.shape == (self.width,), (e.single_observation_space.shape, self.width)
        assert e.action_space.shape == (self.n, 32)
        assert e.max_episode_length == max(s.max_episode_length for s in self.singles)
        terms, metrics, info = [], [], []
        for t, s in zip(self.tasks, self.singles):
            terms += [f"{t}/reward"] + [f"{t}/{x}" for x in s.reward_term_names]
            metrics += [f"{t}/{x}" for x in s.frame_metric_names]
            info += [f"{t}/{x}" for x in s.task_info_names]
        assert e.reward_term_names == terms
        assert e.frame_metric_names == metrics
        assert e.task_info_names == info

    def check_obs(self, obs, singles_obs, what):
        mx = self.mx
        m = obs[:, self.mask_at:]
        assert set(np.unique(m)) <= {0.0, 1.0}, "mask entries are 0/1"
        for k, (t, so) in enumerate(zip(self.tasks, singles_obs)):
            want = np.stack([mapped_row(t, r, self.groups, self.offsets, self.mask_at, self.width) for r in so])
            mx.check(f"{what} rows = single-task env mapped (exact)", obs[self.rows(k)], want, f"task {t}", exact=True)
            active = [self.groups.index(g) for g, _ in TASK_GROUPS[t]]
            assert (m[self.rows(k)][:, active] == 1).all()
            assert (np.delete(m[self.rows(k)], active, axis=1) == 0).all()
            # inactive groups are zero
            for g in self.groups:
                if g not in [x for x, _ in TASK_GROUPS[t]]:
                    at, w = self.offsets[g]
                    assert not obs[self.rows(k), at:at + w].any(), f"group {g} not zero on {t}'s rows"

    def reset(self, seed=None):
        obs, _ = self.env.reset(seed=seed)
        sobs = [s.reset(seed=None if seed is None else seed + int(s0))[0] for s, s0 in zip(self.singles, self.starts)]
        self.last = sobs
        self.check_obs(obs, sobs, "reset obs")

    def reset_mask(self, mask):
        obs, _ = self.env.reset(options={"reset_mask": mask})
        # a single-task environment refuses a mask that selects nothing: its rows stay as they are
        sobs = [s.reset(options={"reset_mask": mask[self.rows(k)]})[0] if mask[self.rows(k)].any() else self.last[k]
                for k, s in enumerate(self.singles)]
        self.last = sobs
        self.check_obs(obs, sobs, "reset_mask obs")

    def step(self, a):
        mx, e = self.mx, self.env
        obs, rew, term, trunc, info = e.step(a)
        outs = [s.step(a[self.rows(k)]) for k, s in enumerate(self.singles)]
        self.last = [o[0] for o in outs]
        self.check_obs(obs, [o[0] for o in outs], "step obs")
        nt_cols = 0
        nm_cols = 0
        ni_cols = 0
        for k, (t, s, (sobs, srew, sterm, strunc, sinfo)) in enumerate(zip(self.tasks, self.singles, outs)):
            r = self.rows(k)
            others = np.ones(self.n, bool)
            others[r] = False
            mx.check("reward (exact)", rew[r], srew, t, exact=True)
            np.testing.assert_array_equal(term[r], sterm, err_msg=f"terminated {t}")
            np.testing.assert_array_equal(trunc[r], strunc, err_msg=f"truncated {t}")
            self.ended += int((sterm | strunc).sum())
            # terms: t/reward then t's terms, x N / N_t on t's rows, 0 elsewhere
            nt = 1 + len(s.reward_term_names)
            cols = info["reward_terms"][:, nt_cols:nt_cols + nt]
            scale = np.float32(self.n) / np.float32(self.counts[k])
            want = np.concatenate([srew[:, None], sinfo["reward_terms"]], axis=1).astype(np.float32) * scale
            mx.check("terms x N/N_t on the task's rows", cols[r], want, t)
            assert not cols[others].any(), f"{t}'s terms nonzero on other tasks' rows"
            mx.check("mean over all rows of t/reward = t's mean reward", cols[:, 0].mean(), srew.mean(), t)
            for j, name in enumerate(s.reward_term_names):
                mx.check("mean over all rows of t/<term> = t's mean term", cols[:, 1 + j].mean(), sinfo["reward_terms"][:, j].mean(), f"{t}/{name}")
            nt_cols += nt
            # metrics and info: t's values (not rescaled) on t's rows, 0 elsewhere
            nm = len(s.frame_metric_names)
            mcols = info["frame_metrics"][:, nm_cols:nm_cols + nm]
            mx.check("metrics on the task's rows (exact)", mcols[r], sinfo["frame_metrics"], t, exact=True)
            assert not mcols[others].any()
            nm_cols += nm
            ni = len(s.task_info_names)
            icols = info["task_info"][:, ni_cols:ni_cols + ni]
            mx.check("task info on the task's rows (exact)", icols[r], sinfo["task_info"], t, exact=True)
            assert not icols[others].any()
            ni_cols += ni
            # terminal observations (SAME_STEP autoreset)
            if "_final_obs" in sinfo:
                assert "_final_obs" in info
                np.testing.assert_array_equal(info["_final_obs"][r], sinfo["_final_obs"])
                for i in np.flatnonzero(sinfo["_final_obs"]):
                    want = mapped_row(t, sinfo["final_obs"][i], self.groups, self.offsets, self.mask_at, self.width)
                    mx.check("final obs = single-task final obs mapped (exact)", info["final_obs"][r.start + i], want, t, exact=True)
            elif "_final_obs" in info:
                assert not info["_final_obs"][r].any()
        assert nt_cols == info["reward_terms"].shape[1]
        assert nm_cols == info["frame_metrics"].shape[1]
        assert ni_cols == info["task_info"].shape[1]
        return term | trunc

    def close(self):
        self.env.close()
        for s in self.singles:
            s.close()


@pytest.mark.parametrize("mode", ["same_step", "disabled"])
def test_multi_matches_single_task_environments(mode):
    t0 = time.time()
    tasks, mix, n, seed = ["hsi_follow", "hsi_sit", "hsi_carry"], [0.2, 0.5, 0.3], 9, 40
    c = MultiCheck(tasks, mix, n, seed, mode)
    assert c.counts == [2, 4, 3]
    c.check_spaces()
    obs = c.env.reset()[0]  # no seed: the streams the constructors seeded (seed + first row)
    c.check_obs(obs, [s.reset()[0] for s in c.singles], "first reset obs")
    rng = np.random.default_rng(7)
    steps = 0
    for phase in range(3):
        for _ in range(40):
            a = rng.uniform(-1, 1, (n, 32)).astype(np.float32)
            done = c.step(a)
            steps += 1
            if mode == "disabled" and done.any():
                c.reset_mask(done)
        if phase == 0:
            c.reset(seed=123)          # sub-batch k: 123 + its first row
        elif phase == 1:
            mask = np.zeros(n, bool)
            mask[[0, 3, 8]] = True
            c.reset_mask(mask)
    c.mx.report(f"hsi_multi ({mode}) {tasks} mix {mix}, {n} envs split {c.counts}: {steps} steps, {c.ended} episodes ended")
    print(f"    {time.time() - t0:.1f} s")
    assert c.ended > 0, "some episodes end (resets of single rows are compared too)"
    c.close()


def test_multi_state_access_is_routed_to_each_rows_task():
    """``get_state`` / ``set_state`` / ``mjcf_xml_of`` of any row of the multi-task environment
    reach the sub-batch holding that row (its MuJoCo access is multiplexed): rows 0-1 are the
    follow batch's environments, rows 2-3 the sit batch's (seeded ``seed + 2``); a state written
    into row 3 is read back, and the index is checked."""
    env = make("hsi_multi", 4, 2, multi={"tasks": ["hsi_follow", "hsi_sit"], "mix": [1, 1]})
    follow, sit = make("hsi_follow", 2, 2), make("hsi_sit", 2, 4)
    for i, (single, j) in enumerate([(follow, 0), (follow, 1), (sit, 0), (sit, 1)]):
        for x, y in zip(env.get_state(i), single.get_state(j)):
            np.testing.assert_array_equal(x, y)
        assert env.mjcf_xml_of(i) == single.mjcf_xml_of(j)
    qpos, qvel = sit.get_state(0)
    qpos = qpos.copy()
    qpos[0] += 0.3
    env.set_state(3, qpos, qvel)
    np.testing.assert_array_equal(env.get_state(3)[0], qpos)
    with pytest.raises(ValueError):
        env.get_state(4)
    env.close()
    follow.close()
    sit.close()


def test_multi_env_split_follows_the_mix():
    t0 = time.time()
    # TokenHSI's default: four tasks, mix 0.1 / 0.3 / 0.3 / 0.3
    assert split_reference(64, [0.1, 0.3, 0.3, 0.3]) == [7, 19, 19, 19]
    cases = [
        (64, None, None, [7, 19, 19, 19]),                                          # defaults
        (64, ["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"], [0.1, 0.3, 0.3, 0.3], [7, 19, 19, 19]),
        (4, ["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"], [0.1, 0.3, 0.3, 0.3], [1, 1, 1, 1]),
        (10, ["hsi_follow", "hsi_sit"], [0.01, 0.99], [1, 9]),                      # at least one each
        (5, ["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"], [], [2, 1, 1, 1]), # equal shares, tie → first
        (11, ["hsi_sit", "hsi_follow", "hsi_climb"], [3, 1, 1], [6, 3, 2]),     # 4.8/1.6/1.6: tie → earlier
    ]
    for n, tasks, mix, want in cases:
        if mix:
            assert split_reference(n, mix) == want
        multi = {} if tasks is None else {"tasks": tasks, "mix": mix}
        env = skillmimic_rs.VecEnv(num_envs=n, task="hsi_multi", autoreset_mode="disabled", threads=1,
                                   hsi={"object_variants": 1}, multi=multi)
        names = tasks or ["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"]
        groups, offsets, mask_at, width = layout(names)
        assert env.single_observation_space.shape == (width,)
        obs = env.reset(seed=1)[0]
        mask = obs[:, mask_at:]
        # each row activates exactly its task's group; rows go to the tasks in order
        assert (mask.sum(axis=1) == 1).all()
        got = [int(x) for x in mask.sum(axis=0)]
        order = list(np.argmax(mask, axis=1))
        assert order == sorted(order), "sub-batches are contiguous, in task order"
        assert got == want, f"{n} envs, tasks {names}, mix {mix}: split {got}, expected {want}"
        terms = [x.split("/")[0] for x in env.reward_term_names if x.endswith("/reward")]
        assert terms == names
        print(f"  split {n} envs, mix {mix or 'equal' if tasks else 'default'} -> {got}")
        env.close()
    print(f"    {time.time() - t0:.1f} s")


def test_multi_named_groups_extra_group_is_zero():
    seed = 60
    # one task, an extra group first: follow block zero, mask [0, 1]
    c = MultiCheck(["hsi_sit"], [1.0], 3, seed, groups=["hsi_follow", "hsi_sit"])
    assert c.width == 222 + 20 + 38 + 2
    c.check_spaces()
    obs = c.env.reset(seed=5)[0]
    assert not obs[:, 222:242].any(), "the follow block of an hsi_sit batch is zero"
    np.testing.assert_array_equal(obs[:, -2:], np.tile([0.0, 1.0], (3, 1)))
    c.check_obs(obs, [c.singles[0].reset(seed=5)[0]], "reset obs")
    rng = np.random.default_rng(3)
    for _ in range(5):
        c.step(rng.uniform(-1, 1, (3, 32)).astype(np.float32))
    c.mx.report("hsi_multi groups [hsi_follow, hsi_sit] over hsi_sit")
    c.close()
    # groups in another order than the tasks', with an unfilled group in between
    c = MultiCheck(["hsi_follow", "hsi_sit"], [1, 1], 4, seed, groups=["hsi_sit", "hsi_climb", "hsi_follow"])
    assert c.width == 222 + 38 + 27 + 20 + 3
    c.check_spaces()
    obs = c.env.reset(seed=9)[0]
    np.testing.assert_array_equal(obs[:, -3:], [[0, 0, 1], [0, 0, 1], [1, 0, 0], [1, 0, 0]])
    assert not obs[:, 222 + 38:222 + 38 + 27].any(), "the unfilled climb block is zero"
    c.check_obs(obs, [s.reset(seed=9 + int(s0))[0] for s, s0 in zip(c.singles, c.starts)], "reset obs")
    rng = np.random.default_rng(4)
    for _ in range(5):
        c.step(rng.uniform(-1, 1, (4, 32)).astype(np.float32))
    c.mx.report("hsi_multi groups [hsi_sit, hsi_climb, hsi_follow] over follow + sit")
    c.close()


def test_follow_carry_inside_multi_activates_its_three_groups():
    groups = ["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb", "hsi_follow_carry"]
    c = MultiCheck(["hsi_sit", "hsi_follow_carry"], [2, 3], 5, 80, groups=groups)
    assert c.counts == [2, 3]
    assert c.width == 222 + 20 + 38 + 42 + 27 + 59 + 5
    c.check_spaces()
    obs = c.env.reset()[0]
    c.check_obs(obs, [s.reset()[0] for s in c.singles], "reset obs")
    np.testing.assert_array_equal(obs[:2, -5:], np.tile([0, 1, 0, 0, 0], (2, 1)))
    np.testing.assert_array_equal(obs[2:, -5:], np.tile([1, 0, 1, 0, 1], (3, 1)), err_msg="follow_carry: follow, carry, follow_carry")
    # the follow_carry rows: follow block ← its follow obs, carry ← its carry obs, follow_carry ←
    # its composite; sit and climb blocks zero
    obs = c.env.reset(seed=80)[0]
    c.singles[0].reset(seed=80)
    fc = c.singles[1].reset(seed=82)[0]  # sub-batch 1 starts at row 2: seed + 2
    at = {g: c.offsets[g][0] for g in groups}
    np.testing.assert_array_equal(obs[2:, at["hsi_follow"]:at["hsi_follow"] + 20], fc[:, 222:242])
    np.testing.assert_array_equal(obs[2:, at["hsi_carry"]:at["hsi_carry"] + 42], fc[:, 242:284])
    np.testing.assert_array_equal(obs[2:, at["hsi_follow_carry"]:at["hsi_follow_carry"] + 59], fc[:, 284:343])
    assert not obs[2:, at["hsi_sit"]:at["hsi_sit"] + 38].any() and not obs[2:, at["hsi_climb"]:at["hsi_climb"] + 27].any()
    rng = np.random.default_rng(8)
    for _ in range(10):
        c.step(rng.uniform(-0.5, 0.5, (5, 32)).astype(np.float32))
    c.mx.report("hsi_multi sit + follow_carry with groups " + str(groups))
    c.close()
    # default groups of [hsi_follow, hsi_follow_carry]: follow, carry, follow_carry (first appearance)
    c = MultiCheck(["hsi_follow", "hsi_follow_carry"], [1, 1], 2, 3)
    assert c.groups == ["hsi_follow", "hsi_carry", "hsi_follow_carry"] and c.width == 222 + 121 + 3
    c.check_spaces()
    obs = c.env.reset()[0]
    c.check_obs(obs, [s.reset()[0] for s in c.singles], "reset obs")
    np.testing.assert_array_equal(obs[:, -3:], [[1, 0, 0], [1, 1, 1]])
    c.step(np.zeros((2, 32), np.float32))
    c.close()


def test_multi_config_errors_name_the_field():
    def build(n=4, task="hsi_multi", **multi):
        return skillmimic_rs.VecEnv(num_envs=n, task=task, autoreset_mode="disabled", threads=1, hsi={"object_variants": 1}, multi=multi)

    with pytest.raises(ValueError, match=r"env\.multi\.mix.*1 weights for 2 tasks"):
        build(tasks=["hsi_follow", "hsi_sit"], mix=[1.0])
    with pytest.raises(ValueError, match=r"env\.multi\.mix.*4 weights for 2 tasks"):
        build(tasks=["hsi_follow", "hsi_sit"], mix=[0.1, 0.3, 0.3, 0.3])
    with pytest.raises(ValueError, match=r"env\.multi\.mix.*positive"):
        build(tasks=["hsi_follow", "hsi_sit"], mix=[1.0, 0.0])
    with pytest.raises(ValueError, match=r"env\.num_envs.*at least one per task"):
        build(n=1, tasks=["hsi_follow", "hsi_sit"])
    with pytest.raises(ValueError, match=r"env\.num_envs.*at least one per task \(4\)"):
        build(n=3)   # the default four tasks
    with pytest.raises(ValueError, match=r"env\.multi\.groups.*'walk' is not a task observation group"):
        build(tasks=["hsi_follow", "hsi_sit"], groups=["hsi_follow", "hsi_sit", "walk"])
    with pytest.raises(ValueError, match=r"env\.multi\.groups.*'proprio' is not a task observation group"):
        build(tasks=["hsi_follow", "hsi_sit"], groups=["proprio", "hsi_follow", "hsi_sit"])
    with pytest.raises(ValueError, match=r"env\.multi\.groups.*misses 'hsi_sit'"):
        build(tasks=["hsi_follow", "hsi_sit"], groups=["hsi_follow"])
    with pytest.raises(ValueError, match=r"env\.multi\.tasks.*'heading' cannot run in 'hsi_multi'"):
        build(tasks=["hsi_follow", "heading"])
    with pytest.raises(ValueError, match=r"env\.multi\.tasks.*'hsi_follow' cannot run in 'hlc_multi'"):
        build(task="hlc_multi", tasks=["hsi_follow", "heading"])
    with pytest.raises(ValueError, match=r"env\.multi\.tasks.*'hsi_multi' is itself a multi-task"):
        build(tasks=["hsi_follow", "hsi_multi"])
    with pytest.raises(ValueError, match=r"env\.multi\.tasks.*'imitation'"):
        build(tasks=["hsi_follow", "imitation"])
    with pytest.raises(ValueError, match=r"env\.multi\.tasks.*'no_such_task' is not a registered task"):
        build(tasks=["hsi_follow", "no_such_task"])
