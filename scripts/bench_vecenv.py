"""Benchmark: ``skillmimic_rs.VecEnv`` steps/s from Python vs. a numpy environment that steps the
official ``mujoco`` package and computes the same observations and rewards (the independent
reference of ``tests/reference_env.py``), same number of environments, same run.

The two are interleaved in chunks of steps so machine drift cancels in the ratio.

    .venv/bin/python scripts/bench_vecenv.py [--envs 64] [--steps 60] [--rounds 3]
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import mujoco
import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

import reference_env as ref  # noqa: E402
import skillmimic_rs  # noqa: E402


class NumpyEnv:
    """The anchor: per-environment Python loop over PyPI mujoco with numpy obs/reward."""

    def __init__(self, xml: str, clips, n: int, episode_length: int, seed: int):
        self.m = mujoco.MjModel.from_xml_string(xml)
        self.d = [mujoco.MjData(self.m) for _ in range(n)]
        self.clips = clips
        self.n, self.ep_len = n, episode_length
        self.rng = np.random.default_rng(seed)
        names = [self.m.body(b).name for b in range(1, 54)]
        self.idx = np.array([3 * (names.index(self.m.actuator(a).name.rsplit("_", 1)[0]) - 1) + "xyz".index(self.m.actuator(a).name[-1]) for a in range(self.m.nu)])
        self.ep = [None] * n
        self.prev = [None] * n
        self.obs = np.zeros((n, ref.OBS_SIZE), np.float32)
        for i in range(n):
            self.reset(i)

    def reset(self, i: int) -> None:
        c = int(self.rng.integers(len(self.clips)))
        clip, dref = self.clips[c]
        s = int(self.rng.integers(2, clip["num_frames"] - 1))
        qpos, qvel = ref.reset_qpos_qvel(self.m, clip, dref, s)
        d = self.d[i]
        d.qpos[:], d.qvel[:], d.ctrl[:], d.qacc_warmstart[:] = qpos, qvel, 0.0, 0.0
        mujoco.mj_forward(self.m, d)
        st = ref.extract_state(self.m, d)
        self.prev[i] = st["dof_vel"].copy()
        self.ep[i] = [c, s, 0, min(clip["num_frames"] - s, self.ep_len)]
        self.obs[i] = ref.observation(st, clip["skill"])

    def step(self, actions: np.ndarray):
        rew = np.zeros(self.n, np.float32)
        for i, d in enumerate(self.d):
            d.ctrl[:] = np.clip(actions[i].astype(np.float64), -1, 1)[self.idx] * np.pi
            mujoco.mj_step(self.m, d)
            mujoco.mj_step(self.m, d)
            mujoco.mj_kinematics(self.m, d)
            mujoco.mj_comPos(self.m, d)
            mujoco.mj_comVel(self.m, d)
            ep = self.ep[i]
            ep[2] += 1
            clip, dref = self.clips[ep[0]]
            t = ep[1] + ep[2]
            st = ref.extract_state(self.m, d)
            sim_h, ref_h = ref.hoi_sim(st), ref.hoi_ref(clip, dref, t)
            cg = ref.contact_graph(st)
            terms = ref.reward_terms(sim_h, self.prev[i], ref_h, cg, ref.reference_graph(float(clip["contact"][t]), "exact"), clip["skill"])
            rew[i] = terms[-1]
            self.prev[i] = st["dof_vel"].copy()
            self.obs[i] = ref.observation(st, clip["skill"])
            if (st["body_pos"][0, 2] < 0.3 and ep[2] > 1) or ep[2] + 1 >= ep[3]:
                self.reset(i)
        return self.obs, rew


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=64)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--chunk", type=int, default=10)
    ap.add_argument("--threads", type=int, default=0, help="Rust simulation threads (0 = all cores)")
    a = ap.parse_args()
    files = sorted((REPO / "motions").glob("*.safetensors"))
    env = skillmimic_rs.VecEnv(num_envs=a.envs, threads=a.threads, copy=False)
    clips = []
    for name, _, _ in env.clips:
        c = ref.load_clip(next(f for f in files if f.stem == name))
        clips.append((c, ref.derive_reference(c)))
    npenv = NumpyEnv(env.mjcf_xml, clips, a.envs, env.config["episode_length"], seed=0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = (0.3 * rng.uniform(-1, 1, (a.steps, a.envs, 156))).astype(np.float32)
    t_rust = t_np = 0.0
    for r in range(a.rounds + 1):
        for c0 in range(0, a.steps, a.chunk):
            ks = range(c0, min(c0 + a.chunk, a.steps))
            t0 = time.perf_counter()
            for k in ks:
                env.step(actions[k])
            t1 = time.perf_counter()
            for k in ks:
                npenv.step(actions[k])
            t2 = time.perf_counter()
            if r > 0:  # round 0 warms up
                t_rust += t1 - t0
                t_np += t2 - t1
    n = a.rounds * a.steps * a.envs
    rust, numpy_ = n / t_rust, n / t_np
    import os

    print(f"bench vecenv: {a.envs} envs, {a.rounds} x {a.steps} steps, {os.cpu_count()} cores, demo clips, full hands")
    print(f"  skillmimic_rs.VecEnv (Rust core, {env.config['threads'] or os.cpu_count()} threads): {rust:9.0f} env-steps/s")
    print(f"  numpy reference on PyPI mujoco (1 Python thread):         {numpy_:9.0f} env-steps/s")
    print(f"  ratio VecEnv / numpy = {rust / numpy_:.2f}x   (target >= 2x)")
    env.close()


if __name__ == "__main__":
    main()
