"""A warning for RL libraries' default exploration on SkillMimic's reward.

The imitation reward is a product of exponentials of tracking errors: it is near zero unless the
whole body and the ball follow the reference. A Gaussian policy with σ ≈ 1 (SB3's ``log_std_init =
0``, rsl_rl's ``init_std = 1``) on actions in [-1, 1] that become PD targets of ±π rad throws the
character off the clip at every step, the reward stays ~0 and PPO has nothing to learn from
(measured: SB3 defaults, 100 k steps, episode reward ~1e-12). The paper fixes σ = e^-2.9 ≈ 0.055.
The adapters watch the first steps and warn once when actions vary that much while the reward is
that small.
"""

from __future__ import annotations

import warnings

import numpy as np

WINDOW = 64          # policy steps watched
SPREAD = 0.5         # mean per-dimension std of actions across environments above which we warn
REWARD = 1e-3        # mean reward per step below which we warn


class ExplorationCheck:
    def __init__(self, library: str, setting: str):
        self.library, self.setting = library, setting
        self.steps = 0
        self.spread = 0.0
        self.reward = 0.0

    def observe(self, actions: np.ndarray, rewards: np.ndarray) -> None:
        """Record one step (continuous actions only, several environments); warn once at the end of the window."""
        if self.steps >= WINDOW or actions.ndim != 2 or actions.shape[0] < 2:
            return
        self.steps += 1
        self.spread += float(np.std(actions, axis=0).mean())
        self.reward += float(np.mean(rewards))
        if self.steps == WINDOW:
            spread, reward = self.spread / WINDOW, self.reward / WINDOW
            if spread > SPREAD and reward < REWARD:
                warnings.warn(
                    f"{self.library}: actions vary with std {spread:.2f} across environments while the reward is "
                    f"{reward:.1e} per step. SkillMimic's reward is ~0 under such wide exploration and PPO will not learn; "
                    f"use a small fixed action noise ({self.setting}; docs/tutorials/gymnasium.md).",
                    RuntimeWarning,
                    stacklevel=3,
                )
