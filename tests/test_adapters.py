"""SB3 and rsl_rl adapters run a few PPO updates on the environment without error."""

from __future__ import annotations

import warnings

import numpy as np

import skillmimic_rs
from conftest import require_module


def test_stable_baselines3_ppo_runs_a_few_updates(tmp_path):
    sb3 = require_module("stable_baselines3")
    from stable_baselines3.common.vec_env import VecCheckNan

    from skillmimic_rs.sb3 import Sb3VecEnv

    venv = VecCheckNan(Sb3VecEnv(skillmimic_rs.VecEnv(num_envs=4, config={"episode_length": 10}, threads=2)), raise_exception=True)
    model = sb3.PPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=2, policy_kwargs={"net_arch": [64, 64]}, seed=0, device="cpu", verbose=0)
    model.learn(total_timesteps=4 * 16 * 3)
    assert model.num_timesteps >= 4 * 16 * 3
    # terminal observations and time-limit flags reach SB3
    inner = venv.venv
    inner.reset()
    seen_terminal = False
    for _ in range(12):
        _, _, dones, infos = inner.step(np.zeros((4, 156), np.float32))
        for d, info in zip(dones, infos):
            if d:
                assert info["terminal_observation"].shape == (902,)
                assert info["TimeLimit.truncated"] in (True, False)
                seen_terminal = True
    assert seen_terminal
    venv.close()


def test_rsl_rl_runner_runs_a_few_iterations(tmp_path):
    require_module("rsl_rl")
    require_module("tensordict")
    import torch
    from rsl_rl.runners import OnPolicyRunner

    from skillmimic_rs.rsl_rl import RslRlVecEnv

    env = RslRlVecEnv(skillmimic_rs.VecEnv(num_envs=4, config={"episode_length": 10}, threads=2))
    cfg = {
        "num_steps_per_env": 12,
        "save_interval": 1000,
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": {"class_name": "PPO", "num_learning_epochs": 2, "num_mini_batches": 2, "learning_rate": 1e-3, "schedule": "fixed", "entropy_coef": 0.0},
        "actor": {"class_name": "MLPModel", "hidden_dims": [64, 64], "activation": "elu", "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 0.1}},
        "critic": {"class_name": "MLPModel", "hidden_dims": [64, 64], "activation": "elu"},
        "multi_gpu": None,
    }
    runner = OnPolicyRunner(env, cfg, log_dir=None, device="cpu")
    runner.learn(num_learning_iterations=3, init_at_random_ep_len=True)
    assert runner.current_learning_iteration == 2
    obs, rew, dones, extras = env.step(torch.zeros(4, 156))
    assert obs["policy"].shape == (4, 902) and dones.dtype == torch.long
    assert "time_outs" in extras and "reward_total" in extras["log"]
    env.close()


def test_adapters_warn_about_exploration_too_wide_for_the_reward():
    """SB3's / rsl_rl's default action noise (σ ≈ 1) gets ~0 reward here and learns nothing: the
    adapters warn after 64 steps; the paper's σ = 0.055 around zero actions does not warn."""
    require_module("stable_baselines3")
    from skillmimic_rs.sb3 import Sb3VecEnv, ppo_recipe

    assert ppo_recipe()["policy_kwargs"]["log_std_init"] == -2.9
    rng = np.random.default_rng(0)
    for sigma, warns in ((1.0, True), (0.055, False)):
        venv = Sb3VecEnv(skillmimic_rs.VecEnv(num_envs=4, threads=2))
        venv.reset()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for _ in range(64):
                venv.step(np.clip(rng.normal(0, sigma, (4, 156)), -1, 1).astype(np.float32))
        hits = [w for w in caught if "will not learn" in str(w.message)]
        assert bool(hits) == warns, (sigma, [str(w.message) for w in caught])
        venv.close()
