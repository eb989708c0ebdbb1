"""Interactive play of the high-level tasks in MuJoCo's viewer: a person switches the skill with the
keyboard and places the target with the mouse, while the frozen skill policy drives the humanoid.

Keys (SkillMimic's viewer mapping, applied to the task's choices that carry the label):
``←`` 011 dribble left, ``→`` 012 dribble right, ``↑`` 013 dribble forward, ``Q`` 001 pickup,
``W`` 002 rebound, ``E`` 031 layup, ``R`` 034 turnaround layup; ``P`` hands the choice back to the
high-level policy (when a checkpoint was given); ``I``/``J``/``K``/``L`` move the target by
0.5 m (+y / −x / −y / +x). Mouse: double-click on the floor to place the target there (the
viewer's selection point on the world body). MuJoCo's viewer also binds some of these letters to
visual toggles.

Without a display the viewer cannot open: :func:`play` raises ``RuntimeError`` with what to do
instead (``skillmimic play --video``).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any, Sequence

import numpy as np

#: GLFW key code -> skill label (SkillMimic's viewer keys).
KEY_LABELS: dict[int, int] = {263: 11, 262: 12, 265: 13, ord("Q"): 1, ord("W"): 2, ord("E"): 31, ord("R"): 34}
#: GLFW key code -> target move (dx, dy) in metres.
KEY_MOVES: dict[int, tuple[float, float]] = {ord("I"): (0.0, 0.5), ord("K"): (0.0, -0.5), ord("J"): (-0.5, 0.0), ord("L"): (0.5, 0.0)}
KEY_POLICY = ord("P")


class Controller:
    """What the person asked for: a manual choice (or the policy's), and target moves.

    ``labels`` = the task's skill label per choice (``VecEnv.choice_labels``)."""

    def __init__(self, labels: Sequence[int], has_policy: bool):
        self.labels = list(labels)
        self.has_policy = has_policy
        self.manual: int | None = None if has_policy else 0
        self.moves: list[tuple[float, float]] = []
        self.message = ""

    def on_key(self, key: int) -> None:
        """Viewer key callback (GLFW key code)."""
        if key in KEY_LABELS:
            label = KEY_LABELS[key]
            if label in self.labels:
                self.manual = self.labels.index(label)
                self.message = f"skill {label:03d} (choice {self.manual})"
            else:
                self.message = f"skill {label:03d} is not a choice of this task ({self.labels})"
        elif key == KEY_POLICY and self.has_policy:
            self.manual = None
            self.message = "high-level policy in control"
        elif key in KEY_MOVES:
            self.moves.append(KEY_MOVES[key])

    def choose(self, policy_choice: int | None) -> int:
        """The choice to apply: the manual one, else the policy's, else 0."""
        if self.manual is not None or policy_choice is None:
            return self.manual if self.manual is not None else 0
        return int(policy_choice)

    def take_moves(self) -> tuple[float, float]:
        """Sum of the pending keyboard target moves (cleared)."""
        dx = sum(m[0] for m in self.moves)
        dy = sum(m[1] for m in self.moves)
        self.moves.clear()
        return dx, dy


def floor_click(select: int, localpos: np.ndarray, last: np.ndarray | None) -> np.ndarray | None:
    """The world xy of a new double-click on the floor, from the viewer's perturbation state: a
    selection of the world body (``select == 0``) stores the world point in ``localpos``. Returns
    ``None`` when nothing new was clicked (same point as ``last``, or no point)."""
    p = np.asarray(localpos, dtype=np.float64)
    if select != 0 or not np.any(p) or (last is not None and np.allclose(p, last)):
        return None
    return p.copy()


def has_display() -> bool:
    """Whether a window can open (macOS and Windows always; elsewhere DISPLAY or WAYLAND_DISPLAY)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _draw_markers(scene: Any, markers: Sequence[dict[str, Any]]) -> None:
    """Draw the task's markers (``VecEnv.task_markers``: goal spheres, rings, hoops) into the
    viewer's user scene."""
    import mujoco

    scene.ngeom = 0
    eye = np.eye(3).ravel()
    for m in markers[: scene.maxgeom]:
        g = scene.geoms[scene.ngeom]
        rgba = np.asarray(m["rgba"], np.float32)
        if m["kind"] == "sphere":
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_SPHERE, [m["radius"], 0, 0], np.asarray(m["pos"]), eye, rgba)
        elif m["kind"] == "box":
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_BOX, np.asarray(m["half"]), np.asarray(m["pos"]), eye, rgba)
        else:
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), eye, rgba)
            mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_CAPSULE, m["radius"], np.asarray(m["from"]), np.asarray(m["to"]))
        scene.ngeom += 1


def viewer_env(task: str, llc: str | os.PathLike, *, config: Any = None, **overrides: Any) -> Any:
    """The one environment the viewer plays: ``config`` (a training config file such as the
    ``*.toml`` the trainer writes next to a checkpoint, or a dict of ``[env]`` fields; every key
    of it applies) with ``task``, the skill policy ``llc`` and ``overrides`` on top."""
    from .vec_env import VecEnv

    return VecEnv(1, config, task=task, llc=llc, **overrides)


def play(task: str, llc: str | os.PathLike, checkpoint: str | os.PathLike | None = None, *, seed: int = 0, realtime: bool = True, config: Any = None, **overrides: Any) -> None:
    """Open MuJoCo's viewer on one environment of high-level ``task`` driven by the skill policy
    ``llc``; the high-level ``checkpoint`` (optional) chooses skills until a key takes over.
    ``config``: a training config file or dict (see :func:`viewer_env`); ``overrides``: further
    config fields (e.g. ``motion=[...]``)."""
    if not has_display():
        raise RuntimeError(
            "interactive play needs a display (DISPLAY / WAYLAND_DISPLAY is not set on this machine); "
            "on a headless machine write a video instead: skillmimic play --checkpoint CKPT --video out.mp4"
        )
    import mujoco
    import mujoco.viewer

    from . import _core

    env = viewer_env(task, llc, config=config, **overrides)
    if not env.choice_labels:
        env.close()
        raise ValueError(f"{llc}: interactive play switches discrete skills; over a modular skill policy the actions are part embeddings (write a video instead: skillmimic play --checkpoint CKPT --video out.mp4)")
    policy = _core.Policy.load(str(checkpoint)) if checkpoint is not None else None
    ctrl = Controller(env.choice_labels, policy is not None)
    model = mujoco.MjModel.from_xml_string(env.mjcf_xml)
    data = mujoco.MjData(model)
    obs, _ = env.reset(seed=seed)
    names = env.task_info_names
    last_click: np.ndarray | None = None
    dt = env.steps_per_action / 60.0
    with mujoco.viewer.launch_passive(model, data, key_callback=ctrl.on_key) as v:
        while v.is_running():
            t0 = time.perf_counter()
            goal = env.task_info()[0].copy()
            click = floor_click(int(v.perturb.select), np.array(v.perturb.localpos), last_click)
            dx, dy = ctrl.take_moves()
            if names[:2] == ["goal_x", "goal_y"] and (click is not None or dx or dy):
                if click is not None:
                    last_click = click
                    goal[:2] = click[:2]
                goal[0] += dx
                goal[1] += dy
                obs = env.set_task_info(0, goal)
            choice = None
            if policy is not None:
                logits, _ = policy.infer(obs[:1])
                choice = int(np.argmax(logits[0]))
            a = ctrl.choose(choice)
            obs, _, _, _, _ = env.step(np.array([a]))
            qpos, qvel = env.get_state(0)
            data.qpos[:], data.qvel[:] = qpos, qvel
            mujoco.mj_forward(model, data)
            with v.lock():
                _draw_markers(v.user_scn, env.task_markers(0))
            v.sync()
            if realtime:
                time.sleep(max(0.0, dt - (time.perf_counter() - t0)))
    env.close()


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m skillmimic_rs.interactive --task heading --llc skills.safetensors [--checkpoint hlc.safetensors]``"""
    import argparse

    p = argparse.ArgumentParser(prog="python -m skillmimic_rs.interactive", description=__doc__.split("\n\n")[0])
    from . import _core

    p.add_argument("--task", required=True, choices=list(_core.HIGH_LEVEL_TASKS))
    p.add_argument("--llc", required=True, help="skill policy checkpoint")
    p.add_argument("--checkpoint", help="high-level policy checkpoint (optional: keys only without it)")
    p.add_argument("--motion", action="append", help="clip files or folders of the episode starts (repeatable)")
    p.add_argument("--config", help="training config file whose [env] keys all apply (e.g. the checkpoint's .toml)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    extra = {"motion": args.motion} if args.motion else {}
    try:
        play(args.task, args.llc, args.checkpoint, seed=args.seed, config=args.config, **extra)
    except RuntimeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
