"""rsl_rl adapter (supported: rsl-rl-lib >= 3.0, < 6, with tensordict).

``RslRlVecEnv(skillmimic_rs.VecEnv(...))`` implements ``rsl_rl.env.VecEnv``: observations are a
``TensorDict`` with the group ``"policy"`` (also used for the critic), ``dones`` is a long tensor,
``extras["time_outs"]`` marks truncations (rsl_rl bootstraps on them) and ``extras["log"]`` holds
the mean reward terms. ``episode_length_buf`` is writable (``learn(init_at_random_ep_len=True)``
assigns it); since episodes are driven by their reference clip, a written buffer is kept for the
runner's bookkeeping but does not shorten the episode in the Rust core.
"""

from __future__ import annotations

import numpy as np
import torch
from rsl_rl.env import VecEnv as _RslVecEnv
from tensordict import TensorDict

from ._explore import ExplorationCheck
from .vec_env import VecEnv, _MODES


def runner_recipe() -> dict:
    """A fresh copy of the rsl_rl recipe of docs/tutorials/gymnasium.md: an ``OnPolicyRunner`` config (rsl-rl-lib 5) with
    the `tiny` preset's PPO (ReLU MLPs [256, 128], 16 steps per environment, 4 minibatches, 2
    epochs, learning rate 3e-5), observation normalisation and the paper's action noise
    σ = e^-2.9 ≈ 0.055 at the start."""
    return {
        "num_steps_per_env": 16,
        "save_interval": 100000,
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": {"class_name": "PPO", "num_learning_epochs": 2, "num_mini_batches": 4, "learning_rate": 3e-5,
                      "schedule": "fixed", "entropy_coef": 0.0, "gamma": 0.99, "lam": 0.95, "clip_param": 0.2},
        "actor": {"class_name": "MLPModel", "hidden_dims": [256, 128], "activation": "relu", "obs_normalization": True,
                  "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 0.055}},
        "critic": {"class_name": "MLPModel", "hidden_dims": [256, 128], "activation": "relu", "obs_normalization": True},
        "multi_gpu": None,
    }


class RslRlVecEnv(_RslVecEnv):
    """Wrap a same-step ``skillmimic_rs.VecEnv`` for rsl_rl's ``OnPolicyRunner``."""

    def __init__(self, env: VecEnv, device: str | torch.device = "cpu", cfg: dict | None = None):
        if env.metadata["autoreset_mode"] != _MODES["same_step"]:
            raise ValueError("RslRlVecEnv needs a VecEnv with autoreset_mode='same_step'")
        self.env = env
        self.device = torch.device(device)
        self.num_envs = env.num_envs
        self.num_actions = env.single_action_space.shape[0]
        self.max_episode_length = env.max_episode_length
        self.cfg = cfg if cfg is not None else env.config
        obs, _ = env.reset()
        self._obs = self._wrap(obs)
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self._explore = ExplorationCheck("RslRlVecEnv", "actor distribution_cfg init_std=0.055, see skillmimic_rs.rsl_rl.runner_recipe()")

    def _wrap(self, obs: np.ndarray) -> TensorDict:
        t = torch.as_tensor(obs, device=self.device)
        return TensorDict({"policy": t}, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._obs

    def step(self, actions: torch.Tensor):
        a = actions.detach().to("cpu", torch.float32).numpy()
        obs, rew, term, trunc, info = self.env.step(a)
        self._explore.observe(a, rew)
        self._obs = self._wrap(obs)
        dones = torch.as_tensor(term | trunc, device=self.device).long()
        self.episode_length_buf += 1
        self.episode_length_buf[dones.bool()] = 0
        terms = info["reward_terms"].mean(axis=0)
        extras = {
            "time_outs": torch.as_tensor(trunc & ~term, device=self.device),
            "log": {f"reward_{n}": float(v) for n, v in zip(self.env.reward_term_names, terms)},
        }
        return self._obs, torch.as_tensor(rew, device=self.device), dones, extras

    def close(self) -> None:
        self.env.close()
