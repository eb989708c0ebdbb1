"""The SB3 and rsl_rl recipes of the guide (docs/tutorials/gymnasium.md), measured (issue 18): PPO of Stable-Baselines3 and of
rsl_rl on the built-in demo clips with the settings that work on SkillMimic's reward
(``skillmimic_rs.sb3.recipe_model``, ``skillmimic_rs.rsl_rl.runner_recipe``), next to SB3's
defaults, all at the same budget of environment steps and the same environments (32).

    .venv/bin/python scripts/experiments/sb3_recipe.py [--steps 204800] [--envs 32] [--seed 0] [--out runs/sb3_recipe]

Prints one JSON line per setting: the mean reward per environment step of the training rollouts
over the first and the last 10 % of the steps (the measure `scripts/demo.sh` prints for our own
PPO over its first and last 25 of 400 iterations),
the deterministic policy's mean episode return over 64 evaluation episodes before and after
training (16 environments, seed 1: the same episode starts for every setting), wall time, steps/s.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import time

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback

import skillmimic_rs
from skillmimic_rs.rsl_rl import runner_recipe
from skillmimic_rs.sb3 import Sb3VecEnv, recipe_model


def evaluate(act, episodes: int = 64, envs: int = 16, seed: int = 1) -> float:
    """Mean return of the first ``episodes`` episodes of a deterministic policy."""
    env = skillmimic_rs.VecEnv(envs, threads=0)
    obs, _ = env.reset(seed=seed)
    ret = np.zeros(envs)
    done_r: list[float] = []
    while len(done_r) < episodes:
        obs, rew, term, trunc, _ = env.step(act(obs))
        ret += rew
        for i in np.flatnonzero(term | trunc):
            done_r.append(float(ret[i]))
            ret[i] = 0.0
    env.close()
    return float(np.mean(done_r[:episodes]))


def window(per_step: list[float], first: bool) -> float:
    """Mean of the first / last 10 % of the per-step mean rewards."""
    w = max(1, len(per_step) // 10)
    part = per_step[:w] if first else per_step[-w:]
    return float(statistics.mean(part)) if part else float("nan")


class StepReward(BaseCallback):
    """The environments' mean reward of every SB3 step (before SB3 folds terminal values in)."""

    def __init__(self):
        super().__init__()
        self.means: list[float] = []

    def _on_step(self) -> bool:
        self.means.append(float(np.mean(self.locals["rewards"])))
        return True


def run_sb3(name: str, steps: int, envs: int, seed: int, out: pathlib.Path) -> dict:
    torch.manual_seed(seed)
    env = skillmimic_rs.VecEnv(envs, threads=0)
    if name == "sb3_recipe":
        model = recipe_model(env, seed=seed, device="cpu")
        venv = model.get_env()

        def act(o):
            return model.predict(venv.normalize_obs(o), deterministic=True)[0]
    else:  # SB3's defaults: nothing but the environment
        model = PPO("MlpPolicy", Sb3VecEnv(env), seed=seed, device="cpu")
        venv = model.get_env()

        def act(o):
            return model.predict(o, deterministic=True)[0]

    before = evaluate(act)
    cb = StepReward()
    t0 = time.time()
    model.learn(total_timesteps=steps, callback=cb)
    wall = time.time() - t0
    if hasattr(venv, "training"):
        venv.training = False
    res = {"setting": name, "steps": model.num_timesteps, "envs": envs, "seed": seed,
           "reward_per_step_first10pct": window(cb.means, True), "reward_per_step_last10pct": window(cb.means, False),
           "eval_return_before": before, "eval_return_after": evaluate(act),
           "wall_s": round(wall, 1), "steps_per_s": round(model.num_timesteps / wall, 1)}
    model.save(out / f"{name}.zip")
    venv.close()
    return res


def run_rsl_rl(steps: int, envs: int, seed: int, out: pathlib.Path) -> dict:
    from rsl_rl.runners import OnPolicyRunner
    from tensordict import TensorDict

    from skillmimic_rs.rsl_rl import RslRlVecEnv

    torch.manual_seed(seed)
    env = RslRlVecEnv(skillmimic_rs.VecEnv(envs, threads=0))
    cfg = dict(runner_recipe(), seed=seed)
    runner = OnPolicyRunner(env, cfg, log_dir=None, device="cpu")
    horizon = cfg["num_steps_per_env"]
    iters = max(1, steps // (envs * horizon))

    def act(obs):
        policy = runner.get_inference_policy("cpu")
        with torch.no_grad():
            return policy(TensorDict({"policy": torch.as_tensor(obs)}, batch_size=[obs.shape[0]])).numpy().astype("float32")

    before = evaluate(act)
    means: list[float] = []
    step = env.step

    def recording_step(actions):  # reward per step of each rollout, as for SB3
        out_ = step(actions)
        means.append(float(out_[1].mean()))
        return out_

    env.step = recording_step
    t0 = time.time()
    runner.learn(num_learning_iterations=iters)
    wall = time.time() - t0
    env.step = step
    n = iters * envs * horizon
    res = {"setting": "rsl_rl_recipe", "steps": n, "envs": envs, "seed": seed,
           "reward_per_step_first10pct": window(means, True), "reward_per_step_last10pct": window(means, False),
           "eval_return_before": before, "eval_return_after": evaluate(act),
           "wall_s": round(wall, 1), "steps_per_s": round(n / wall, 1)}
    env.close()
    return res


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--steps", type=int, default=204_800)
    p.add_argument("--envs", type=int, default=32)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="runs/sb3_recipe")
    p.add_argument("--only", choices=["sb3_recipe", "sb3_defaults", "rsl_rl_recipe"], action="append")
    a = p.parse_args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in a.only or ["sb3_recipe", "sb3_defaults", "rsl_rl_recipe"]:
        res = run_rsl_rl(a.steps, a.envs, a.seed, out) if name == "rsl_rl_recipe" else run_sb3(name, a.steps, a.envs, a.seed, out)
        print(json.dumps(res), flush=True)
        with open(out / "results.jsonl", "a") as f:
            f.write(json.dumps(res) + "\n")


if __name__ == "__main__":
    main()
