"""How long the TokenHSI character stays up in hsi_follow when its PD targets replay a reference clip open
loop: each episode starts from a random frame of the clips in a folder (reference-state initialisation) and
every policy step sets the PD targets to the clip's next frame (the last frame once the clip ends). A clip
that physics can follow without feedback for longer is an easier reference; none can be followed for long
without it (no clip's root is actuated). Compare the built-in procedural walks with retargeted BallPlay-M
running, the same way (docs/tokenhsi.md, "Built-in walks").

Usage: python scripts/experiments/hsi_open_loop_survival.py CLIP_DIR [CLIP_DIR ...]
(write the built-in walks with `skillmimic synth-motions --character tokenhsi --out-dir DIR`).
Prints, per folder: episodes, mean time up (s, capped at 2 s) and the share still up at 1 s and 2 s.
"""

import pathlib
import sys

import numpy as np
from safetensors.numpy import load_file

import skillmimic_rs

ENVS, CAP = 128, 60  # 2 s at 30 Hz


def clips(folder: str) -> list[np.ndarray]:
    return [load_file(str(p))["dof_pos"].astype(np.float64) for p in sorted(pathlib.Path(folder).rglob("*.safetensors"))]


def action_map() -> tuple[np.ndarray, np.ndarray]:
    """(offset, scale) of target = offset + scale * a per action entry, ASE's rule from the released joint
    limits: a 3-DoF joint scales all three hinges by min(1.2 x its widest limit, pi), offset 0; an elbow
    [-160, 0] deg maps to its centre -80 deg +- 0.7 x its width."""
    widest = {"abdomen": 90, "neck": 60, "shoulder": 180, "hip": 140, "knee": 160, "ankle": 55}
    joints = ["abdomen", "neck", "shoulder", "elbow", "shoulder", "elbow", "hip", "knee", "ankle", "hip", "knee", "ankle"]
    offset, scale = [], []
    for j in joints:
        if j == "elbow":
            offset.append(np.radians(-80.0))
            scale.append(np.radians(0.7 * 160.0))
        else:
            offset += [0.0] * 3
            scale += [min(np.radians(1.2 * widest[j]), np.pi)] * 3
    return np.array(offset), np.array(scale)


def main(folders: list[str]) -> None:
    for folder in folders:
        refs = clips(folder)
        offset, scale = action_map()
        env = skillmimic_rs.VecEnv(num_envs=ENVS, task="hsi_follow", autoreset_mode="disabled", threads=2,
                                   hsi={"state_init": "reference", "style_motion": [folder]})
        env.reset(seed=1)
        # which clip frame each episode started from
        start = []
        for i in range(ENVS):
            dof = env.get_state(i)[0][7:39]
            best = min(((np.abs(c - dof).max(axis=1).min(), k, int(np.abs(c - dof).max(axis=1).argmin()))
                        for k, c in enumerate(refs)))
            assert best[0] < 1e-4, f"env {i}: no clip frame matches its start ({best[0]})"
            start.append(best[1:])
        up = np.zeros(ENVS, int)
        done = np.zeros(ENVS, bool)
        for step in range(1, CAP + 1):
            a = np.zeros(env.action_space.shape, np.float32)
            for i, (k, t) in enumerate(start):
                c = refs[k]
                target = c[min(t + step, len(c) - 1)]
                a[i] = np.clip((target - offset) / scale, -1.0, 1.0)
            _, _, te, tr, _ = env.step(a)
            up[~done] += 1
            done |= te | tr
            if done.all():
                break
        secs = up / 30.0
        print(f"{folder}: {len(refs)} clips, {ENVS} episodes, open-loop time up {secs.mean():.2f} s (cap 2 s), "
              f"up at 1 s {np.mean(up >= 30) * 100:.0f} %, at 2 s {np.mean(up >= CAP) * 100:.0f} %")
        env.close()


if __name__ == "__main__":
    main(sys.argv[1:])
