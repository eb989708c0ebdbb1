"""ModSkill skill reuse (seed 001 §3.5) through the Python environment, against PyTorch and the
numpy reference:

* a high-level task over a ``modular_attention`` checkpoint has a continuous action of one
  embedding per part; the PD targets it applies equal the checkpoint's part controllers run in
  PyTorch (``skillmimic_rs.policy.load_checkpoint``) on each embedding projected onto the unit
  sphere (``F.normalize``), clamped to [-1, 1];
* ``steering`` and ``reach``: a PyPI-mujoco shadow replays those PD targets; the observation's task
  part and the reward equal ``reference_hlc`` to 1e-5 with the goal of ``task_info`` in force
  during the step, over goals that are redrawn during the episode.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import torch

import reference_hlc as hl
import skillmimic_rs
from skillmimic_rs import _core
from skillmimic_rs.policy import load_checkpoint
from test_env_parity import TOL, Shadow

REPO = pathlib.Path(__file__).resolve().parent.parent
MOTIONS = [str(REPO / "motions")]
SMALL = ["ppo.modular.embed=16", "ppo.modular.proj_hidden=32", "ppo.modular.controller=[48, 32]"]


@pytest.fixture(scope="module")
def modular_llc(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("modreuse") / "modular.ckpt"
    _core.init_policy(str(path), "modular_attention", 902, ("box", 156), [32], seed=3, overrides=SMALL)
    return str(path)


def torch_targets(policy, latent: np.ndarray) -> np.ndarray:
    """The part controllers of the PyTorch mirror on unit-sphere embeddings."""
    actor = policy.actor
    out = torch.zeros(latent.shape[0], 156, dtype=torch.float64)
    x = torch.as_tensor(latent, dtype=torch.float64)
    with torch.no_grad():
        for k, part in enumerate(actor.parts):
            z = torch.nn.functional.normalize(x[:, k * actor.embed:(k + 1) * actor.embed], dim=-1)
            out[:, part.outputs] = part.controller.double()(z)
    return out.clamp(-1.0, 1.0).numpy()


@pytest.mark.parametrize("task", ["steering", "heading"])
def test_part_embeddings_drive_the_torch_part_controllers(modular_llc, task):
    env = skillmimic_rs.VecEnv(4, task=task, llc=modular_llc, motion=MOTIONS, autoreset_mode="disabled", threads=1)
    assert env.single_action_space.shape == (5 * 16,) and env.steps_per_action == 1 and env.choice_labels == []
    policy = load_checkpoint(modular_llc)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(5):
        latent = rng.normal(size=(4, 80)).astype(np.float32)
        env.step(latent)
        np.testing.assert_allclose(env.pd_targets(), torch_targets(policy, latent), rtol=0, atol=1e-5)
    env.close()


@pytest.mark.parametrize("task", ["steering", "reach"])
def test_goal_tasks_match_the_numpy_reference(modular_llc, task):
    env = skillmimic_rs.VecEnv(
        3, task=task, llc=modular_llc, motion=MOTIONS, autoreset_mode="disabled", threads=1,
        **{task: {"change_steps_min": 7, "change_steps_max": 13}},
    )
    sh = Shadow(env)
    assert sh.model.body(hl.REACH_HAND + 1).name == "R_Middle1"
    obs, _ = env.reset(seed=5)
    for i in range(3):
        sh.copy_state(i)
    rng = np.random.default_rng(1)
    terms_of = hl.steering_terms if task == "steering" else hl.reach_terms
    redraws = 0
    for k in range(40):
        goals = env.task_info().copy()
        if task == "steering":
            assert np.allclose(np.hypot(goals[:, 0], goals[:, 1]), 1.0, atol=1e-6)
            assert np.all((0.5 <= goals[:, 2]) & (goals[:, 2] <= 3.0)), goals
        else:
            assert np.all((0.0 <= goals[:, 2]) & (goals[:, 2] <= 2.0)), goals
        for i in range(3):
            np.testing.assert_allclose(obs[i, hl.STATE_OBS:], hl.task_observation(task, sh.state(i), goals[i]), err_msg=f"step {k} env {i} task observation", **TOL)
        latent = rng.normal(size=(3, 80)).astype(np.float32)
        obs, rew, term, trunc, info = env.step(latent)
        targets = env.pd_targets()
        for i in range(3):
            if term[i] or trunc[i]:
                continue
            sh.step(i, targets[i])
            st = sh.state(i)
            np.testing.assert_allclose(obs[i], hl.observation(task, st, env.task_info()[i]), err_msg=f"step {k} env {i} observation", **TOL)
            np.testing.assert_allclose(info["reward_terms"][i], terms_of(st, goals[i]), err_msg=f"step {k} env {i} reward", **TOL)
            np.testing.assert_allclose(rew[i], terms_of(st, goals[i])[-1], **TOL)
        redraws += int(np.any(env.task_info() != goals))
    assert redraws >= 3, "goals are redrawn every 7-13 steps"
    env.close()


def test_a_skill_policy_keeps_discrete_steering_choices(tmp_path):
    llc = tmp_path / "skill.ckpt"
    _core.init_policy(str(llc), "gaussian_mlp", 902, ("box", 156), [32], seed=2)
    env = skillmimic_rs.VecEnv(2, task="steering", llc=str(llc), motion=MOTIONS, threads=1)
    assert env.single_action_space.n == 3 and env.choice_labels == [12, 13, 11] and env.steps_per_action == 3
    env.close()


def test_fused_onnx_gives_the_environments_pd_targets(modular_llc, tmp_path, skillmimic_bin):
    """`skillmimic export --fused` of a steering policy over part embeddings: onnxruntime on the
    environment's observations gives the PD targets the environment applies for the policy's mean
    embeddings."""
    import json

    import onnx
    import onnxruntime as ort

    from conftest import run_cli

    out = tmp_path / "steer"
    run_cli(skillmimic_bin, "train", "--preset", "tiny", "--task", "steering", "--llc", modular_llc, "--motion", MOTIONS[0],
            "--set", "run.iterations=1", "--set", "env.num_envs=8", "--set", "ppo.minibatch=64", "--set", "ppo.hidden=[32]", "--out", str(out))
    ckpt = out / "latest.safetensors"
    alone = subprocess_run([str(skillmimic_bin), "export", "--checkpoint", str(ckpt), "--out", str(tmp_path / "alone.onnx")])
    assert alone.returncode != 0 and "--fused" in alone.stderr
    run_cli(skillmimic_bin, "export", "--checkpoint", str(ckpt), "--out", str(tmp_path / "fused.onnx"), "--fused")
    onnx.checker.check_model(onnx.load(str(tmp_path / "fused.onnx")), full_check=True)
    side = json.loads((tmp_path / "fused.onnx.json").read_text())
    assert side["graph"] == "fused_part_embeddings" and side["act_dim"] == 156 and side["choices"] == []
    sess = ort.InferenceSession(str(tmp_path / "fused.onnx"), providers=["CPUExecutionProvider"])
    policy = _core.Policy.load(str(ckpt))
    env = skillmimic_rs.VecEnv(8, task="steering", llc=modular_llc, motion=MOTIONS, threads=1)
    obs, _ = env.reset(seed=2)
    worst = 0.0
    for _ in range(10):
        mu, _ = policy.infer(obs)
        actions, latent = sess.run(["actions", "latent"], {"obs": obs})
        np.testing.assert_allclose(latent, mu, rtol=1e-5, atol=1e-5)
        obs, *_ = env.step(mu)
        worst = max(worst, float(np.abs(actions - env.pd_targets()).max()))
    print(f"fused part-embedding graph vs the environment's PD targets: max |d| {worst:.2e}")
    assert worst < 1e-5
    env.close()


def subprocess_run(args):
    import subprocess

    return subprocess.run(args, capture_output=True, text=True)
