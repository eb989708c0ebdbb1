"""``skillmimic_rs.VecEnv`` follows the gymnasium 1.x vector-env contract and fails cleanly on bad
input."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import skillmimic_rs


@pytest.fixture
def env():
    e = skillmimic_rs.VecEnv(num_envs=3, config={"episode_length": 8, "threads": 2})
    yield e
    e.close()


def test_spaces_dtypes_and_shapes(env):
    assert isinstance(env, gym.vector.VectorEnv)
    assert env.num_envs == 3
    space = env.single_observation_space
    assert space.shape == (902,) and space.dtype == np.float32
    # finite bounds only where bounded: rotation columns [-1, 1], skill one-hot [0, 1]
    blocks = skillmimic_rs.OBS_BLOCKS
    for name in ("body_rot", "ball_rot"):
        a, b = blocks[name]
        assert (space.low[a:b] == -1).all() and (space.high[a:b] == 1).all()
    a, b = blocks["skill"]
    assert (space.low[a:b] == 0).all() and (space.high[a:b] == 1).all()
    assert np.isinf(space.low[:blocks["body_rot"][0]]).all() and np.isinf(space.high[blocks["ball_linvel"][0]:blocks["skill"][0]]).all()
    assert env.single_action_space == gym.spaces.Box(-1.0, 1.0, (156,), np.float32)
    assert env.observation_space.shape == (3, 902) and env.action_space.shape == (3, 156)
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == (3, 902)
    assert env.observation_space.contains(obs)
    obs, rew, term, trunc, info = env.step(env.action_space.sample())
    assert obs.shape == (3, 902) and obs.dtype == np.float32
    assert rew.shape == (3,) and rew.dtype == np.float32
    assert term.dtype == np.bool_ and trunc.dtype == np.bool_ and term.shape == (3,)
    for key in ("reward_terms", "contact_graph", "frame_metrics", "clip", "ref_frame", "progress", "skill"):
        assert key in info and ("_" + key) in info
        assert len(info[key]) == 3
    assert info["reward_terms"].shape == (3, len(env.reward_term_names))
    np.testing.assert_allclose(info["reward_terms"][:, -1], rew)


def test_same_step_autoreset_semantics(env):
    env.reset(seed=1)
    zero = np.zeros((3, 156), np.float32)
    for k in range(1, 10):
        prev = env.episode_info()
        obs, rew, term, trunc, info = env.step(zero)
        done = term | trunc
        if done.any():
            # terminal observation kept, returned obs is the reset observation
            assert info["_final_obs"].tolist() == done.tolist()
            for i in range(3):
                if done[i]:
                    assert info["final_obs"][i].shape == (902,)
                    assert not np.array_equal(info["final_obs"][i], obs[i])
                    np.testing.assert_array_equal(info["final_obs_dense"][i], info["final_obs"][i])
                    assert info["progress"][i] == 0
                else:
                    assert info["final_obs"][i] is None
                    assert info["progress"][i] == prev["progress"][i] + 1
            break
    else:
        pytest.fail("no episode ended within 9 steps although episode_length is 8")


def test_disabled_mode_and_reset_mask():
    env = skillmimic_rs.VecEnv(num_envs=2, config={"episode_length": 4}, autoreset_mode="disabled")
    assert env.metadata["autoreset_mode"] == AutoresetMode.DISABLED
    env.reset(seed=0)
    zero = np.zeros((2, 156), np.float32)
    for _ in range(3):
        obs, rew, term, trunc, info = env.step(zero)
    assert trunc.all() and "final_obs" not in info
    assert (env.episode_info()["progress"] == 3).all()
    obs2, info2 = env.reset(options={"reset_mask": np.array([True, False])})
    assert info2["progress"].tolist() == [0, 3]
    np.testing.assert_array_equal(obs2[1], obs[1])
    with pytest.raises(ValueError, match="selects no environment"):
        env.reset(options={"reset_mask": np.array([False, False])})
    with pytest.raises(ValueError, match="reset_mask"):
        env.reset(options={"reset_mask": np.array([1, 0])})
    env.close()


def test_seeding_is_deterministic():
    def rollout(seed):
        e = skillmimic_rs.VecEnv(num_envs=2, config={"episode_length": 10})
        obs, info = e.reset(seed=seed)
        out = [obs, info["ref_frame"]]
        rng = np.random.default_rng(5)
        for _ in range(25):
            o, r, *_ = e.step(rng.uniform(-0.3, 0.3, (2, 156)).astype(np.float32))
            out += [o, r]
        e.close()
        return out

    a, b, c = rollout(7), rollout(7), rollout(8)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c))


def test_state_access(env):
    env.reset(seed=0)
    qpos, qvel = env.get_state(1)
    assert qpos.dtype == np.float64 and qpos.shape == (7 + 52 * 4 + 7,) and qvel.shape == (6 + 52 * 3 + 6,)
    qpos2 = qpos.copy()
    qpos2[2] += 0.5  # lift the root
    obs = env.set_state(1, qpos2, qvel)
    assert np.isclose(obs[1, 0], qpos2[2], atol=1e-6)  # observation 0 is the root height
    np.testing.assert_array_equal(env.get_state(1)[0], qpos2)
    assert env.mjcf_path.read_text() == env.mjcf_xml
    assert env.contact_graph().shape == (3, len(env.contact_graph_names))
    assert env.config["num_envs"] == 3 and env.config["reward"]["w_p"] == 20.0
    assert [c[1] for c in env.clips] == [50, 51]


def test_bad_inputs_raise_clear_python_errors(env):
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions: expected shape \(3, 156\)"):
        env.step(np.zeros((3, 155), np.float32))
    with pytest.raises(ValueError, match="float array"):
        env.step(np.zeros((3, 156), np.int64))
    a = np.zeros((3, 156), np.float32)
    a[2, 7] = np.nan
    with pytest.raises(ValueError, match="non-finite value at environment 2, entry 7"):
        env.step(a)
    # float64 actions are accepted (converted)
    env.step(np.zeros((3, 156), np.float64))
    with pytest.raises(ValueError, match="out of range"):
        env.get_state(5)
    with pytest.raises(ValueError, match="qpos"):
        env.set_state(0, np.zeros(3), np.zeros(168))
    with pytest.raises(ValueError, match="unknown field `num_env`"):
        skillmimic_rs.VecEnv(num_envs=2, num_env=3)
    with pytest.raises(ValueError, match="env.hands"):
        skillmimic_rs.VecEnv(num_envs=2, hands="claws")
    with pytest.raises(ValueError, match="w_ig"):
        skillmimic_rs.VecEnv(num_envs=2, config={"reward": {"w_ig": -1.0}})
    with pytest.raises(ValueError, match="no such clip file or folder"):
        skillmimic_rs.VecEnv(num_envs=2, motion=["/nonexistent/clips"])
    with pytest.raises(FileNotFoundError):
        skillmimic_rs.VecEnv(num_envs=2, config="/nonexistent/config.toml")
    with pytest.raises(ValueError, match="autoreset_mode"):
        skillmimic_rs.VecEnv(num_envs=2, autoreset_mode="every_step")
    env.close()
    env.close()  # idempotent
    for call in (lambda: env.step(a), lambda: env.reset(), lambda: env.get_state(0), lambda: env.mjcf_xml):
        with pytest.raises(RuntimeError, match="closed"):
            call()


def test_toml_config_matches_cli_format(tmp_path, repo_root):
    cfg = tmp_path / "c.toml"
    motions = repo_root / "motions"
    cfg.write_text(f'[env]\nmotion = ["{motions}"]\nepisode_length = 12\n[env.reward]\nvariant = "additive"\n')
    e = skillmimic_rs.VecEnv(num_envs=2, config=cfg)
    assert e.config["reward"]["variant"] == "additive" and e.config["episode_length"] == 12
    e.close()


def test_env_checker_style_rollout_with_copy_false():
    e = skillmimic_rs.VecEnv(num_envs=2, copy=False)
    obs, _ = e.reset(seed=0)
    obs2, *_ = e.step(np.zeros((2, 156), np.float32))
    assert obs2 is obs  # the internal buffer, overwritten in place
    e.close()


def test_every_registered_task_runs_through_the_python_vecenv(tmp_path):
    """``VecEnv(task=...)`` for every task of the registry: declared spaces, 30 steps, no NaN
    (the high-level tasks drive a small skill policy written for the test)."""
    llc = tmp_path / "llc.safetensors"
    skillmimic_rs._core.init_policy(str(llc), "gaussian_mlp", 902, ("box", 156), [16], 0)
    high_level = set(skillmimic_rs.HIGH_LEVEL_TASKS)
    assert {"heading", "circling", "throwing", "scoring", "steering", "reach"} <= high_level <= set(skillmimic_rs.TASKS)
    for task in skillmimic_rs.TASKS:
        extra = {"llc": llc} if task in high_level else {}
        n = 4 if task == "hsi_multi" else 3  # one environment per task of TokenHSI's mix
        env = skillmimic_rs.VecEnv(num_envs=n, task=task, threads=1, **extra)
        try:
            assert env.task == task
            obs, info = env.reset(seed=2)
            assert obs.shape == (n,) + env.single_observation_space.shape and obs.dtype == np.float32
            for _ in range(30):
                a = env.action_space.sample()
                a = a.astype(np.float32) if task not in high_level else a
                obs, rew, term, trunc, info = env.step(a)
                assert np.isfinite(obs).all() and np.isfinite(rew).all()
                assert info["reward_terms"].shape == (n, len(env.reward_term_names))
                assert info["frame_metrics"].shape == (n, len(env.frame_metric_names))
        finally:
            env.close()
    stand = skillmimic_rs.VecEnv(num_envs=2, task="stand")
    assert stand.single_observation_space.shape == (826,) and stand.reward_term_names == ["height", "heading", "total"]
    # the episode fields come from the task's declaration: stand declares none
    assert stand.episode_names == [] and stand.episode_info() == {}
    # bounds from the declared blocks: the proprioception's rotation columns, nothing else
    rot = [(a, b) for name, a, b, lo, hi in stand._core.obs_blocks if name == "body_rot"]
    (a, b), = rot
    assert (stand.single_observation_space.low[a:b] == -1).all() and np.isinf(stand.single_observation_space.low[:a]).all()
    with pytest.raises(ValueError, match="env.task"):
        skillmimic_rs.VecEnv(num_envs=2, task="juggle")
