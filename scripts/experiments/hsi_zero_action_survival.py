"""Survival of the TokenHSI character under zero actions (PD targets at the rest pose) in hsi_follow,
from the rest pose and from reference frames of the clips in CLIPS (default runs/devpack/clips, written
by `skillmimic retarget --to tokenhsi` from BallPlay-M run/turn/lrun/rrun): 64 environments, 10 s.

Usage: python scripts/experiments/hsi_zero_action_survival.py [CLIPS]
"""

import sys

import numpy as np

import skillmimic_rs


def main(clips: str) -> None:
    for init, motion in (("default", []), ("reference", [clips])):
        env = skillmimic_rs.VecEnv(num_envs=64, task="hsi_follow", autoreset_mode="disabled", threads=2,
                                   hsi={"state_init": init, "style_motion": motion})
        env.reset(seed=0)
        n = env.num_envs
        done, term = np.zeros(n, bool), np.zeros(n, bool)
        length, err, power = np.zeros(n, int), np.zeros(n), []
        for _ in range(300):
            _, _, te, tr, info = env.step(np.zeros(env.action_space.shape, np.float32))
            alive = ~done
            length[alive] += 1
            term |= alive & te
            err[alive] = info["frame_metrics"][alive, 0]
            power.append(info["reward_terms"][alive, 1].mean())
            done |= te | tr
            if done.all():
                break
        print(f"{init:9s} starts, zero actions: mean length {length.mean():.1f} steps ({length.mean() / 30:.2f} s), "
              f"terminated {term.mean() * 100:.0f} %, path error at the end {err.mean():.2f} m, "
              f"power term/step {np.mean(power):.3f}")
        env.close()


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/devpack/clips")
