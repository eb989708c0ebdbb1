"""PyTorch version of the skillmimic-rs policy; loads the Rust trainer's safetensors checkpoints.

``SkillMimicPolicy`` has exactly the tensors of a checkpoint as its ``state_dict``:

========================================  =======  ==============================
key                                       dtype    shape
========================================  =======  ==============================
``actor.{0,2,4,6}.weight`` / ``.bias``    float32  (out, in) / (out,)
``critic.{0,2,4,6}.weight`` / ``.bias``   float32  (out, in) / (out,)
``log_std``                               float32  (act_dim,)
``obs_norm.mean`` / ``.var``              float64  (obs_dim,)
``obs_norm.count``                        float64  ()
``value_norm.mean`` / ``.var``            float64  (1,)
``value_norm.count``                      float64  ()
========================================  =======  ==============================

(for the paper network; ``actor``/``critic`` are ``nn.Sequential(Linear, ReLU, …, Linear)``).
That is the ``gaussian_mlp`` policy family. ``CategoricalMlpPolicy`` mirrors the
``categorical_mlp`` family (discrete actions): the same tensors without ``log_std``, the actor
giving logits; its checkpoints carry ``policy = "categorical_mlp"`` and ``actions =
"discrete:<n>"`` in the metadata, and :func:`load_checkpoint` builds the right class.
``ModularAttentionPolicy`` mirrors ``modular_attention`` (ModSkill): actor tensors
``actor.parts.{k}.{q,k,v}.{0,1}.*`` and ``actor.parts.{k}.controller.*``, described by the
metadata ``actor_net``. ``TokenTransformerPolicy`` mirrors ``token_transformer`` and
``token_transformer_categorical`` (TokenHSI): ``actor.output_token``, ``actor.tokenizers.*``,
``actor.encoder.layers.*`` (``nn.TransformerEncoder`` names), ``actor.head.*``,
``actor.adapters.*`` (adapted policies) and ``actor.mu.*``, described by ``actor_net``.
Training checkpoints also hold ``optim.*`` tensors (Adam state), which :func:`load_checkpoint`
skips. Observations are normalised in float64, ``clamp((x - mean) / sqrt(var + eps), ±clip)``,
then cast to float32; the critic's output is de-normalised the same way (clamp, scale, shift).
"""

from __future__ import annotations

import json
import pathlib
from typing import Sequence

import torch
from torch import nn

from ._core import ACT_DIM, OBS_DIM


class RunningMeanStd(nn.Module):
    """Running mean/variance buffers (float64) of the Rust trainer's normaliser."""

    def __init__(self, dim: int, eps: float = 1e-5, clip: float = 5.0):
        super().__init__()
        self.eps, self.clip = eps, clip
        self.register_buffer("mean", torch.zeros(dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(dim, dtype=torch.float64))
        self.register_buffer("count", torch.ones((), dtype=torch.float64))

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        y = (x.double() - self.mean) / torch.sqrt(self.var + self.eps)
        return y.clamp(-self.clip, self.clip).float()

    def denormalize(self, y: torch.Tensor) -> torch.Tensor:
        return (y.double().clamp(-self.clip, self.clip) * torch.sqrt(self.var + self.eps) + self.mean).float()


def _mlp(sizes: Sequence[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for k in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[k], sizes[k + 1]))
        if k + 2 < len(sizes):
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class _MlpActorCritic(nn.Module):
    """Separate actor and critic MLPs over the normalised observation (every MLP family)."""

    def __init__(self, obs_dim, actor_out, hidden, norm_eps, norm_clip, normalize_input, normalize_value, log_std=None):
        super().__init__()
        self.actor = _mlp([obs_dim, *hidden, actor_out])
        self.critic = _mlp([obs_dim, *hidden, 1])
        if log_std is not None:
            self.log_std = nn.Parameter(torch.full((actor_out,), float(log_std)), requires_grad=False)
        self.obs_norm = RunningMeanStd(obs_dim, norm_eps, norm_clip)
        self.value_norm = RunningMeanStd(1, norm_eps, norm_clip)
        self.normalize_input = normalize_input
        self.normalize_value = normalize_value

    def normalized(self, obs: torch.Tensor) -> torch.Tensor:
        """The actor's and critic's input for raw observations ``(N, obs_dim)``."""
        return self.obs_norm.normalize(obs) if self.normalize_input else obs.float()

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Actor outputs ``(N, outputs)`` and values ``(N,)`` for raw observations ``(N, obs_dim)``."""
        x = self.normalized(obs)
        out = self.actor(x)
        v = self.critic(x).squeeze(-1)
        if self.normalize_value:
            v = self.value_norm.denormalize(v)
        return out, v


class SkillMimicPolicy(_MlpActorCritic):
    """``gaussian_mlp``, SkillMimic's actor–critic: action means from the actor, fixed log-std.

    The default widths are the SkillMimic humanoid's imitation task; for another character pass
    ``act_dim=skillmimic_rs.CHARACTERS[name]["act_dim"]`` and the task's observation width (or
    load a checkpoint, which carries both).
    """

    def __init__(
        self,
        obs_dim: int = OBS_DIM,
        act_dim: int = ACT_DIM,
        hidden: Sequence[int] = (1024, 512, 512),
        log_std: float = -2.9,
        norm_eps: float = 1e-5,
        norm_clip: float = 5.0,
        normalize_input: bool = True,
        normalize_value: bool = True,
    ):
        super().__init__(obs_dim, act_dim, hidden, norm_eps, norm_clip, normalize_input, normalize_value, log_std=log_std)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, deterministic: bool = True) -> torch.Tensor:
        """Actions in [-1, 1] (the mean, or a Gaussian sample when not deterministic)."""
        mu, _ = self(obs)
        a = mu if deterministic else mu + torch.exp(self.log_std) * torch.randn_like(mu)
        return a.clamp(-1.0, 1.0)


class CategoricalMlpPolicy(_MlpActorCritic):
    """``categorical_mlp``: logits over ``num_actions`` choices from the actor (no log-std)."""

    def __init__(
        self,
        obs_dim: int,
        num_actions: int,
        hidden: Sequence[int] = (1024, 512, 512),
        norm_eps: float = 1e-5,
        norm_clip: float = 5.0,
        normalize_input: bool = True,
        normalize_value: bool = True,
    ):
        super().__init__(obs_dim, num_actions, hidden, norm_eps, norm_clip, normalize_input, normalize_value)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, deterministic: bool = True) -> torch.Tensor:
        """Chosen indices ``(N,)`` (the most likely choice, or a sample)."""
        logits, _ = self(obs)
        if deterministic:
            return logits.argmax(-1)
        return torch.distributions.Categorical(logits=logits).sample()


class _Part(nn.Module):
    """One body part of :class:`ModularAttentionActor`: Q/K/V projections and its controller."""

    def __init__(self, inputs: Sequence[int], outputs: Sequence[int], embed: int, proj_hidden: int, controller: Sequence[int]):
        super().__init__()
        for name in ("q", "k", "v"):
            setattr(self, name, nn.Sequential(nn.Linear(len(inputs), proj_hidden), nn.Linear(proj_hidden, embed)))
        self.controller = _mlp([embed, *controller, len(outputs)])
        self.register_buffer("inputs", torch.tensor(list(inputs), dtype=torch.long), persistent=False)
        self.register_buffer("outputs", torch.tensor(list(outputs), dtype=torch.long), persistent=False)


class ModularAttentionActor(nn.Module):
    """ModSkill's modular attention actor (``modular_attention``; the Rust definition is
    ``skillmimic_nn::modular``): per part k, token ``x[:, inputs_k]``, q/k/v = Linear→Linear
    (no activation), softmax attention over the part tokens (``heads`` heads, scores divided by
    sqrt(embed/heads) only when ``scaled``), each embedding L2-normalised, one controller MLP per
    part writing ``outputs_k`` of the action row. ``spec`` = the checkpoint metadata
    ``actor_net`` (embed, proj_hidden, heads, scaled, controller, parts = [name, inputs, outputs])."""

    def __init__(self, spec: dict, act_dim: int):
        super().__init__()
        self.embed, self.heads, self.scaled, self.act_dim = spec["embed"], spec["heads"], spec["scaled"], act_dim
        self.part_names = [p[0] for p in spec["parts"]]
        self.parts = nn.ModuleList(_Part(i, o, spec["embed"], spec["proj_hidden"], spec["controller"]) for _, i, o in spec["parts"])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, np_, h = x.shape[0], len(self.parts), self.heads
        dh = self.embed // h
        tokens = [x[:, p.inputs] for p in self.parts]
        q, k, v = (torch.stack([getattr(p, n)(t) for p, t in zip(self.parts, tokens)], 1).view(b, np_, h, dh).transpose(1, 2) for n in "qkv")
        scores = q @ k.transpose(-1, -2)
        if self.scaled:
            scores = scores / dh**0.5
        z = (torch.softmax(scores, -1) @ v).transpose(1, 2).reshape(b, np_, self.embed)
        z = torch.nn.functional.normalize(z, dim=-1)
        out = x.new_zeros(b, self.act_dim)
        for i, p in enumerate(self.parts):
            out[:, p.outputs] = p.controller(z[:, i])
        return out


class ModularAttentionPolicy(_MlpActorCritic):
    """``modular_attention``: :class:`ModularAttentionActor` for the action means, a critic MLP
    over the whole observation (``hidden``), fixed log-std — ModSkill's policy."""

    def __init__(self, spec: dict, obs_dim: int = OBS_DIM, act_dim: int = ACT_DIM, hidden: Sequence[int] = (1024, 512, 512), log_std: float = -2.9, norm_eps: float = 1e-5, norm_clip: float = 5.0, normalize_input: bool = True, normalize_value: bool = True):
        super().__init__(obs_dim, act_dim, hidden, norm_eps, norm_clip, normalize_input, normalize_value, log_std=log_std)
        self.actor = ModularAttentionActor(spec, act_dim)

    act = SkillMimicPolicy.act


class TokenTransformerActor(nn.Module):
    """TokenHSI's token transformer actor (``token_transformer*``; the Rust definition is
    ``skillmimic_nn::token``): one tokenizer MLP per observation group (ReLU after every layer),
    the sequence ``[output_token, token_0, ..., token_{G-1}]`` without positional embedding, a
    post-norm ``nn.TransformerEncoder`` (dropout 0, ReLU) with a key padding mask that ignores task
    token k where the raw mask entry k is <= 0.5, the encoded output token through the head MLP
    (ReLU after each hidden layer, plus the zero-initialised ``adapters`` in parallel when present,
    multiplied by the largest raw mask entry of ``adapter_gate`` when that is given)
    and the output layer ``mu``. ``spec`` = the checkpoint metadata ``actor_net``."""

    def __init__(self, spec: dict, act_dim: int):
        super().__init__()
        self.spec, self.act_dim = spec, act_dim
        e = spec["embed"]
        self.widths = [w for _, w in spec["groups"]]
        self.mask = spec["mask"]
        self.output_token = nn.Parameter(torch.zeros(1, 1, e))

        def tokenizer(w):
            sizes = [w, *spec["tokenizer"], e]
            layers: list[nn.Module] = []
            for k in range(len(sizes) - 1):
                layers += [nn.Linear(sizes[k], sizes[k + 1]), nn.ReLU()]
            return nn.Sequential(*layers)

        self.tokenizers = nn.ModuleList(tokenizer(w) for w in self.widths)
        layer = nn.TransformerEncoderLayer(e, spec["heads"], spec["feedforward"], dropout=0.0, activation="relu", batch_first=True, norm_first=False)
        self.encoder = nn.TransformerEncoder(layer, spec["layers"], enable_nested_tensor=False)
        sizes = [e, *spec["head"]]
        self.head = nn.Sequential(*[m for k in range(len(sizes) - 1) for m in (nn.Linear(sizes[k], sizes[k + 1]), nn.ReLU())])
        if spec["adapters"]:
            self.adapters = nn.ModuleList(nn.Linear(sizes[k], sizes[k + 1]) for k in range(len(sizes) - 1))
        self.mu = nn.Linear(sizes[-1], act_dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``x`` (B, obs_dim): normalised groups, raw mask entries. Returns (B, act_dim)."""
        b, at, tokens = x.shape[0], 0, []
        for w, tok in zip(self.widths, self.tokenizers):
            tokens.append(tok(x[:, at : at + w]))
            at += w
        seq = torch.cat([self.output_token.expand(b, 1, -1), torch.stack(tokens, 1)], 1)
        pad = None
        if self.mask:
            ignore = x[:, at : at + self.mask] <= 0.5
            pad = torch.cat([torch.zeros(b, 2, dtype=torch.bool, device=x.device), ignore], 1)
        h = self.encoder(seq, src_key_padding_mask=pad)[:, 0]
        gate = None
        if self.spec["adapters"] and self.spec.get("adapter_gate") and self.mask:
            gate = x[:, [at + k for k in self.spec["adapter_gate"]]].max(1, keepdim=True).values
        for k in range(len(self.head) // 2):
            y = self.head[2 * k](h)
            if self.spec["adapters"]:
                a = self.adapters[k](h)
                y = y + (a if gate is None else a * gate)
            h = torch.relu(y)
        return self.mu(h)


class TokenTransformerPolicy(_MlpActorCritic):
    """``token_transformer`` (Gaussian, fixed log-std) or ``token_transformer_categorical``
    (logits; ``log_std=None``): :class:`TokenTransformerActor`, a critic MLP over the whole
    normalised observation (``hidden``). The mask entries reach the actor unnormalised."""

    def __init__(self, spec: dict, obs_dim: int, act_dim: int, hidden: Sequence[int] = (2048, 1024, 512), log_std: float | None = -2.9, norm_eps: float = 1e-5, norm_clip: float = 5.0, normalize_input: bool = True, normalize_value: bool = True):
        super().__init__(obs_dim, act_dim, hidden, norm_eps, norm_clip, normalize_input, normalize_value, log_std=log_std)
        self.actor = TokenTransformerActor(spec, act_dim)
        self.raw = slice(obs_dim - spec["mask"], obs_dim)

    def normalized(self, obs: torch.Tensor) -> torch.Tensor:
        """The actor's and critic's input: normalised observation, mask entries raw."""
        x = super().normalized(obs)
        if self.normalize_input and self.raw.start < self.raw.stop:
            x = torch.cat([x[:, : self.raw.start], obs[:, self.raw].float()], 1)
        return x

    @torch.no_grad()
    def act(self, obs: torch.Tensor, deterministic: bool = True) -> torch.Tensor:
        """Gaussian: actions in [-1, 1]; categorical: chosen indices."""
        if hasattr(self, "log_std"):
            return SkillMimicPolicy.act(self, obs, deterministic)
        return CategoricalMlpPolicy.act(self, obs, deterministic)


def checkpoint_metadata(path: str | pathlib.Path) -> dict[str, str]:
    """The metadata strings of a skillmimic checkpoint."""
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
    if meta.get("format") != "skillmimic-policy":
        raise ValueError(f"{path}: not a skillmimic checkpoint (format {meta.get('format')!r})")
    return meta


def load_checkpoint(path: str | pathlib.Path, map_location: str | torch.device = "cpu") -> SkillMimicPolicy | CategoricalMlpPolicy | ModularAttentionPolicy | TokenTransformerPolicy:
    """Build the PyTorch module of a checkpoint written by ``skillmimic train``/``export``
    (:class:`SkillMimicPolicy` for ``gaussian_mlp``, :class:`CategoricalMlpPolicy` for
    ``categorical_mlp``, :class:`ModularAttentionPolicy` for ``modular_attention``; strict: every
    policy tensor must be present with the right shape)."""
    from safetensors.torch import load_file

    meta = checkpoint_metadata(path)
    family = meta.get("policy", "gaussian_mlp")
    common = dict(
        obs_dim=int(meta["obs_dim"]),
        hidden=json.loads(meta["hidden"]),
        norm_eps=float(meta["norm_eps"]),
        norm_clip=float(meta["norm_clip"]),
        normalize_input=meta["normalize_input"] == "true",
        normalize_value=meta["normalize_value"] == "true",
    )
    if family == "gaussian_mlp":
        policy: SkillMimicPolicy | CategoricalMlpPolicy | ModularAttentionPolicy | TokenTransformerPolicy = SkillMimicPolicy(act_dim=int(meta["act_dim"]), **common)
    elif family == "categorical_mlp":
        kind, _, n = meta.get("actions", "").partition(":")
        if kind != "discrete" or not n.isdigit():
            raise ValueError(f"{path}: metadata 'actions' is {meta.get('actions')!r}, expected 'discrete:<n>'")
        policy = CategoricalMlpPolicy(num_actions=int(n), **common)
    elif family == "modular_attention":
        policy = ModularAttentionPolicy(json.loads(meta["actor_net"]), act_dim=int(meta["act_dim"]), **common)
    elif family in ("token_transformer", "token_transformer_categorical"):
        kind, _, n = meta.get("actions", "").partition(":")
        outputs = int(n) if kind == "discrete" else int(meta["act_dim"])
        policy = TokenTransformerPolicy(json.loads(meta["actor_net"]), act_dim=outputs, log_std=-2.9 if family == "token_transformer" else None, **common)
    else:
        raise ValueError(f"{path}: unknown policy family {family!r} (gaussian_mlp, categorical_mlp, modular_attention, token_transformer, token_transformer_categorical)")
    tensors = load_file(str(path), device=str(map_location))
    # the training-only tensors (optimiser, motion prior, the exact-resume state) are not the policy's
    state = {k: v for k, v in tensors.items() if not k.startswith(("optim.", "amp.", "resume."))}
    policy.load_state_dict(state, strict=True)
    return policy.to(map_location).eval()
