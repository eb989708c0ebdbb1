"""Headless rendering of skillmimic_rs states with ``mujoco.Renderer`` and video writing.

``MUJOCO_GL=egl`` (set by the package when no display exists) renders on the CPU with Mesa.
MP4 needs the ``video`` extra (``imageio`` + ``imageio-ffmpeg``, which bundles ffmpeg); GIF works
with Pillow alone.
"""

from __future__ import annotations

import pathlib
from typing import Iterable, Sequence

import mujoco
import numpy as np


def make_renderer(model: mujoco.MjModel, width: int = 640, height: int = 480) -> mujoco.Renderer:
    """An offscreen renderer; call ``close()`` on it when done."""
    from ._gl import before_rendering

    before_rendering()
    return mujoco.Renderer(model, height=height, width=width)


def render_state(renderer: mujoco.Renderer, model: mujoco.MjModel, qpos, qvel=None, camera: str | int = "side") -> np.ndarray:
    """RGB frame (``uint8 (H, W, 3)``) of the state ``qpos`` (and ``qvel``) seen by ``camera``."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    if qvel is not None:
        data.qvel[:] = qvel
    mujoco.mj_forward(model, data)
    renderer.update_scene(data, camera=camera)
    return renderer.render().copy()


def write_video(frames: Sequence[np.ndarray] | Iterable[np.ndarray], path: str | pathlib.Path, fps: int = 30) -> pathlib.Path:
    """Write frames to ``.mp4`` (imageio-ffmpeg) or ``.gif`` (Pillow)."""
    path = pathlib.Path(path)
    frames = list(frames)
    if not frames:
        raise ValueError("write_video: no frames")
    if path.suffix == ".gif":
        try:
            from PIL import Image
        except ImportError as e:  # pragma: no cover - depends on the optional extra
            raise ImportError("GIF output needs Pillow (the video extra): pip install 'skillmimic-rs[video]'") from e

        images = [Image.fromarray(f) for f in frames]
        images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
        return path
    if path.suffix == ".mp4":
        try:
            import imageio.v2 as imageio
        except ImportError as e:  # pragma: no cover - depends on the optional extra
            raise ImportError("MP4 output needs the video extra: pip install 'skillmimic-rs[video]'") from e
        imageio.mimwrite(path, frames, fps=fps, codec="libx264", quality=7, macro_block_size=8)
        return path
    raise ValueError(f"write_video: unsupported extension {path.suffix!r} (use .mp4 or .gif)")


def render_episode(env, policy=None, steps: int = 120, path: str | pathlib.Path = "episode.mp4", env_id: int = 0, fps: int = 30, width: int = 640, height: int = 480) -> pathlib.Path:
    """Roll out ``policy`` (a callable obs -> actions; zero actions if None) in a ``VecEnv`` for
    ``steps`` steps and write environment ``env_id`` to a video (every second 60 Hz frame at 30 fps)."""
    model = mujoco.MjModel.from_xml_string(env.mjcf_xml)
    renderer = make_renderer(model, width, height)
    try:
        obs, _ = env.reset()
        frames = []
        stride = max(1, round(60 / fps))
        for k in range(steps):
            actions = np.zeros(env.action_space.shape, np.float32) if policy is None else policy(obs)
            obs, *_ = env.step(actions)
            if k % stride == 0:
                frames.append(render_state(renderer, model, *env.get_state(env_id)))
        return write_video(frames, path, fps)
    finally:
        renderer.close()
