"""The gymnasium surface (issue 18): the single-environment view passes ``check_env``; the vector
environment works under gymnasium's vector wrappers in its default NEXT_STEP mode; NEXT_STEP,
SAME_STEP and DISABLED give exactly the transitions of ``gymnasium.vector.SyncVectorEnv`` over the
single-environment view with the same seeds; ids are registered for ``make`` / ``make_vec``.

The reference side is gymnasium's own ``SyncVectorEnv`` stepping independent single environments
(each a batch of one): it shares no batching, seeding or autoreset code with ``VecEnv``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import skillmimic_rs
from skillmimic_rs import SkillMimicEnv, VecEnv

# short episodes (truncation after 6 steps) plus falls under random actions: many resets per run
KW = dict(episode_length=6, threads=1)
N = 4
STEPS = 40
MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP, "disabled": AutoresetMode.DISABLED}


def test_check_env_passes_on_single_environment():
    from gymnasium.utils.env_checker import check_env

    env = SkillMimicEnv(**KW)
    check_env(env, skip_render_check=True)
    env.close()


def test_observation_bounds_hold():
    env = VecEnv(N, autoreset_mode="next_step", **KW)
    space = env.single_observation_space
    assert np.isfinite(space.low).sum() == 318 + 6 + 64  # body / ball rotation columns, skill one-hot
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(30):
        assert all(space.contains(o) for o in obs)
        obs, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
    env.close()


def _actions(rng, n):
    return rng.uniform(-1, 1, (n, skillmimic_rs.ACT_DIM)).astype(np.float32)


@pytest.mark.parametrize("mode", ["next_step", "same_step", "disabled"])
def test_same_transitions_as_sync_vector_env(mode):
    ours = VecEnv(N, autoreset_mode=mode, **KW)
    ref = gym.vector.SyncVectorEnv([lambda: SkillMimicEnv(**KW) for _ in range(N)], autoreset_mode=MODES[mode])
    o1, _ = ours.reset(seed=11)
    o2, _ = ref.reset(seed=11)
    np.testing.assert_array_equal(o1, o2)
    rng = np.random.default_rng(5)
    ends = 0
    for t in range(STEPS):
        a = _actions(rng, N)
        r1 = ours.step(a)
        r2 = ref.step(a)
        for k, name in enumerate(("obs", "reward", "terminated", "truncated")):
            np.testing.assert_array_equal(r1[k], np.asarray(r2[k], dtype=r1[k].dtype), err_msg=f"{mode}: {name} at step {t}")
        done = r1[2] | r1[3]
        ends += int(done.sum())
        if mode == "same_step" and done.any():
            for i in np.flatnonzero(done):
                np.testing.assert_array_equal(r1[4]["final_obs"][i], r2[4]["final_obs"][i])
            np.testing.assert_array_equal(r1[4]["_final_info"], done)
        if mode == "disabled" and done.any():
            o1, _ = ours.reset(options={"reset_mask": done.copy()})
            o2, _ = ref.reset(options={"reset_mask": done.copy()})
            np.testing.assert_array_equal(o1, o2, err_msg=f"disabled: reset observations after step {t}")
    assert ends >= 2 * N, f"only {ends} episode ends in {STEPS} steps: the test would not exercise resets"
    ours.close()
    ref.close()


def test_next_step_semantics():
    env = VecEnv(2, autoreset_mode="next_step", **KW)
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    for _ in range(20):
        obs, rew, term, trunc, info = env.step(_actions(rng, 2))
        done = term | trunc
        if done.any():
            break
    assert done.any()
    obs2, rew2, term2, trunc2, info2 = env.step(_actions(rng, 2))
    assert (rew2[done] == 0).all() and not term2[done].any() and not trunc2[done].any()
    assert not info2["_reward_terms"][done].any() and (info2["reward_terms"][done] == 0).all()
    # the reset environments start a new episode: one more step moves them on
    obs3, *_ = env.step(_actions(rng, 2))
    assert not np.array_equal(obs2[done], obs3[done])
    env.close()


def test_vector_wrappers_in_next_step_mode():
    from gymnasium.wrappers.vector import FlattenObservation, NormalizeObservation, RecordEpisodeStatistics, TransformObservation

    env = gym.make_vec("SkillMimic-Imitation-v0", num_envs=N, **KW)
    assert isinstance(env, VecEnv) and env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    env = RecordEpisodeStatistics(env)
    env = NormalizeObservation(env)
    env = TransformObservation(env, lambda o: np.clip(o, -5, 5))
    env = FlattenObservation(env)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(2)
    episodes = 0
    for _ in range(25):
        obs, rew, term, trunc, info = env.step(_actions(rng, N))
        assert obs.shape == (N, skillmimic_rs.OBS_DIM) and np.abs(obs).max() <= 5
        if "episode" in info:
            episodes += int(info["_episode"].sum())
            assert (info["episode"]["l"][info["_episode"]] >= 1).all()
    assert episodes >= N
    env.close()


def test_registered_ids():
    assert skillmimic_rs.GYM_IDS["SkillMimic-Imitation-v0"] == "imitation"
    assert skillmimic_rs.gym_id("hsi_sit") == "SkillMimic-HsiSit-v0"
    # written out here, not derived: a renamed or dropped id (or task) fails this test
    expected = {
        "SkillMimic-Imitation-v0": "imitation",
        "SkillMimic-Stand-v0": "stand",
        "SkillMimic-Tracking-v0": "tracking",
        "SkillMimic-HsiFollow-v0": "hsi_follow",
        "SkillMimic-HsiSit-v0": "hsi_sit",
        "SkillMimic-HsiClimb-v0": "hsi_climb",
        "SkillMimic-HsiCarry-v0": "hsi_carry",
        "SkillMimic-HsiFollowCarry-v0": "hsi_follow_carry",
        "SkillMimic-HsiSitCarry-v0": "hsi_sit_carry",
        "SkillMimic-HsiClimbCarry-v0": "hsi_climb_carry",
        "SkillMimic-HsiMulti-v0": "hsi_multi",
        "SkillMimic-Heading-v0": "heading",
        "SkillMimic-Circling-v0": "circling",
        "SkillMimic-Throwing-v0": "throwing",
        "SkillMimic-Scoring-v0": "scoring",
        "SkillMimic-Steering-v0": "steering",
        "SkillMimic-Reach-v0": "reach",
        "SkillMimic-HlcMulti-v0": "hlc_multi",
    }
    assert skillmimic_rs.GYM_IDS == expected
    for gid, task in expected.items():
        assert gym.registry[gid].kwargs.get("task") == task, gid
    env = gym.make("SkillMimic-Imitation-v0", **KW)
    assert isinstance(env.unwrapped, SkillMimicEnv)
    obs, _ = env.reset(seed=1)
    assert obs.shape == (skillmimic_rs.OBS_DIM,)
    env.close()
    venv = gym.make_vec("SkillMimic-Stand-v0", num_envs=2, autoreset_mode="same_step", threads=1)
    assert venv.task == "stand" and venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    venv.close()


def test_render_follows_vector_convention():
    env = VecEnv(2, render_mode="rgb_array", threads=1)
    env.reset(seed=0)
    frames = env.render()
    assert isinstance(frames, tuple) and len(frames) == 2
    assert all(f.shape == (480, 640, 3) and f.dtype == np.uint8 for f in frames)
    assert frames[0].std() > 5, "the frame shows a scene, not a blank image"
    env.render_env_ids = (1,)
    assert len(env.render()) == 1
    env.close()
    one = SkillMimicEnv(render_mode="rgb_array", threads=1)
    one.reset(seed=0)
    assert one.render().shape == (480, 640, 3)
    one.close()
