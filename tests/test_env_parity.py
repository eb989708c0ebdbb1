"""The Rust environment (through ``skillmimic_rs.VecEnv``) against the official ``mujoco`` package
and the independent numpy reference of ``tests/reference_env.py``.

* physics: a PyPI-mujoco shadow of each environment, started from the VecEnv's state and driven
  by the same actions, stays bit-identical for 1000 physics steps;
* observations and rewards: the numpy reference, fed from the shadow's MuJoCo state, reproduces
  the VecEnv's observations, contact graph and frame metrics to 1e-5 and the reward terms to 1e-5
  *relative* over a few hundred random steps with automatic resets (terminal observations
  included), for every reward variant, both contact-graph modes and, once, with every reward
  weight non-zero (the terms whose default weight is 0 are otherwise identically 1).

Reward terms are products of exponentials: contact-graph factors are e^-5k and totals after a fall
are far below 1e-5, so an absolute tolerance would accept almost any wrong tiny term; they are
compared relatively (``assert_terms_close``).
"""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np
import pytest

import reference_env as ref
from reference_bounce import FloorBounce
import skillmimic_rs
from conftest import find_shared, skeleton_dof_index

REPO = pathlib.Path(__file__).resolve().parent.parent
TOL = dict(rtol=1e-5, atol=1e-5)
# reward terms: relative; the absolute floor only covers float32 subnormals (below 1.2e-38 a
# float32 keeps fewer than 24 significant bits)
TERM_TOL = dict(rtol=1e-5, atol=1e-37)

# every reward weight non-zero, keys of `env.reward` (RewardConfig) and of the numpy reference
ALL_WEIGHTS = {"w_pv": 0.5, "w_rv": 0.1, "w_or": 0.3, "w_opv": 0.2, "w_orv": 0.05}


def reference_weights(reward_cfg: dict) -> dict:
    """The numpy reference's weight overrides for an `env.reward` table (`w_x` -> `x`)."""
    return {k[2:]: v for k, v in reward_cfg.items() if k.startswith("w_")}


def assert_terms_close(got, want, msg: str = "") -> None:
    """Reward terms (or a total) equal to 1e-5 relative, also where they are e^-20 or 1e-30."""
    got, want = np.asarray(got, np.float64), np.asarray(want, np.float64)
    np.testing.assert_allclose(got, want, err_msg=msg, **TERM_TOL)


class Shadow:
    """PyPI-mujoco copies of the VecEnv's environments, stepped like the Rust core."""

    def __init__(self, env: skillmimic_rs.VecEnv):
        self.env = env
        self.model = mujoco.MjModel.from_xml_string(env.mjcf_xml)
        self.datas = [mujoco.MjData(self.model) for _ in range(env.num_envs)]
        self.idx = skeleton_dof_index(self.model)
        self.substeps = 2
        self.bounce = [FloorBounce(self.model) for _ in range(env.num_envs)]

    def copy_state(self, i: int) -> None:
        """Take environment i's state after a (re)set: same clearing as the core's reset."""
        qpos, qvel = self.env.get_state(i)
        d = self.datas[i]
        d.time = 0.0
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        d.ctrl[:] = 0.0
        d.qacc_warmstart[:] = 0.0
        mujoco.mj_forward(self.model, d)
        self.bounce[i].reset()

    def step(self, i: int, action: np.ndarray) -> None:
        d = self.datas[i]
        d.ctrl[:] = np.clip(action.astype(np.float64), -1.0, 1.0)[self.idx] * np.pi
        for _ in range(self.substeps):
            mujoco.mj_step(self.model, d)
            self.bounce[i].after_substep(d)
        # kinematics of the new state; contacts stay those of the last sub-step
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        mujoco.mj_comVel(self.model, d)

    def state(self, i: int) -> dict:
        return ref.extract_state(self.model, self.datas[i])


def clip_table(env: skillmimic_rs.VecEnv, files: list[pathlib.Path]) -> list[tuple[dict, dict]]:
    """Clips of the numpy side in the VecEnv's library order (matched by name)."""
    by_name = {}
    for f in files:
        c = ref.load_clip(f)
        by_name[f.stem] = (c, ref.derive_reference(c))
    return [by_name[name] for name, _, _ in env.clips]


def test_physics_bit_identical_for_1000_steps_across_environments():
    env = skillmimic_rs.VecEnv(num_envs=4, autoreset_mode="disabled", threads=2)
    env.reset(seed=3)
    sh = Shadow(env)
    for i in range(env.num_envs):
        sh.copy_state(i)
    rng = np.random.default_rng(0)
    for k in range(500):  # 500 policy steps = 1000 mj_step per environment
        a = (0.4 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
        env.step(a)
        for i in range(env.num_envs):
            sh.step(i, a[i])
    for i in range(env.num_envs):
        qpos, qvel = env.get_state(i)
        assert np.array_equal(qpos, sh.datas[i].qpos) and np.array_equal(qvel, sh.datas[i].qvel), f"env {i} diverged"
    env.close()


def run_parity(env: skillmimic_rs.VecEnv, files: list[pathlib.Path], steps: int, seed: int, mode: str, variant: str, weights: dict | None = None) -> int:
    """Drive `env` and a shadow for `steps` random steps, checking everything against the numpy
    reference (`weights`: the reference's overrides of its default reward weights)."""
    clips = clip_table(env, files)
    sh = Shadow(env)
    obs, info = env.reset(seed=seed)
    prev = []
    for i in range(env.num_envs):
        sh.copy_state(i)
        st = sh.state(i)
        np.testing.assert_allclose(ref.observation(st, int(info["skill"][i])), obs[i], **TOL)
        prev.append(st["dof_vel"].copy())
    rng = np.random.default_rng(seed)
    resets = 0
    for k in range(steps):
        a = (0.3 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
        ep = env.episode_info()  # episodes before the step (clip, reference start)
        obs, rew, term, trunc, info = env.step(a)
        terms = info["reward_terms"]
        for i in range(env.num_envs):
            sh.step(i, a[i])
            st = sh.state(i)
            clip, dref = clips[ep["clip"][i]]
            skill = int(ep["skill"][i])
            t = min(int(ep["ref_frame"][i]) + 1, clip["num_frames"] - 1)
            sim_h, ref_h = ref.hoi_sim(st), ref.hoi_ref(clip, dref, t)
            cg_sim = ref.contact_graph(st, mode)
            cg_ref = ref.reference_graph(float(clip["contact"][t]), mode)
            want = ref.reward_terms(sim_h, prev[i], ref_h, cg_sim, cg_ref, skill, variant=variant, mode=mode, weights=weights)
            assert_terms_close(terms[i], want, f"step {k} env {i} reward terms")
            assert_terms_close(rew[i], want[-1], f"step {k} env {i} reward")
            np.testing.assert_allclose(info["contact_graph"][i], cg_sim, **TOL)
            np.testing.assert_allclose(info["frame_metrics"][i], ref.frame_metrics(sim_h, ref_h, cg_sim, cg_ref), **TOL)
            o = ref.observation(st, skill)
            done = term[i] or trunc[i]
            if done:
                resets += 1
                np.testing.assert_allclose(info["final_obs"][i], o, err_msg=f"step {k} env {i} terminal obs", **TOL)
                sh.copy_state(i)  # the core reset this environment inside the step
                st = sh.state(i)
                o = ref.observation(st, int(info["skill"][i]))
            np.testing.assert_allclose(obs[i], o, err_msg=f"step {k} env {i} observation", **TOL)
            prev[i] = st["dof_vel"].copy()
            # the physics of the shadow stays exact
            qpos, qvel = env.get_state(i)
            assert np.array_equal(qpos, sh.datas[i].qpos), f"step {k} env {i}: qpos differs"
    return resets


@pytest.mark.parametrize(
    "variant,mode,hands,weights",
    [
        ("skillmimic", "exact", "full", {}),
        ("additive", "force_threshold", "box", {}),
        ("deepmimic", "exact", "full", {}),
        ("no_contact_graph", "force_threshold", "full", {}),
        # every term active: body / dof velocity, ball rotation / velocity / angular velocity
        ("skillmimic", "force_threshold", "full", ALL_WEIGHTS),
        ("skillmimic", "exact", "box", ALL_WEIGHTS),
    ],
    ids=["skillmimic-exact", "additive-force", "deepmimic-exact", "no_cg-force", "all_weights-force", "all_weights-exact"],
)
def test_observations_and_rewards_match_numpy_reference_on_demo_clips(variant, mode, hands, weights):
    files = sorted((REPO / "motions").glob("*.safetensors"))
    reward = {"variant": variant, "contact_graph": mode, **weights}
    cfg = {"episode_length": 25, "hands": hands, "threads": 2, "reward": reward}
    env = skillmimic_rs.VecEnv(num_envs=3, config=cfg)
    resets = run_parity(env, files, steps=120, seed=1, mode=mode, variant=variant, weights=reference_weights(reward))
    assert resets >= 6, "the run must include automatic resets"
    env.close()


@pytest.mark.parametrize("mode,steps,min_resets", [("exact", 300, 10), ("force_threshold", 300, 10)])
def test_observations_and_rewards_match_numpy_reference_on_real_clips(shared_dir, mode, steps, min_resets):
    files = sorted((shared_dir / "data/ballplay_m").rglob("*.pt"))
    files = [f for f in files if f.parent.name in ("run", "layup", "pick_40", "shot_style1")][:8]
    # the contact-graph mode is named: the default is not this test's business
    cfg = {"motion": [str(f) for f in files], "episode_length": 40, "threads": 2, "reward": {"variant": "skillmimic", "contact_graph": mode}}
    env = skillmimic_rs.VecEnv(num_envs=4, config=cfg)
    resets = run_parity(env, files, steps=steps, seed=2, mode=mode, variant="skillmimic")
    print(f"{steps} steps x 4 envs on {len(files)} real clips ({mode}), {resets} resets: obs match to 1e-5, rewards to 1e-5 relative")
    assert resets >= min_resets
    env.close()
