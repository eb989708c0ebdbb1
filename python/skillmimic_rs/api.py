"""The paper's trainer, evaluation and playback from Python: the same Rust runner and the same
artefacts as ``skillmimic train`` / ``eval`` / ``play``.

::

    import skillmimic_rs as sm
    summary = sm.train(preset="tiny", iterations=20, out="runs/a", no_video=True)
    report = sm.evaluate(summary["checkpoint"], episodes=16)
    sm.play(summary["checkpoint"], video="runs/a/play.gif", steps=120)

Keyword options are the command's flags with ``_`` for ``-`` (``num_envs=64`` → ``--num-envs 64``;
``True`` → a bare flag; a list → the flag once per entry, e.g. ``motion=[a, b]``); ``config`` is a
TOML file (``--config``) or a dict of ``{table: {field: value}}`` (each leaf becomes ``--set
table.field=value``, applied after the flags, as on the command line).
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import tempfile
from typing import Any, Callable, Mapping

from . import _core
from ._gl import before_rendering


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"config value {v!r} is not a finite number")
        return repr(v)
    if isinstance(v, (str, os.PathLike)):
        return json.dumps(os.fspath(v))  # a TOML basic string
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"config value {v!r} of type {type(v).__name__} has no TOML form")


def _sets(config: Mapping[str, Any], prefix: str = "") -> list[str]:
    """``{"ppo": {"lr": 1e-4}}`` → ``["--set", "ppo.lr=0.0001"]`` (tables recurse, other values are leaves)."""
    out: list[str] = []
    for k, v in config.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping) and v and prefix.count(".") < 2:
            out += _sets(v, key + ".")
        else:
            out += ["--set", f"{key}={_toml_value(v)}"]
    return out


def _argv(config: Mapping[str, Any] | str | os.PathLike | None, options: Mapping[str, Any]) -> list[str]:
    argv: list[str] = []
    if isinstance(config, (str, os.PathLike)):
        argv += ["--config", os.fspath(config)]
    for k, v in options.items():
        if v is None or v is False:
            continue
        flag = "--" + k.replace("_", "-")
        if v is True:
            argv.append(flag)
        elif isinstance(v, (list, tuple)):
            for x in v:
                argv += [flag, os.fspath(x) if isinstance(x, os.PathLike) else str(x)]
        else:
            argv += [flag, os.fspath(v) if isinstance(v, os.PathLike) else str(v)]
    if isinstance(config, Mapping):
        argv += _sets(config)
    return argv


def cli(*args: str) -> int:
    """Run ``skillmimic <args>`` in this process; returns the exit code (0 ok, 1 failed, 2 usage).

    Ctrl-C during ``train`` stops it after the iteration under way with a checkpoint (continue with
    ``--resume latest``), then raises ``KeyboardInterrupt``."""
    before_rendering()  # a command may render (play, the end-of-training video)
    return int(_core.cli_main([os.fspath(a) for a in args]))


def _run(command: str, argv: list[str]) -> None:
    code = cli(command, *argv)
    if code != 0:
        raise RuntimeError(f"`skillmimic {command}` failed (exit code {code}; the error is printed above): arguments {argv}")


def train(
    config: Mapping[str, Any] | str | os.PathLike | None = None,
    *,
    out: str | os.PathLike = "runs/train",
    on_iteration: Callable[[dict[str, Any]], None] | None = None,
    verbose: bool = True,
    **options: Any,
) -> dict[str, Any]:
    """Train with PPO exactly as ``skillmimic train`` (same defaults: preset ``small``, the built-in
    demo clips; ``preset="tiny"`` for a quick run) and return the run's ``summary.json`` as a dict
    (``checkpoint``, ``metrics``, ``samples``, ``early_mean_reward`` → ``late_mean_reward``, …).

    ``on_iteration`` receives every iteration's log record (the dict of ``log.jsonl``); with
    ``verbose`` a line is printed about every 5 % of the run. Ctrl-C stops after the current
    iteration with the checkpoint saved (``resume="latest"`` continues).
    """
    argv = _argv(config, dict(options, out=out))
    try:
        trainer = _core.Trainer(argv, None)
    except ValueError as e:
        raise ValueError(f"skillmimic_rs.train: {e}") from None
    total = trainer.iterations  # (the trainer is busy inside run: read it before)
    every = max(1, total // 20)

    def hook(js: str) -> None:
        rec = json.loads(js)
        if on_iteration is not None:
            on_iteration(rec)
        if verbose and (rec["iteration"] % every == 0 or rec["iteration"] == total):
            print(f"iteration {rec['iteration']}/{total}: reward/step {rec['mean_reward']:.4f}, "
                  f"{rec['samples_per_s']:.0f} samples/s", flush=True)

    summary = trainer.run(hook)
    if summary is None:  # not rank 0 of a data-parallel run
        return {}
    s = json.loads(summary)
    s["out"] = os.path.dirname(s["metrics"])
    return s


def evaluate(checkpoint: str | os.PathLike | None, *, out: str | os.PathLike | None = None,
             config: Mapping[str, Any] | None = None, **options: Any) -> dict[str, Any]:
    """Evaluate as ``skillmimic eval`` (imitation metrics, success rates, ``v2=True`` for SR/TSR/NR,
    ``baselines=True`` for high-level tasks) and return its JSON report as a dict; ``out`` keeps
    the file (default: a temporary file, removed)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(out) if out is not None else pathlib.Path(tmp) / "metrics.json"
        _run("eval", _argv(config, dict(options, checkpoint=checkpoint, out=path)))
        return json.loads(path.read_text())


def play(checkpoint: str | os.PathLike | None = None, *, video: str | os.PathLike | None = None,
         states: str | os.PathLike | None = None, config: Mapping[str, Any] | None = None,
         **options: Any) -> dict[str, pathlib.Path]:
    """Roll out a policy (or ``reference=clip``) as ``skillmimic play`` and write a headless video
    (``.mp4`` needs ffmpeg, ``.gif`` nothing) and/or the visited states (safetensors); returns the
    written paths."""
    if video is None and states is None:
        raise ValueError("skillmimic_rs.play: give video= and/or states= (where to write the result)")
    _run("play", _argv(config, dict(options, checkpoint=checkpoint, video=video, states=states)))
    return {k: pathlib.Path(v) for k, v in (("video", video), ("states", states)) if v is not None}


def _retarget(source: str | os.PathLike, kind: str, out: str | os.PathLike, options: dict[str, Any]) -> dict[str, Any]:
    _run("retarget", _argv(None, dict(options, **{kind: source}, out=out)))
    name = options.get("name") or pathlib.Path(source).stem
    report = json.loads((pathlib.Path(out) / f"{name}.retarget.json").read_text())
    report["clip"] = pathlib.Path(out) / f"{name}.safetensors"
    return report


def retarget_bvh(bvh: str | os.PathLike, *, out: str | os.PathLike, skill: int, map: str | os.PathLike = "cmu",
                 **options: Any) -> dict[str, Any]:
    """Retarget a BVH motion onto the SkillMimic humanoid as ``skillmimic retarget --bvh`` (joint
    ``map``: ``humanoid``, ``mocapbank``, ``cmu`` or a TOML file; ``ball_csv=``, ``ball_joint=``,
    ``name=``, ``no_ground=True``, ``ik=True``) and return its report (foot penetration and sliding,
    joint-speed spikes, scale, IK residuals) with ``clip``: the written clip's path."""
    return _retarget(bvh, "bvh", out, dict(options, skill=skill, map=map))


def retarget_amass(npz: str | os.PathLike, *, out: str | os.PathLike, skill: int, map: str | os.PathLike = "smplh",
                   **options: Any) -> dict[str, Any]:
    """Retarget an SMPL / SMPL-H / SMPL-X sequence in the AMASS ``.npz`` layout onto the SkillMimic
    humanoid as ``skillmimic retarget --amass`` (``rest="smpl"`` (default) or ``"humanoid"``,
    ``body_model=`` a user's model file, and the options of :func:`retarget_bvh`); returns the
    report with ``clip``."""
    return _retarget(npz, "amass", out, dict(options, skill=skill, map=map))


def amass_to_smpl(npz: str | os.PathLike, *, out: str | os.PathLike, **options: Any) -> dict[str, Any]:
    """Write an SMPL / SMPL-H / SMPL-X sequence in the AMASS ``.npz`` layout as a clip of the SMPL
    humanoid with its SMPL joint rotations as they are (no retargeting), as ``skillmimic retarget
    --amass FILE --to smpl`` (``name=``, ``no_ground=True``); returns the report (frames, fps,
    ground shift) with ``clip``. The tracking task also reads such ``.npz`` files directly
    (``env.motion``, ``env.character = "smpl"``)."""
    return _retarget(npz, "amass", out, dict(options, to="smpl"))


def retarget_positions(csv: str | os.PathLike, *, out: str | os.PathLike, skill: int, fps: float,
                       map: str | os.PathLike = "humanoid", **options: Any) -> dict[str, Any]:
    """Retarget joint positions (a CSV with ``<joint>_x,<joint>_y,<joint>_z`` columns, one row per
    frame at ``fps``) onto the SkillMimic humanoid as ``skillmimic retarget --positions``; the
    options and the returned report are those of :func:`retarget_bvh`."""
    return _retarget(csv, "positions", out, dict(options, skill=skill, fps=fps, map=map))
