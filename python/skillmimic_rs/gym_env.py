"""gymnasium surface beyond :class:`~skillmimic_rs.VecEnv`: a single-environment view and the
registered ids.

* :class:`SkillMimicEnv` is one environment as a ``gymnasium.Env`` (a batch of one, no automatic
  reset), for ``gymnasium.utils.env_checker.check_env``, ``gymnasium.make`` and libraries that
  vectorise single environments themselves (``gymnasium.vector.SyncVectorEnv`` over it plans the
  same episodes as :class:`~skillmimic_rs.VecEnv` with the same seed, see ``vec_env``).
* Every registered task has an id ``SkillMimic-<Task>-v0`` (``imitation`` → ``SkillMimic-Imitation-v0``,
  ``hsi_sit`` → ``SkillMimic-HsiSit-v0``; :data:`GYM_IDS`), registered when ``skillmimic_rs`` is
  imported: ``gymnasium.make(id)`` gives a :class:`SkillMimicEnv`, ``gymnasium.make_vec(id,
  num_envs=N)`` the batched Rust :class:`~skillmimic_rs.VecEnv` with gymnasium's default
  NEXT_STEP autoreset (pass ``autoreset_mode="same_step"`` for SB3-style loops). Keyword
  arguments are those of the classes (``config=``, ``llc=``, config fields).
"""

from __future__ import annotations

import os
from typing import Any, Mapping

import gymnasium as gym
import numpy as np

from . import _core
from .vec_env import VecEnv


def _row(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Environment ``i``'s entries of a vector ``info`` (keys whose ``_key`` mask is set)."""
    out: dict[str, Any] = {}
    for k, v in info.items():
        if k.startswith("_"):
            continue
        mask = info.get("_" + k)
        if isinstance(v, dict):
            if mask is None or mask[i]:
                out[k] = _row(v, i)
        elif mask is None or mask[i]:
            out[k] = v[i]
    return out


class SkillMimicEnv(gym.Env):
    """One environment of a registered task as a ``gymnasium.Env``.

    Args:
        config, task, llc, **overrides: as for :class:`~skillmimic_rs.VecEnv` (``num_envs`` is 1).
        render_mode: ``"rgb_array"`` or ``None``.

    ``reset(seed=s)`` starts the episode stream ``s`` (the stream a :class:`VecEnv` reset with
    seed ``s - i`` gives its environment ``i``); ``reset()`` continues it. ``step`` after the end
    of an episode without ``reset`` keeps simulating the finished episode (gymnasium leaves this
    undefined). Observations, actions and info entries are those of one row of the vector
    environment; rewards are Python floats.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 60}

    def __init__(
        self,
        config: Mapping[str, Any] | str | os.PathLike | None = None,
        *,
        task: str | None = None,
        llc: str | os.PathLike | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self._vec = VecEnv(1, config, task=task, llc=llc, autoreset_mode="disabled", render_mode=render_mode, **overrides)
        self.observation_space = self._vec.single_observation_space
        self.action_space = self._vec.single_action_space
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=int(round(60 / self._vec.steps_per_action)))

    @property
    def vec_env(self) -> VecEnv:
        """The batch of one underneath (research accessors: states, reward terms, MJCF)."""
        return self._vec

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        obs, info = self._vec.reset(seed=seed)
        return obs[0], _row(info, 0)

    def step(self, action):
        if isinstance(self.action_space, gym.spaces.Discrete):
            a = np.asarray([int(action)], dtype=np.int64)
        else:
            a = np.asarray(action, dtype=np.float32).reshape(1, -1)
        obs, rew, term, trunc, info = self._vec.step(a)
        return obs[0], float(rew[0]), bool(term[0]), bool(trunc[0]), _row(info, 0)

    def render(self):
        frames = self._vec.render()
        return None if frames is None else frames[0]

    def close(self) -> None:
        self._vec.close()


def _make_vec(num_envs: int = 1, autoreset_mode: str = "next_step", **kwargs: Any) -> VecEnv:
    """``gymnasium.make_vec``'s constructor: a :class:`VecEnv` in gymnasium's default NEXT_STEP mode."""
    kwargs.pop("max_episode_steps", None)  # episode lengths are the task's (config), not a wrapper's
    return VecEnv(num_envs, autoreset_mode=autoreset_mode, **kwargs)


def gym_id(task: str) -> str:
    """The gymnasium id of a registered task: ``hsi_sit`` → ``SkillMimic-HsiSit-v0``."""
    return "SkillMimic-" + "".join(part.capitalize() for part in task.split("_")) + "-v0"


#: gymnasium id → task of every registered task.
GYM_IDS: dict[str, str] = {gym_id(t): t for t in _core.TASKS}


def register() -> None:
    """Register every id of :data:`GYM_IDS` with gymnasium (idempotent; done on import)."""
    for gid, task in GYM_IDS.items():
        if gid in gym.registry:
            continue
        gym.register(
            id=gid,
            entry_point="skillmimic_rs.gym_env:SkillMimicEnv",
            vector_entry_point="skillmimic_rs.gym_env:_make_vec",
            kwargs={"task": task},
        )
