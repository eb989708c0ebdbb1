"""Policy families against PyTorch: the ``categorical_mlp`` family's Rust forward pass equals its
PyTorch mirror module, and the canonical PPO loss (candle autograd) equals a PPO loss written here
from the formulas with torch autograd (losses and every parameter gradient)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_module

torch = require_module("torch")

import skillmimic_rs  # noqa: E402
from skillmimic_rs import _core  # noqa: E402
from skillmimic_rs.policy import CategoricalMlpPolicy, SkillMimicPolicy, load_checkpoint  # noqa: E402


def test_registries_are_exposed():
    assert skillmimic_rs.TASKS[:2] == ("imitation", "stand")
    assert set(skillmimic_rs.POLICY_FAMILIES) >= {"gaussian_mlp", "categorical_mlp"}


def test_categorical_checkpoint_loads_into_the_pytorch_mirror(tmp_path):
    path = tmp_path / "cat.safetensors"
    _core.init_policy(str(path), "categorical_mlp", 12, ("discrete", 5), [32, 16], seed=3)
    module = load_checkpoint(path)
    assert isinstance(module, CategoricalMlpPolicy)
    assert "log_std" not in module.state_dict()
    rng = np.random.default_rng(0)
    obs = rng.normal(size=(7, 12)).astype(np.float32)
    logits, values = _core.Policy.load(str(path)).infer(obs)
    t_logits, t_values = module(torch.from_numpy(obs))
    np.testing.assert_allclose(logits, t_logits.detach().numpy(), rtol=0, atol=1e-5)
    np.testing.assert_allclose(values, t_values.detach().numpy(), rtol=0, atol=1e-5)
    assert logits.shape == (7, 5)
    # a Gaussian checkpoint still loads as the SkillMimic module
    gpath = tmp_path / "gauss.safetensors"
    _core.init_policy(str(gpath), "gaussian_mlp", 12, ("box", 4), [8], seed=1)
    assert isinstance(load_checkpoint(gpath), SkillMimicPolicy)
    with pytest.raises(ValueError, match="cannot act"):
        _core.init_policy(str(gpath), "categorical_mlp", 12, ("box", 4), [8])


def _torch_ppo_loss(module, obs_n, actions, old_neglogp, adv, ret, clip, critic_coef, entropy_coef):
    """PPO-clip loss of a categorical policy, from the formulas (not from the Rust code)."""
    x = torch.from_numpy(obs_n)
    logits = module.actor(x)
    v = module.critic(x).squeeze(-1)
    logp_all = torch.log_softmax(logits, dim=-1)
    neglogp = -logp_all.gather(1, torch.from_numpy(actions).long()).squeeze(1)
    ratio = torch.exp(torch.clamp(torch.from_numpy(old_neglogp) - neglogp, -20, 20))
    a = torch.from_numpy(adv)
    actor = torch.max(-a * ratio, -a * torch.clamp(ratio, 1 - clip, 1 + clip)).mean()
    critic = ((v - torch.from_numpy(ret)) ** 2).mean()
    entropy = -(logp_all.exp() * logp_all).sum(-1).mean()
    total = actor + critic_coef * critic - entropy_coef * entropy
    return total, actor, critic, entropy


def test_canonical_ppo_loss_of_the_categorical_family_matches_pytorch(tmp_path):
    path = tmp_path / "cat.safetensors"
    _core.init_policy(str(path), "categorical_mlp", 10, ("discrete", 4), [16, 16], seed=5)
    module = load_checkpoint(path).double().float()
    rng = np.random.default_rng(1)
    n = 64
    obs_n = rng.normal(size=(n, 10)).astype(np.float32)
    actions = rng.integers(0, 4, size=(n, 1)).astype(np.float32)
    with torch.no_grad():
        lp = torch.log_softmax(module.actor(torch.from_numpy(obs_n)), -1)
        cur = -lp.gather(1, torch.from_numpy(actions).long()).squeeze(1).numpy()
    # old log-probabilities around the current ones, some outside the clip range
    old = (cur + rng.normal(scale=0.3, size=n)).astype(np.float32)
    adv = rng.normal(size=n).astype(np.float32)
    ret = rng.normal(size=n).astype(np.float32)
    clip, cc, ce = 0.2, 5.0, 0.01
    losses, grads = _core.ppo_loss_and_grads(str(path), obs_n, actions, old, adv, ret, clip=clip, critic_coef=cc, backend="fast", entropy_coef=ce)
    total, actor, critic, entropy = _torch_ppo_loss(module, obs_n, actions, old, adv, ret, clip, cc, ce)
    for name, want in [("actor", actor), ("critic", critic), ("entropy", entropy), ("total", total)]:
        assert losses[name] == pytest.approx(want.item(), rel=1e-5, abs=1e-6), name
    assert losses["bounds"] == 0.0
    module.zero_grad()
    total.backward()
    named = dict(module.named_parameters())
    assert set(grads) == {k for k in named if k.startswith(("actor.", "critic."))}
    for name, g in grads.items():
        want = named[name].grad.numpy()
        err = np.abs(g - want).max() / max(np.abs(want).max(), 1e-8)
        assert err < 1e-4, f"{name}: relative error {err}"


@pytest.mark.parametrize("masked", [False, True])
def test_transformer_encoder_layer_matches_pytorch(masked):
    """skillmimic_nn's attention blocks against torch.nn.TransformerEncoderLayer (post-norm, ReLU,
    batch-first, eval mode), with and without a key padding mask."""
    torch.manual_seed(0)
    b, s, e, h, f = 3, 6, 16, 4, 32
    layer = torch.nn.TransformerEncoderLayer(e, h, f, dropout=0.0, batch_first=True).eval()
    with torch.no_grad():
        for p in layer.parameters():  # non-trivial biases and norms
            p.add_(0.1 * torch.randn_like(p))
    x = torch.randn(b, s, e)
    mask = torch.zeros(b, s, dtype=torch.bool)
    mask[0, [1, 4]] = True
    mask[2, 5] = True
    with torch.no_grad():
        want = layer(x, src_key_padding_mask=mask if masked else None)
    sd = {k: v.detach().numpy().astype(np.float32).ravel() for k, v in layer.state_dict().items()}
    got = _core.transformer_encoder_layer(sd, x.numpy(), h, mask.numpy() if masked else None).reshape(b, s, e)
    np.testing.assert_allclose(got, want.numpy(), rtol=0, atol=2e-5)
