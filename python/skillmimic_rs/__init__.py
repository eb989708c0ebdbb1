"""skillmimic_rs: SkillMimic / SkillMimic-V2 on MuJoCo with a Rust core.

Quick start::

    import skillmimic_rs
    env = skillmimic_rs.VecEnv(num_envs=16)          # built-in demo clips, paper defaults
    obs, info = env.reset(seed=0)
    obs, rew, term, trunc, info = env.step(env.action_space.sample())

    summary = skillmimic_rs.train(preset="tiny", iterations=20, out="runs/a")   # the paper's PPO
    report = skillmimic_rs.evaluate(summary["checkpoint"])                        # `skillmimic eval`

The console command ``skillmimic`` (and ``python -m skillmimic_rs``) is the full command-line tool;
``gymnasium.make_vec("SkillMimic-Imitation-v0", num_envs=16)`` and ``gymnasium.make(...)`` work
after ``import skillmimic_rs`` (one id per task, ``skillmimic_rs.GYM_IDS``).

``mujoco`` (3.17.0) is imported first: the Rust extension uses the very same ``libmujoco`` that
the ``mujoco`` package loaded. Without a display, ``MUJOCO_GL`` defaults to ``egl`` (headless
rendering).
"""

from __future__ import annotations

import os
import sys
import types

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"

import mujoco as _mujoco  # noqa: E402,F401  (load libmujoco before the extension)

from . import _core  # noqa: E402
from ._core import ACT_DIM, BUILTIN_DEMO, CHARACTERS, FRAME_METRIC_NAMES, HIGH_LEVEL_TASKS, OBS_DIM, POLICY_FAMILIES, TASKS, TERM_NAMES, core_version  # noqa: E402
from .motion import register_generator  # noqa: E402
from .vec_env import VecEnv, load_config  # noqa: E402
from .api import amass_to_smpl, cli, evaluate, play, retarget_amass, retarget_bvh, retarget_positions, train  # noqa: E402
from .gym_env import GYM_IDS, SkillMimicEnv, gym_id, register as _register_gym  # noqa: E402

__version__ = core_version()
_register_gym()  # gymnasium.make("SkillMimic-Imitation-v0") / make_vec(..., num_envs=N)

#: Observation blocks: name -> (start, stop) index range of the 902-wide observation (from the
#: Rust core's ``obs::BLOCKS``, in observation order).
OBS_BLOCKS: dict[str, tuple[int, int]] = {name: (int(a), int(b)) for name, (a, b) in _core.OBS_BLOCKS.items()}

__all__ = [
    "VecEnv",
    "train",
    "evaluate",
    "play",
    "amass_to_smpl",
    "retarget_amass",
    "retarget_bvh",
    "retarget_positions",
    "cli",
    "SkillMimicEnv",
    "GYM_IDS",
    "gym_id",
    "load_config",
    "register_generator",
    "OBS_DIM",
    "OBS_BLOCKS",
    "ACT_DIM",
    "CHARACTERS",
    "TERM_NAMES",
    "FRAME_METRIC_NAMES",
    "TASKS",
    "HIGH_LEVEL_TASKS",
    "POLICY_FAMILIES",
    "BUILTIN_DEMO",
    "core_version",
    "__version__",
]


class _Package(types.ModuleType):
    """The package's module type: ``import skillmimic_rs.train`` (the torchrun entry point,
    ``python -m skillmimic_rs.train``) must not replace the function ``skillmimic_rs.train`` with
    that submodule, which Python's import system would otherwise do by setting the attribute."""

    def __setattr__(self, name: str, value: object) -> None:
        if name == "train" and isinstance(value, types.ModuleType) and value.__name__ == f"{__name__}.train":
            return  # the submodule stays reachable as sys.modules["skillmimic_rs.train"]
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
