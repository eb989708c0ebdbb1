"""The ``token_transformer`` policy family (TokenHSI) against PyTorch: the Rust forward pass equals
``torch.nn.TransformerEncoder`` with the same weights and key padding mask (the mirror module
``TokenTransformerPolicy``), masks included — masked task tokens do not change the output, unmasked
ones do — and the PPO loss and every parameter gradient of the canonical candle loss equal torch
autograd through that module in float64. The observation normaliser is non-trivial and the mask
entries reach the actor raw."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
from conftest import require_module

torch = require_module("torch")
safetensors_torch = require_module("safetensors.torch")

from skillmimic_rs import _core  # noqa: E402
from skillmimic_rs.policy import TokenTransformerPolicy, checkpoint_metadata, load_checkpoint  # noqa: E402

GROUPS = ["proprio:22", "follow:5", "sit:7", "carry:6", "mask:3"]
OBS = 22 + 5 + 7 + 6 + 3
SMALL = [
    f"ppo.token.groups={json.dumps(GROUPS)}",
    "ppo.token.tokenizer=[24, 16]",
    "ppo.token.embed=8",
    "ppo.token.heads=2",
    "ppo.token.layers=2",
    "ppo.token.feedforward=32",
    "ppo.token.head=[40, 24]",
    "ppo.log_std=0.0",
]


def _make(tmp_path, family="token_transformer", actions=("box", 6)):
    """A fresh policy whose observation statistics are replaced by random ones (so the
    normalisation and the raw mask columns matter)."""
    path = tmp_path / f"{family}.safetensors"
    _core.init_policy(str(path), family, OBS, actions, [32, 16], seed=5, overrides=SMALL)
    meta = checkpoint_metadata(path)
    tensors = safetensors_torch.load_file(str(path))
    g = torch.Generator().manual_seed(0)
    tensors["obs_norm.mean"] = torch.randn(OBS, generator=g, dtype=torch.float64) * 0.5
    tensors["obs_norm.var"] = torch.rand(OBS, generator=g, dtype=torch.float64) * 2 + 0.2
    safetensors_torch.save_file(tensors, str(path), metadata=meta)
    return path


def _obs(rng, n):
    obs = rng.normal(size=(n, OBS)).astype(np.float32)
    mask = rng.integers(0, 2, size=(n, 3)).astype(np.float32)
    mask[0] = 0  # a row with no task token
    mask[1] = [0, 1, 0]  # one-hot rows, as TokenHSI's multi-task training
    mask[2] = [1, 0, 1]  # a composition row
    obs[:, -3:] = mask
    return obs


def test_forward_equals_torch_transformer_encoder_with_the_mask(tmp_path):
    path = _make(tmp_path)
    module = load_checkpoint(path)
    assert isinstance(module, TokenTransformerPolicy)
    assert isinstance(module.actor.encoder, torch.nn.TransformerEncoder)
    rng = np.random.default_rng(1)
    obs = _obs(rng, 64)
    mu, values = _core.Policy.load(str(path)).infer(obs)
    with torch.no_grad():
        t_mu, t_v = module(torch.from_numpy(obs))
    print(f"max |d mu| {np.abs(mu - t_mu.numpy()).max():.2e}, max |d value| {np.abs(values - t_v.numpy()).max():.2e}")
    np.testing.assert_allclose(mu, t_mu.numpy(), rtol=0, atol=1e-5)
    np.testing.assert_allclose(values, t_v.numpy(), rtol=0, atol=1e-5)

    # a masked task token's observation does not matter; an unmasked one's does
    policy = _core.Policy.load(str(path))
    base = obs[:8].copy()
    base[:, -3:] = [1, 0, 0]
    moved = base.copy()
    moved[:, 27:34] += 3.0  # the sit group, masked
    a, _ = policy.infer(base)
    b, _ = policy.infer(moved)
    np.testing.assert_array_equal(a, b)
    moved[:, -3:] = [1, 1, 0]
    base[:, -3:] = [1, 1, 0]
    a, _ = policy.infer(base)
    b, _ = policy.infer(moved)
    assert np.abs(a - b).max() > 1e-3


def test_categorical_variant_gives_the_mirrors_logits(tmp_path):
    path = _make(tmp_path, "token_transformer_categorical", ("discrete", 3))
    module = load_checkpoint(path)
    obs = _obs(np.random.default_rng(4), 32)
    logits, _ = _core.Policy.load(str(path)).infer(obs)
    with torch.no_grad():
        t_logits, _ = module(torch.from_numpy(obs))
    assert logits.shape == (32, 3)
    np.testing.assert_allclose(logits, t_logits.numpy(), rtol=0, atol=1e-5)


def test_ppo_loss_and_gradients_equal_torch_autograd(tmp_path):
    path = _make(tmp_path)
    module = load_checkpoint(path)
    rng = np.random.default_rng(2)
    n = 48
    obs = _obs(rng, n)
    with torch.no_grad():
        x = module.normalized(torch.from_numpy(obs))
    obs_n = x.numpy()
    ref = copy.deepcopy(module).double().train()
    params = {k: p for k, p in ref.named_parameters() if k.startswith(("actor.", "critic."))}
    for p in params.values():
        p.requires_grad_(True)
    xt = torch.from_numpy(obs_n).double()
    mu_t = ref.actor(xt)
    v_t = ref.critic(xt).squeeze(-1)
    with torch.no_grad():
        actions = (mu_t + torch.from_numpy(rng.normal(0, 0.3, tuple(mu_t.shape)))).float().numpy()
        nl = (0.5 * (torch.from_numpy(actions).double() - mu_t) ** 2 + 0.5 * math.log(2 * math.pi)).sum(1).numpy()
    old = (nl + rng.uniform(-0.4, 0.4, n)).astype(np.float32)
    adv = rng.normal(size=n).astype(np.float32)
    ret = rng.normal(size=n).astype(np.float32)
    new = (0.5 * (torch.from_numpy(actions).double() - mu_t) ** 2 + 0.5 * math.log(2 * math.pi)).sum(1)
    ratio = torch.exp((torch.from_numpy(old).double() - new).clamp(-20, 20))
    at = torch.from_numpy(adv).double()
    loss = torch.max(-at * ratio, -at * ratio.clamp(0.8, 1.2)).mean()
    loss = loss + 5.0 * ((v_t - torch.from_numpy(ret).double()) ** 2).mean()
    loss = loss + 10.0 * ((mu_t - 1).clamp(min=0) ** 2 + (-1 - mu_t).clamp(min=0) ** 2).sum(1).mean()
    loss.backward()
    losses, grads = _core.ppo_loss_and_grads(str(path), obs_n, actions, old, adv, ret, critic_coef=5.0, bounds_coef=10.0, backend="candle")
    assert abs(losses["total"] - loss.item()) <= 1e-5 * (1 + abs(loss.item())), (losses, loss.item())
    # every trained tensor of the mirror has a gradient from Rust (the output token included)
    assert set(grads) == set(params), set(grads) ^ set(params)
    absolute = max(np.abs(grads[k] - p.grad.numpy()).max() for k, p in params.items())
    worst = max(np.abs(grads[k] - p.grad.numpy()).max() / max(np.abs(p.grad.numpy()).max(), 1e-12) for k, p in params.items())
    print(f"gradients vs torch autograd: max absolute difference {absolute:.2e}, max relative {worst:.2e}")
    assert absolute <= 1e-5 and worst <= 1e-4


def test_adapted_network_with_gated_adapters_matches_the_mirror(tmp_path):
    """An adapted network (adapters present, gated by the last task group's mask entry) as the
    adaptation writes it: Rust equals the mirror, the adapters act only on rows whose gate entry
    is 1, and rows without it give exactly the un-adapted network's outputs."""
    path = _make(tmp_path)
    meta = checkpoint_metadata(path)
    plain = _core.Policy.load(str(path))
    spec = json.loads(meta["actor_net"])
    spec.update(adapters=True, adapter_gate=[2])
    meta["actor_net"] = json.dumps(spec)
    tensors = safetensors_torch.load_file(str(path))
    g = torch.Generator().manual_seed(3)
    sizes = [spec["embed"], *spec["head"]]
    for k in range(len(sizes) - 1):
        tensors[f"actor.adapters.{k}.weight"] = torch.randn(sizes[k + 1], sizes[k], generator=g) * 0.2
        tensors[f"actor.adapters.{k}.bias"] = torch.randn(sizes[k + 1], generator=g) * 0.2
    adapted = tmp_path / "adapted.safetensors"
    safetensors_torch.save_file(tensors, str(adapted), metadata=meta)
    module = load_checkpoint(adapted)
    obs = _obs(np.random.default_rng(7), 64)
    mu, _ = _core.Policy.load(str(adapted)).infer(obs)
    with torch.no_grad():
        t_mu, _ = module(torch.from_numpy(obs))
    print(f"adapted: max |d mu| Rust vs mirror {np.abs(mu - t_mu.numpy()).max():.2e}")
    np.testing.assert_allclose(mu, t_mu.numpy(), rtol=0, atol=1e-5)
    base, _ = plain.infer(obs)
    off = obs[:, -1] == 0
    assert off.any() and (~off).any()
    np.testing.assert_array_equal(mu[off], base[off])
    assert np.abs(mu[~off] - base[~off]).min(axis=1).max() > 1e-3
