"""Clips in the project format from Python, and Python clip generators for ModSkill's active skill
learning.

A clip file is safetensors with float32 tensors ``root_pos (T, 3)``, ``root_rot (T, 4)`` (unit
quaternions, **w, x, y, z**), ``dof_rot (T, 52, 3)`` (exp maps of each body relative to its parent,
rad), ``body_pos (T, 53, 3)``, ``ball_pos (T, 3)``, ``ball_rot (T, 4)`` (w, x, y, z),
``contact (T,)`` (0 or 1) — positions in metres, z-up world frame — and the metadata ``format``,
``format_version``, ``fps``, ``skill`` (0..63), ``name``, ``source``. The Rust loader validates
every field when a clip is read back.

A generator (``run.active.generator``) registered here is called once per failed clip::

    def mdm_variations(failed: str, out_dir: str) -> None:
        clip = skillmimic_rs.motion.read_clip(failed)
        ...                                         # e.g. text-to-motion conditioned on it
        skillmimic_rs.motion.write_clip(f"{out_dir}/{clip['name']}~mdm0.safetensors", new_clip)

    skillmimic_rs.register_generator("mdm", mdm_variations)
    # then train with --set run.active.enabled=true --set run.active.generator=mdm

Generated clips pass the validity filter (no body below the floor, joint speeds within bounds,
finite values) before they join the library; rejected ones are logged with the reason.
"""

from __future__ import annotations

import pathlib
from typing import Any, Callable

import numpy as np

from . import _core

FIELDS = {"root_pos": (3,), "root_rot": (4,), "dof_rot": (52, 3), "body_pos": (53, 3), "ball_pos": (3,), "ball_rot": (4,), "contact": ()}


def read_clip(path: str | pathlib.Path) -> dict[str, Any]:
    """The arrays (float32) and metadata (``name``, ``source``: str; ``skill``: int; ``fps``:
    float) of a project-format clip."""
    from safetensors import safe_open

    with safe_open(str(path), framework="numpy") as f:
        meta = f.metadata() or {}
        if meta.get("format") != _core.CLIP_FORMAT:
            raise ValueError(f"{path}: metadata format is {meta.get('format')!r}, expected {_core.CLIP_FORMAT!r}")
        clip: dict[str, Any] = {k: f.get_tensor(k) for k in FIELDS}
    clip.update(name=meta.get("name", ""), source=meta.get("source", ""), skill=int(meta["skill"]), fps=float(meta["fps"]))
    return clip


def write_clip(path: str | pathlib.Path, clip: dict[str, Any]) -> None:
    """Write ``clip`` (the keys of :func:`read_clip`) as a project-format file; shapes are checked
    against ``T = len(root_pos)``."""
    from safetensors.numpy import save_file

    t = len(clip["root_pos"])
    tensors = {}
    for k, tail in FIELDS.items():
        a = np.ascontiguousarray(clip[k], dtype=np.float32)
        if a.shape != (t, *tail):
            raise ValueError(f"clip field {k!r} has shape {a.shape}, expected {(t, *tail)}")
        tensors[k] = a
    meta = {"format": _core.CLIP_FORMAT, "format_version": str(_core.CLIP_FORMAT_VERSION), "fps": repr(float(clip["fps"])), "skill": str(int(clip["skill"])), "name": str(clip["name"]), "source": str(clip.get("source", "python"))}
    save_file(tensors, str(path), metadata=meta)


def register_generator(name: str, fn: Callable[[str, str], None]) -> None:
    """Register ``fn(failed_clip_path, out_dir)`` as the clip generator ``name`` of this process
    (``run.active.generator = name``); see the module doc. Re-registering a name replaces it."""
    if not callable(fn):
        raise TypeError("fn must be callable as fn(failed_clip_path: str, out_dir: str)")
    _core.register_generator(name, fn)
