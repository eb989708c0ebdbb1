"""`skillmimic import-rlgames`: checkpoints in the exact rl_games layout, written here by PyTorch
(random weights, Adam state, a frame counter above 2^31, numpy scalars), import without running
pickle code; the imported policy's actions and values equal the rl_games forward pass in PyTorch
on real observations of the environment; a .pth whose pickle would run code is refused."""

from __future__ import annotations

import collections
import math
import os

import numpy as np

from conftest import require_module, run_cli

torch = require_module("torch")



def _mlp(g, dims):
    return [(torch.randn(o, i, generator=g) / math.sqrt(i), torch.randn(o, generator=g) * 0.1) for i, o in zip(dims[:-1], dims[1:])]


def write_rlgames(path, obs: int, hidden, head: str, outputs: int, seed: int = 0, fit: np.ndarray | None = None) -> dict:
    """A checkpoint as rl_games' A2C agent saves it (reference-facts §7.5, §8.3). `fit`: rows of
    observations whose mean and variance become the normaliser statistics (else random ones)."""
    g = torch.Generator().manual_seed(seed)
    sd = collections.OrderedDict()
    for trunk, out_name, out_width in (("actor_mlp", head, outputs), ("critic_mlp", "value", 1)):
        layers = _mlp(g, [obs, *hidden, out_width])
        for k, (w, b) in enumerate(layers[:-1]):
            sd[f"a2c_network.{trunk}.{2 * k}.weight"], sd[f"a2c_network.{trunk}.{2 * k}.bias"] = w, b
        sd[f"a2c_network.{out_name}.weight"], sd[f"a2c_network.{out_name}.bias"] = layers[-1]
    if head == "mu":
        sd["a2c_network.sigma"] = torch.full((outputs,), -2.9)
    running = collections.OrderedDict(
        running_mean=torch.randn(obs, generator=g, dtype=torch.float64) * 0.5,
        running_var=torch.rand(obs, generator=g, dtype=torch.float64) * 3 + 0.05,
        count=torch.tensor(123456.0, dtype=torch.float64),
    )
    if fit is not None:
        running["running_mean"] = torch.from_numpy(fit.astype(np.float64).mean(0))
        running["running_var"] = torch.from_numpy(fit.astype(np.float64).var(0))
    reward = collections.OrderedDict(
        running_mean=torch.tensor([0.3], dtype=torch.float64), running_var=torch.tensor([2.5], dtype=torch.float64), count=torch.tensor(99.0, dtype=torch.float64)
    )
    params = [torch.nn.Parameter(v.clone()) for v in sd.values()]
    opt = torch.optim.Adam(params, lr=2e-5)
    sum((p**2).sum() for p in params).backward()
    opt.step()
    torch.save({"model": sd, "running_mean_std": running, "reward_mean_std": reward, "epoch": 4321, "frame": 2**31 + 12345,
                "optimizer": opt.state_dict(), "last_mean_rewards": np.float32(3.25), "env_state": None}, path)
    return {"model": sd, "running": running, "reward": reward, "hidden": list(hidden), "head": head}


def rlgames_forward(ck: dict, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """rl_games inference: normalise in float32 with the float64 statistics cast down, clamp ±5,
    ReLU MLPs, value un-normalised (clamp ±5, scale, shift)."""
    sd, r, v = ck["model"], ck["running"], ck["reward"]
    t = torch.from_numpy(x)
    t = ((t - r["running_mean"].float()) / torch.sqrt(r["running_var"].float() + 1e-5)).clamp(-5, 5)

    def run(trunk, out):
        h = t
        for k in range(len(ck["hidden"])):
            h = torch.relu(h @ sd[f"a2c_network.{trunk}.{2 * k}.weight"].T + sd[f"a2c_network.{trunk}.{2 * k}.bias"])
        return h @ sd[f"a2c_network.{out}.weight"].T + sd[f"a2c_network.{out}.bias"]

    with torch.no_grad():
        mu = run("actor_mlp", ck["head"])
        val = run("critic_mlp", "value")[:, 0].clamp(-5, 5) * torch.sqrt(v["running_var"].float() + 1e-5) + v["running_mean"].float()
    return mu.numpy(), val.numpy()


def _observations(env, steps: int = 20) -> np.ndarray:
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=1)
    rows = [obs]
    for _ in range(steps):
        obs, *_ = env.step(env.action_space.sample() if hasattr(env.action_space, "sample") else rng.uniform(-1, 1, (env.num_envs, 156)))
        rows.append(obs)
    return np.concatenate(rows).astype(np.float32)


def test_skill_and_high_level_policies_import_and_act_like_pytorch(tmp_path, skillmimic_bin):
    import skillmimic_rs

    skill = write_rlgames(tmp_path / "llc.pth", 902, (1024, 512, 512), "mu", 156)
    r = run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "llc.pth"), "--kind", "skill", "--out", str(tmp_path / "llc.safetensors"))
    assert "epoch 4321, frame 2147495993" in r.stdout, r.stdout
    env = skillmimic_rs.VecEnv(num_envs=8)
    env.action_space.seed(0)
    x = _observations(env)
    mu, val = skillmimic_rs._core.Policy.load(str(tmp_path / "llc.safetensors")).infer(x)
    ref_mu, ref_val = rlgames_forward(skill, x)
    print(f"skill policy on {len(x)} observations: max |d mu| {np.abs(mu - ref_mu).max():.2e} (max |mu| {np.abs(ref_mu).max():.2f}), max |d value| {np.abs(val - ref_val).max():.2e}")
    np.testing.assert_allclose(mu, ref_mu, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(val, ref_val, rtol=1e-5, atol=1e-5)
    # the imported policy evaluates in the environment
    run_cli(skillmimic_bin, "eval", "--checkpoint", str(tmp_path / "llc.safetensors"), "--episodes", "2", "--num-envs", "2", "--out", str(tmp_path / "m.json"))

    # a high-level controller for the heading task, over the imported skill policy
    henv = skillmimic_rs.VecEnv(num_envs=4, task="heading", llc=str(tmp_path / "llc.safetensors"))
    d = henv.single_observation_space.shape[0]
    hlc = write_rlgames(tmp_path / "hlc.pth", d, (1024, 512), "logits", 3, seed=1)
    run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "hlc.pth"), "--kind", "hlc", "--task", "heading", "--out", str(tmp_path / "hlc.safetensors"))
    henv.action_space.seed(0)
    hx = _observations(henv, 6)
    logits, hval = skillmimic_rs._core.Policy.load(str(tmp_path / "hlc.safetensors")).infer(hx)
    ref_logits, ref_hval = rlgames_forward(hlc, hx)
    np.testing.assert_allclose(logits, ref_logits, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(hval, ref_hval, rtol=1e-5, atol=1e-5)
    assert (logits.argmax(1) == ref_logits.argmax(1)).all()


class _Evil:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_pth_whose_pickle_runs_code_is_refused_unrun(tmp_path, skillmimic_bin):
    import subprocess

    marker = tmp_path / "pwned"
    ck = write_rlgames(tmp_path / "ok.pth", 902, (64,), "mu", 156)
    torch.save({"model": ck["model"], "running_mean_std": ck["running"], "env_state": _Evil(marker)}, tmp_path / "evil.pth")
    r = subprocess.run([str(skillmimic_bin), "import-rlgames", str(tmp_path / "evil.pth"), "--kind", "skill"], capture_output=True, text=True)
    assert r.returncode != 0 and "nothing was executed" in r.stderr and "system" in r.stderr, r.stderr
    assert not marker.exists()
    # shape errors name what was expected
    write_rlgames(tmp_path / "small.pth", 100, (64,), "mu", 156)
    r = subprocess.run([str(skillmimic_bin), "import-rlgames", str(tmp_path / "small.pth"), "--kind", "skill"], capture_output=True, text=True)
    assert r.returncode != 0 and "expected 902 (SkillMimic) or 905" in r.stderr, r.stderr
    r = subprocess.run([str(skillmimic_bin), "import-rlgames", str(tmp_path / "ok.pth"), "--kind", "hlc"], capture_output=True, text=True)
    assert r.returncode != 0 and "model" in r.stderr, r.stderr
