"""Stable-Baselines3 adapter (supported: stable-baselines3 >= 2.4, < 3).

``Sb3VecEnv(skillmimic_rs.VecEnv(...))`` is an SB3 ``VecEnv``: ``reset()`` returns observations
only, ``step_wait()`` returns ``(obs, rewards, dones, infos)`` with ``dones = terminated |
truncated`` and, for finished environments, ``infos[i]["terminal_observation"]`` and
``infos[i]["TimeLimit.truncated"] = truncated and not terminated`` (SB3's same-step semantics).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv as _Sb3VecEnv

from ._explore import ExplorationCheck
from .vec_env import VecEnv, _MODES


def ppo_recipe() -> dict[str, Any]:
    """The PPO settings that learn on SkillMimic's reward, as keyword arguments of
    ``stable_baselines3.PPO`` (measured in docs/tutorials/gymnasium.md): the `tiny` preset's PPO (ReLU MLPs
    [256, 128], horizon 16, minibatch 128, 2 epochs, learning rate 3e-5, gamma 0.99, lambda 0.95,
    clip 0.2) and the paper's action noise log σ = -2.9. Use it through :func:`recipe_model`,
    which adds the two parts keyword arguments cannot express. A fresh copy on every call."""
    import torch

    return dict(
        n_steps=16,
        batch_size=128,
        n_epochs=2,
        learning_rate=3e-5,
        gamma=0.99,
        gae_lambda=0.95,
        clip_range=0.2,
        ent_coef=0.0,
        policy_kwargs=dict(log_std_init=-2.9, net_arch=dict(pi=[256, 128], vf=[256, 128]), activation_fn=torch.nn.ReLU),
    )


def recipe_model(env: VecEnv, seed: int = 0, **overrides: Any):
    """SB3 PPO on ``env`` with the recipe: :func:`ppo_recipe` (``overrides`` replace entries),
    observations normalised by running mean / std clipped at 5 (``VecNormalize``, rewards left
    as they are; ``VecMonitor`` inside it logs raw episode returns), and the action noise fixed
    at σ = e^-2.9 as in the paper (SB3 would otherwise learn log σ). Returns the ``PPO`` model;
    its environment is ``model.get_env()`` (call ``.normalize_obs`` on raw observations to act
    with ``model.predict`` elsewhere)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    kw = dict(ppo_recipe(), **overrides)
    venv = VecNormalize(VecMonitor(Sb3VecEnv(env)), norm_obs=True, norm_reward=False, clip_obs=5.0, gamma=kw["gamma"])
    venv.seed(seed)
    model = PPO("MlpPolicy", venv, seed=seed, **kw)
    model.policy.log_std.requires_grad_(False)  # fixed σ: Adam skips a parameter without gradient
    return model


class Sb3VecEnv(_Sb3VecEnv):
    """Wrap a same-step ``skillmimic_rs.VecEnv`` for Stable-Baselines3."""

    def __init__(self, env: VecEnv):
        if env.metadata["autoreset_mode"] != _MODES["same_step"]:
            raise ValueError("Sb3VecEnv needs a VecEnv with autoreset_mode='same_step'")
        self.env = env
        self._actions: np.ndarray | None = None
        self._seed: int | None = None
        self._explore = ExplorationCheck("Sb3VecEnv", "policy_kwargs=dict(log_std_init=-2.9), see skillmimic_rs.sb3.ppo_recipe()")
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)

    def reset(self) -> np.ndarray:
        obs, _ = self.env.reset(seed=self._seed)
        self._seed = None
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, dtype=np.float32)

    def step_wait(self):
        obs, rew, term, trunc, info = self.env.step(self._actions)
        self._explore.observe(self._actions, rew)
        dones = term | trunc
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            infos[i]["terminal_observation"] = info["final_obs"][i]
            infos[i]["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
        return obs, rew, dones, infos

    def close(self) -> None:
        self.env.close()

    def seed(self, seed: int | None = None) -> Sequence[None | int]:
        self._seed = seed
        return [seed] * self.num_envs

    def _indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        value = getattr(self.env, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        out = getattr(self.env, method_name)(*method_args, **method_kwargs)
        return [out for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        frames = self.env.render()
        return list(frames) if frames is not None else [None] * self.num_envs
