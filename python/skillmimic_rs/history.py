"""PyTorch version of the SkillMimic-V2 history encoder; loads the files written by
``skillmimic history pretrain``.

``HistoryEncoder`` has exactly the tensors of an encoder file as its ``state_dict``:
``conv1.weight`` (128, 316, 3), ``conv1.bias`` (128,), ``conv2.weight`` (64, 128, 3),
``conv2.bias`` (64,), ``conv3.weight`` (32, 64, 3), ``conv3.bias`` (32,), ``fc.weight``
(μ, 32·k), ``fc.bias`` (μ,). Input: windows of shape (batch, k, 316), oldest frame first, the
per-frame feature documented in ``crates/skillmimic-env/src/v2/history.rs`` (root height, body
positions in the heading frame, joint exp maps, ball position). Output: (batch, μ), the values the
environment appends to the observation (entries 902 … 902+μ).
"""

from __future__ import annotations

import pathlib

import torch
from torch import nn

from ._core import HISTORY_FEATURE_DIM as FEATURE_DIM  # 316, the Rust core's v2::history::FEATURE_DIM


class HistoryEncoder(nn.Module):
    """Three 1-D convolutions (kernel 3, padding 1, ReLU) and a linear layer."""

    def __init__(self, length: int = 60, embed_dim: int = 3):
        super().__init__()
        self.length, self.embed_dim = length, embed_dim
        self.conv1 = nn.Conv1d(FEATURE_DIM, 128, 3, padding=1)
        self.conv2 = nn.Conv1d(128, 64, 3, padding=1)
        self.conv3 = nn.Conv1d(64, 32, 3, padding=1)
        self.fc = nn.Linear(32 * length, embed_dim)

    def forward(self, windows: torch.Tensor) -> torch.Tensor:
        x = windows.transpose(1, 2)  # (batch, 316, k)
        x = torch.relu(self.conv1(x))
        x = torch.relu(self.conv2(x))
        x = torch.relu(self.conv3(x))
        return self.fc(x.flatten(1))  # channel-major flatten: c·k + τ


def load_history_encoder(path: str | pathlib.Path) -> HistoryEncoder:
    """Load an encoder file (strict: every tensor name and shape must match)."""
    from safetensors import safe_open
    from safetensors.torch import load_file

    path = pathlib.Path(path)
    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
    if meta.get("format") != "skillmimic-history-encoder":
        raise ValueError(f"{path}: metadata 'format' is {meta.get('format')!r}, expected 'skillmimic-history-encoder'")
    enc = HistoryEncoder(int(meta["history_length"]), int(meta["embed_dim"]))
    enc.load_state_dict(load_file(str(path)), strict=True)
    return enc.eval().requires_grad_(False)
