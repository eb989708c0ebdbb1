"""Variants of the first demo clip for the parity tests, written to a temporary folder.

* ``000_ballfree_copy`` / ``010_ballfree_copy``: the clip with the ball-free labels 0 and 10;
* ``052_moving_root_copy``: the clip with its root accelerating and turning (about 0.6 rad/s,
  mostly about z). The demo clips stand still and face +x, so root velocities and the heading
  rotation would otherwise be zero / identity at every frame.

The poses are not physically consistent (``body_pos`` is not moved); the tests that use these
clips only read the root, the joints and the ball.
"""

from __future__ import annotations

import pathlib

import numpy as np

import reference_env as ref
from skillmimic_rs import motion

REPO = pathlib.Path(__file__).resolve().parent.parent


def demo_variants(tmp_path: pathlib.Path) -> list[pathlib.Path]:
    """Write the three variants into `tmp_path` and return their paths."""
    src = motion.read_clip(sorted((REPO / "motions").glob("*.safetensors"))[0])
    variants = {f"{s:03d}_ballfree_copy": {"skill": s} for s in (0, 10)}
    s = np.arange(len(src["root_pos"]), dtype=np.float64)[:, None] / 60.0  # seconds
    turn = ref.rotvec_to_quat(np.array([0.1, -0.05, 0.6]) * s)  # wxyz, like the clip format
    variants["052_moving_root_copy"] = {
        "root_pos": (src["root_pos"] + np.array([0.9, -0.4, 0.05]) * s + np.array([0.5, 0.3, 0.0]) * s**2).astype(np.float32),
        "root_rot": ref.quat_mul(turn, src["root_rot"]).astype(np.float32),
        "skill": 52,
    }
    out = []
    for name, change in variants.items():
        path = tmp_path / f"{name}.safetensors"
        motion.write_clip(path, {**src, **change, "name": name})
        out.append(path)
    return out
