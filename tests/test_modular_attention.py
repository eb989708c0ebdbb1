"""The ``modular_attention`` policy family (ModSkill) against PyTorch: every part token gathers
exactly its bodies' observation columns (derived here from the observation table and the MJCF
body names; the root height in the root's part, as the released code) and the shared ones; the Rust forward pass equals the PyTorch mirror module and an independent functional
reference written from the paper/code facts; the PPO loss and every parameter gradient — of the
canonical loss (candle autograd) and of the hand-written fast path (``ppo.backend = "fast"``, the
default) — equal torch autograd of the Gaussian PPO loss on that reference."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import require_module

torch = require_module("torch")

from skillmimic_rs import _core  # noqa: E402
from skillmimic_rs.policy import ModularAttentionPolicy, checkpoint_metadata, load_checkpoint  # noqa: E402

SMALL = ["ppo.modular.controller=[48, 32]", "ppo.modular.proj_hidden=40", "ppo.modular.embed=16", "ppo.log_std=0.0"]


def _body_names(repo_root):
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(repo_root / "mjcf" / "skillmimic_full.xml"))
    return [m.body(i).name for i in range(1, 54)]  # body 0 of MuJoCo is the world


def _expected_parts(names, split):
    """Part → bodies from ModSkill's split (facts §1.1) on this humanoid."""
    idx = {n: i for i, n in enumerate(names)}
    side = lambda s, first: [i for i, n in enumerate(names) if n.startswith(s) and i >= idx[first]]  # noqa: E731
    legs = [("l_leg", [idx[n] for n in ("L_Hip", "L_Knee", "L_Ankle", "L_Toe")]), ("r_leg", [idx[n] for n in ("R_Hip", "R_Knee", "R_Ankle", "R_Toe")])]
    torso = ("torso", [idx[n] for n in ("Pelvis", "Torso", "Spine", "Spine2", "Chest", "Neck", "Head")])
    larm, rarm = side("L_", "L_Thorax"), side("R_", "R_Thorax")
    if split == "five":
        return [*legs, torso, ("l_arm", larm), ("r_arm", rarm)]
    hand = lambda arm, wrist: [b for b in arm if b >= idx[wrist]]  # noqa: E731
    return [*legs, torso, ("l_arm", [b for b in larm if b < idx["L_Wrist"]]), ("l_hand", hand(larm, "L_Wrist")), ("r_arm", [b for b in rarm if b < idx["R_Wrist"]]), ("r_hand", hand(rarm, "R_Wrist"))]


@pytest.mark.parametrize("split", ["five", "seven"])
def test_part_tokens_gather_exactly_their_bodies_columns(tmp_path, repo_root, split):
    path = tmp_path / "m.safetensors"
    _core.init_policy(str(path), "modular_attention", 905, ("box", 156), [32], seed=1, overrides=[*SMALL, f"ppo.modular.parts={split}"])
    spec = json.loads(checkpoint_metadata(path)["actor_net"])
    names = _body_names(repo_root)
    blocks = _core.OBS_BLOCKS
    tips = [names.index(f"{s}_{f}3") for s in "LR" for f in ("Index", "Middle", "Pinky", "Ring", "Thumb")]
    # the ball, the skill condition, a history embedding (905 = 902 + 3): no body's columns, in
    # every token; the root height only in the root's (torso) token, first (the released layout)
    shared = [*range(blocks["ball_pos"][0], blocks["ball_angvel"][1]), *range(blocks["skill"][0], 905)]
    covered = []
    want_parts = _expected_parts(names, split)
    assert [p[0] for p in spec["parts"]] == [n for n, _ in want_parts]
    for (name, inputs, outputs), (_, bodies) in zip(spec["parts"], want_parts):
        want = [0] if 0 in bodies else []
        for b in bodies:
            if b >= 1:
                want += range(blocks["body_pos"][0] + 3 * (b - 1), blocks["body_pos"][0] + 3 * b)
            want += range(blocks["body_rot"][0] + 6 * b, blocks["body_rot"][0] + 6 * b + 6)
            want += range(blocks["body_linvel"][0] + 3 * b, blocks["body_linvel"][0] + 3 * b + 3)
            want += range(blocks["body_angvel"][0] + 3 * b, blocks["body_angvel"][0] + 3 * b + 3)
            if b in tips:
                f = tips.index(b)
                want += range(blocks["fingertip_force"][0] + 3 * f, blocks["fingertip_force"][0] + 3 * f + 3)
        assert inputs == want + shared, name
        assert outputs == [c for b in bodies if b >= 1 for c in range(3 * (b - 1), 3 * b)], name
        covered += outputs
    assert sorted(covered) == list(range(156))


def _reference_actor(sd, spec, x):
    """ModSkill's actor from the facts, written with plain tensor ops over the state dict."""
    e, h = spec["embed"], spec["heads"]
    dh = e // h
    lin = lambda t, p: t @ sd[p + ".weight"].T + sd[p + ".bias"]  # noqa: E731
    q, k, v = [], [], []
    for i, (_, inputs, _) in enumerate(spec["parts"]):
        t = x[:, inputs]
        for dst, tag in ((q, "q"), (k, "k"), (v, "v")):
            dst.append(lin(lin(t, f"actor.parts.{i}.{tag}.0"), f"actor.parts.{i}.{tag}.1"))
    n, p = x.shape[0], len(spec["parts"])
    out = torch.zeros(n, 156, dtype=x.dtype)
    for hh in range(h):
        cols = slice(hh * dh, (hh + 1) * dh)
        qs = torch.stack([t[:, cols] for t in q], 1)
        ks = torch.stack([t[:, cols] for t in k], 1)
        vs = torch.stack([t[:, cols] for t in v], 1)
        s = torch.einsum("npd,nqd->npq", qs, ks) * (1 / math.sqrt(dh) if spec["scaled"] else 1.0)
        zh = torch.einsum("npq,nqd->npd", torch.softmax(s, -1), vs)
        z = zh if hh == 0 else torch.cat([z, zh], -1)
    z = z / z.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    for i, (_, _, outputs) in enumerate(spec["parts"]):
        hcur, layer = z[:, i], 0
        while f"actor.parts.{i}.controller.{layer}.weight" in sd:
            hcur = lin(hcur, f"actor.parts.{i}.controller.{layer}")
            layer += 2
            if f"actor.parts.{i}.controller.{layer}.weight" in sd:
                hcur = torch.relu(hcur)
        out[:, outputs] = hcur
    return out


@pytest.mark.parametrize("variant", [[], ["ppo.modular.scaled=true", "ppo.modular.heads=2", "ppo.modular.parts=seven"]])
def test_forward_and_ppo_gradients_match_pytorch(tmp_path, variant):
    path = tmp_path / "m.safetensors"
    _core.init_policy(str(path), "modular_attention", 902, ("box", 156), [64, 32], seed=4, overrides=[*SMALL, *variant])
    spec = json.loads(checkpoint_metadata(path)["actor_net"])
    module = load_checkpoint(path)
    assert isinstance(module, ModularAttentionPolicy)
    rng = np.random.default_rng(2)
    n = 96
    obs = rng.normal(size=(n, 902)).astype(np.float32)
    mu, _ = _core.Policy.load(str(path)).infer(obs)
    with torch.no_grad():
        t_mu, _ = module(torch.from_numpy(obs))
        x = module.obs_norm.normalize(torch.from_numpy(obs))
        sd = {k: v.double() for k, v in module.state_dict().items()}
        ref = _reference_actor(sd, spec, x.double()).numpy()
    print(f"{variant}: max |d mu| Rust vs mirror {np.abs(mu - t_mu.numpy()).max():.2e}, vs reference {np.abs(mu - ref).max():.2e}")
    np.testing.assert_allclose(mu, t_mu.numpy(), rtol=0, atol=1e-5)
    np.testing.assert_allclose(mu, ref, rtol=0, atol=1e-5)

    # the PPO loss (candle autograd, and the fast path) vs torch autograd on the float64 reference
    obs_n = x.numpy()
    actions = (ref + rng.normal(0, 0.3, ref.shape)).astype(np.float32)
    nl = (0.5 * (actions.astype(np.float64) - ref) ** 2 + 0.5 * math.log(2 * math.pi)).sum(1)
    old = (nl + rng.uniform(-0.4, 0.4, n)).astype(np.float32)
    adv = rng.normal(size=n).astype(np.float32)
    ret = rng.normal(size=n).astype(np.float32)
    params = {k: v.clone().requires_grad_(True) for k, v in sd.items() if k.startswith(("actor.", "critic."))}
    xt = torch.from_numpy(obs_n).double()
    mu_t = _reference_actor(params, spec, xt)
    hcur = xt
    for k in range(3):
        hcur = hcur @ params[f"critic.{2 * k}.weight"].T + params[f"critic.{2 * k}.bias"]
        hcur = torch.relu(hcur) if k < 2 else hcur
    v_t = hcur.squeeze(-1)
    new = (0.5 * (torch.from_numpy(actions).double() - mu_t) ** 2 + 0.5 * math.log(2 * math.pi)).sum(1)
    ratio = torch.exp((torch.from_numpy(old).double() - new).clamp(-20, 20))
    at = torch.from_numpy(adv).double()
    loss = torch.max(-at * ratio, -at * ratio.clamp(0.8, 1.2)).mean()
    loss = loss + 5.0 * ((v_t - torch.from_numpy(ret).double()) ** 2).mean()
    loss = loss + 10.0 * ((mu_t - 1).clamp(min=0) ** 2 + (-1 - mu_t).clamp(min=0) ** 2).sum(1).mean()
    loss.backward()
    for backend in ("candle", "fast"):
        losses, grads = _core.ppo_loss_and_grads(str(path), obs_n, actions, old, adv, ret, critic_coef=5.0, bounds_coef=10.0, backend=backend)
        assert abs(losses["total"] - loss.item()) <= 1e-5 * (1 + abs(loss.item())), (backend, losses, loss.item())
        assert set(grads) == set(params)
        worst = max(np.abs(grads[k] - p.grad.numpy()).max() / max(np.abs(p.grad.numpy()).max(), 1e-12) for k, p in params.items())
        absolute = max(np.abs(grads[k] - p.grad.numpy()).max() for k, p in params.items())
        print(f"{variant} {backend}: gradients vs torch autograd: max relative difference {worst:.2e}, max absolute {absolute:.2e}")
        # absolute to 1e-5; relative to 2e-5 (the 156-term log-density is summed in float32, as
        # for gaussian_mlp in test_learner.py)
        assert absolute <= 1e-5 and worst <= 2e-5, backend
