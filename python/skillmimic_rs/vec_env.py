"""`VecEnv`: the SkillMimic environment as a gymnasium 1.x vector environment.

The Rust core steps ``num_envs`` MuJoCo environments in parallel (GIL released) and writes
observations, rewards and flags into numpy buffers preallocated here. Conventions:

* observations ``float32 (num_envs, 902)`` (index table: ``skillmimic_rs.OBS_BLOCKS``), actions
  ``float32 (num_envs, 156)`` in [-1, 1] (PD target = pi * action, exp-map joint coordinates);
* ``autoreset_mode="same_step"`` (default here; what the SB3 / rsl_rl adapters and most RL loops
  want): finished environments are reset inside ``step``; the terminal observations are in
  ``info["final_obs"]`` (object array, ``None`` elsewhere) with the mask ``info["_final_obs"]``,
  and densely in ``info["final_obs_dense"]``; the terminal step's reward terms and frame metrics
  in ``info["final_info"]`` (mask ``info["_final_info"]``);
* ``autoreset_mode="next_step"`` (gymnasium's default, ``gymnasium.make_vec``'s here): a finished
  environment returns its terminal observation; the next ``step`` resets it instead of stepping
  it (its action is ignored, reward 0, flags false, its step-info rows masked out);
* ``autoreset_mode="disabled"``: nothing resets by itself; call
  ``reset(options={"reset_mask": mask})`` (the loop of the original SkillMimic learner);
* episode starts: environment ``i`` draws from its own stream seeded ``seed + i`` (gymnasium's
  convention), so in every mode a batch plans the same episodes as
  ``gymnasium.vector.SyncVectorEnv`` over :class:`skillmimic_rs.SkillMimicEnv` with the same seed;
* ``info`` also carries the per-term reward breakdown (``reward_terms``, columns
  ``VecEnv.reward_term_names``), the contact graph, frame metrics and episode bookkeeping.
"""

from __future__ import annotations

import json
import os
import pathlib
import tempfile
import threading
from typing import Any, Mapping, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from . import _core

BUILTIN_DEMO = _core.BUILTIN_DEMO


def load_config(config: Mapping[str, Any] | str | os.PathLike | None) -> dict[str, Any]:
    """The ``[env]`` fields from a dict or a TOML file (the same file the CLI reads).

    A TOML file may hold the fields in an ``[env]`` table (a CLI config file; its ``[ppo]`` and
    ``[run]`` tables are ignored here) or, with none of those tables, at top level. The file is
    read by the Rust core with the CLI's rule for relative paths (``motion`` entries and
    ``v2.history.encoder``): relative to the file's folder, except that a path that exists only
    relative to the working directory stays as written (configs saved by the trainer). A dict is
    taken as is.
    """
    if config is None:
        return {}
    if isinstance(config, Mapping):
        return dict(config.get("env", config)) if "env" in config and isinstance(config["env"], Mapping) else dict(config)
    path = pathlib.Path(config)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} not found")
    return json.loads(_core.load_env_config(str(path)))


_MODES = {"same_step": AutoresetMode.SAME_STEP, "next_step": AutoresetMode.NEXT_STEP, "disabled": AutoresetMode.DISABLED}


def _parse_mode(mode: str | AutoresetMode) -> AutoresetMode:
    if isinstance(mode, AutoresetMode) and mode in _MODES.values():
        return mode
    if isinstance(mode, str):
        key = mode.lower().replace("-", "_")
        key = {"samestep": "same_step", "nextstep": "next_step"}.get(key, key)
        if key in _MODES:
            return _MODES[key]
    raise ValueError(f"autoreset_mode {mode!r} is not supported: use 'same_step', 'next_step' or 'disabled' (or the AutoresetMode members)")


def _observation_space(blocks: Sequence[tuple[str, int, int, float, float]], dim: int) -> gym.spaces.Box:
    """One environment's observation space: finite bounds where the task declares its values
    bounded by construction (rotation-matrix columns in [-1, 1], one-hot entries in [0, 1]; the
    core's ``obs_blocks``), unbounded elsewhere."""
    low = np.full(dim, -np.inf, np.float32)
    high = np.full(dim, np.inf, np.float32)
    for _, a, b, lo, hi in blocks:
        low[a:b], high[a:b] = lo, hi
    return gym.spaces.Box(low, high, (dim,), np.float32)


def _check_finite(value: Any, key: str) -> None:
    """Refuse NaN / infinite numbers in a config before it becomes JSON (which has no such
    values): a ``ValueError`` naming the key, like the Rust range check's messages."""
    if isinstance(value, float) and not np.isfinite(value):
        raise ValueError(f"config field '{key}': is not a finite number ({value})")
    if isinstance(value, Mapping):
        for k, v in value.items():
            _check_finite(v, f"{key}.{k}")
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _check_finite(v, f"{key}[{i}]")


class _Exclusive:
    """Non-blocking hold of a ``VecEnv`` for one call (see ``VecEnv._exclusive``)."""

    def __init__(self, lock: threading.Lock, what: str) -> None:
        self.lock, self.what = lock, what

    def __enter__(self) -> None:
        if not self.lock.acquire(blocking=False):
            raise RuntimeError(
                f"VecEnv.{self.what}: the environment is in use by another thread; one VecEnv must be used "
                "from one thread at a time (make one VecEnv per thread)"
            )

    def __exit__(self, *exc: object) -> None:
        self.lock.release()


class VecEnv(gym.vector.VectorEnv):
    """Batched environment of any registered task (gymnasium ``VectorEnv``).

    Args:
        num_envs: number of parallel environments.
        task: a task of the registry (``"imitation"``, the default: SkillMimic; ``"stand"``; see
            ``skillmimic_rs.TASKS``); the same as the config key ``task``.
        config: a dict of ``[env]`` config fields or a path to a TOML config file (CLI format).
            Unknown keys raise ``ValueError``.
        llc: the frozen policy a high-level task (``"heading"``, ``"circling"``, ``"throwing"``,
            ``"scoring"``, ``"steering"``) drives (the config key ``hlc.llc``). Over a
            ``gaussian_mlp`` skill policy the actions are integer choices (``Discrete``), each
            held for ``steps_per_action`` (3) simulation steps; over a ``modular_attention``
            checkpoint (ModSkill skill reuse) they are one embedding per body part (``Box`` of
            parts × embedding width), each projected onto the unit sphere and fed to that
            part's frozen controller, held for ``hlc.latent_steps`` (1) steps.
        autoreset_mode: ``"same_step"`` (default), ``"next_step"`` (gymnasium's default) or
            ``"disabled"``.
        copy: return copies of the internal buffers (default, safe); ``False`` returns the
            buffers themselves, which the next call overwrites.
        render_mode: ``"rgb_array"`` or ``None``.
        **overrides: individual config fields (e.g. ``hands="box"``, ``threads=2``).

    With no config the environment runs on the built-in demo clips (the stand-and-dribble clips
    shipped in ``motions/``) with the paper's default reward.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"], "render_fps": 60}

    def __init__(
        self,
        num_envs: int = 16,
        config: Mapping[str, Any] | str | os.PathLike | None = None,
        *,
        task: str | None = None,
        llc: str | os.PathLike | None = None,
        autoreset_mode: str | AutoresetMode = "same_step",
        copy: bool = True,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        mode = _parse_mode(autoreset_mode)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not supported: use 'rgb_array' or None")
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        cfg = load_config(config)
        cfg.update(overrides)
        if task is not None:
            cfg["task"] = task
        if llc is not None:
            cfg["hlc"] = dict(cfg.get("hlc", {}), llc=str(llc))
        cfg["num_envs"] = num_envs
        _check_finite(cfg, "env")
        cfg.setdefault("motion", [BUILTIN_DEMO])
        cfg["motion"] = [str(m) for m in cfg["motion"]]
        self._core = _core.CoreEnv(json.dumps(cfg), mode == AutoresetMode.SAME_STEP)
        self.metadata = dict(self.metadata, autoreset_mode=mode)
        self.num_envs = num_envs
        self.render_mode = render_mode
        self.copy = copy
        n, d, a = num_envs, self._core.obs_dim, self._core.act_dim
        self.single_observation_space = _observation_space(self._core.obs_blocks, d)
        kind, size = self._core.action_space
        if kind == "discrete":
            self.single_action_space = gym.spaces.Discrete(size)
        else:
            self.single_action_space = gym.spaces.Box(-1.0, 1.0, (a,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self._obs = np.zeros((n, d), np.float32)
        # the episode fields reported in every info dict (of those the task declares)
        self._episode_keys = [k for k in ("clip", "ref_frame", "progress", "skill") if k in self._core.episode_names]
        self._rew = np.zeros(n, np.float32)
        self._term = np.zeros(n, bool)
        self._trunc = np.zeros(n, bool)
        self._final_obs = np.zeros((n, d), np.float32)
        self._final_mask = np.zeros(n, bool)
        # episodes that ended but whose end-of-episode bookkeeping has not run (NEXT_STEP, DISABLED)
        self._unclosed = np.zeros(n, bool)
        # NEXT_STEP: environments the next step resets; rows reset by the last step
        self._pending = np.zeros(n, bool)
        self._reset_rows = np.zeros(n, bool)
        self._renderers: dict[str, tuple[Any, Any]] = {}  # scene XML -> (MjModel, Renderer)
        self._render_of: dict[int, tuple[Any, Any]] = {}  # environment -> its entry of _renderers
        self._mjcf_path: pathlib.Path | None = None
        #: environments ``render()`` draws (None: all, gymnasium's vector convention)
        self.render_env_ids: tuple[int, ...] | None = None
        self.closed = False
        self._busy = threading.Lock()

    # --- gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Reset all environments, or those of ``options["reset_mask"]`` (bool array of num_envs)."""
        with self._exclusive("reset"):
            return self._reset(seed, options)

    def _exclusive(self, what: str) -> _Exclusive:
        """Hold the environment for one call: a second thread calling meanwhile gets a clear
        ``RuntimeError`` (the shared output buffers make concurrent calls meaningless)."""
        return _Exclusive(self._busy, what)

    def _reset(self, seed: int | None, options: dict[str, Any] | None):
        self._check_open()
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        mask = None if options is None else options.get("reset_mask")
        if mask is not None:
            mask = np.asarray(mask)
            if mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
                raise ValueError(f"reset_mask: expected a bool array of shape ({self.num_envs},), got {mask.dtype} {mask.shape}")
            if seed is not None:
                raise ValueError("reset: pass either seed (full reset) or reset_mask, not both")
            if not mask.any():
                raise ValueError("reset_mask selects no environment")
            self._close_episodes(mask)
            self._core.reset_mask(mask, self._obs)
            self._pending[mask] = False
        else:
            self._close_episodes(np.ones(self.num_envs, bool))
            self._core.reset_all(seed, self._obs)
            self._pending[:] = False
        self._final_mask[:] = False
        self._reset_rows[:] = False
        return self._out(self._obs), self._info(step=False)

    def step(self, actions):
        """One policy step (60 Hz; high-level tasks: 20 Hz). Returns ``(obs, reward, terminated,
        truncated, info)``."""
        with self._exclusive("step"):
            return self._step(actions)

    def _step(self, actions):
        self._check_open()
        a = np.asarray(actions)
        if isinstance(self.single_action_space, gym.spaces.Discrete):
            k = int(self.single_action_space.n)
            if a.shape not in ((self.num_envs,), (self.num_envs, 1)):
                raise ValueError(f"actions: expected {self.num_envs} integer choices, shape ({self.num_envs},), got {a.shape}")
            if not np.issubdtype(a.dtype, np.integer) or a.min() < 0 or a.max() >= k:
                raise ValueError(f"actions: expected integer choices in 0..{k}, got dtype {a.dtype} with values {a.min()}..{a.max()}")
            return self._step_core(np.ascontiguousarray(a.reshape(self.num_envs, 1), dtype=np.float32))
        if a.shape != (self.num_envs, self.single_action_space.shape[0]):
            raise ValueError(f"actions: expected shape {(self.num_envs, self.single_action_space.shape[0])}, got {a.shape}")
        if not np.issubdtype(a.dtype, np.floating):
            raise ValueError(f"actions: expected a float array, got dtype {a.dtype}")
        return self._step_core(np.ascontiguousarray(a, dtype=np.float32))

    def _step_core(self, a: np.ndarray):
        mode = self.metadata["autoreset_mode"]
        reset = mode == AutoresetMode.NEXT_STEP and bool(self._pending.any())
        if reset:
            # NEXT_STEP: the finished environments are stepped once more with the batch (their
            # result is discarded), then reset from their own start streams; the reset overwrites
            # the whole simulation and task state, so the outcome equals not stepping them
            p = self._pending.copy()
            self._close_episodes(p)
        self._core.step(a, self._obs, self._rew, self._term, self._trunc, self._final_obs, self._final_mask)
        if reset:
            self._core.reset_mask(p, self._obs)
            self._rew[p] = 0.0
            self._term[p] = False
            self._trunc[p] = False
            self._reset_rows[:] = p
        else:
            self._reset_rows.fill(False)
        if mode != AutoresetMode.SAME_STEP:
            np.logical_or(self._term, self._trunc, out=self._unclosed)
        if mode == AutoresetMode.NEXT_STEP:
            self._pending[:] = self._unclosed
        return self._out(self._obs), self._out(self._rew), self._out(self._term), self._out(self._trunc), self._info(step=True)

    def _close_episodes(self, rows: np.ndarray) -> None:
        """End-of-episode bookkeeping of the ended episodes among ``rows`` before they reset."""
        m = rows & self._unclosed
        if m.any():
            self._core.end_episodes(m)
        self._unclosed[rows] = False

    def render(self):
        """RGB frames (``uint8 (H, W, 3)``), one per environment of ``render_env_ids`` (default:
        every environment, gymnasium's vector convention that its vector ``RecordVideo`` /
        ``HumanRendering`` wrappers expect; set ``render_env_ids = (0,)`` to render one)."""
        self._check_open()
        if self.render_mode != "rgb_array":
            return None
        import mujoco

        from .render import make_renderer, render_state

        ids = range(self.num_envs) if self.render_env_ids is None else self.render_env_ids
        frames = []
        for i in ids:
            if i not in self._render_of:
                # tasks with object variants have one scene per variant: one model and renderer
                # per distinct scene, each environment's scene text fetched once
                xml = self.mjcf_xml_of(i)
                if xml not in self._renderers:
                    model = mujoco.MjModel.from_xml_string(xml)
                    self._renderers[xml] = (model, make_renderer(model))
                self._render_of[i] = self._renderers[xml]
            model, renderer = self._render_of[i]
            frames.append(render_state(renderer, model, *self.get_state(i)))
        return tuple(frames)

    def close(self, **kwargs) -> None:
        """Release the simulation; later calls raise ``RuntimeError``."""
        for _, renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
        self._render_of.clear()
        if not self.closed:
            self._core.close()
        self.closed = True

    # --- research access ---------------------------------------------------------------------
    @property
    def task(self) -> str:
        """The task's registry name."""
        return self._core.task

    @property
    def reward_term_names(self) -> list[str]:
        """Columns of ``info["reward_terms"]``."""
        return list(self._core.term_names)

    @property
    def contact_graph_names(self) -> list[str]:
        """Columns of ``info["contact_graph"]`` (the configured contact-graph mode)."""
        return list(self._core.cg_names)

    @property
    def task_info_names(self) -> list[str]:
        """Columns of ``info["task_info"]`` (high-level tasks: the current episode's goal, e.g.
        ``goal_x``, ``goal_y`` in world metres)."""
        return list(self._core.cg_names)

    @property
    def steps_per_action(self) -> int:
        """Simulation steps per policy step (3 for the high-level tasks)."""
        return int(self._core.steps_per_action)

    @property
    def choice_labels(self) -> list[int]:
        """Skill label of each discrete choice of a high-level task (``control_mapping``)."""
        return list(self._core.choice_labels)

    def set_task_info(self, i: int, values) -> np.ndarray:
        """Move environment ``i``'s goal (``task_info_names`` order, world metres) and return the new
        observations (all environments)."""
        self._check_open()
        self._core.set_task_info(int(i), np.ascontiguousarray(values, dtype=np.float32), self._obs)
        return self._out(self._obs)

    def pd_targets(self) -> np.ndarray:
        """``(num_envs, 156)`` PD targets in [-1, 1] applied in the last simulation step (the frozen
        skill policy's actions in a high-level task; empty columns when the actions are the targets)."""
        self._check_open()
        return self._core.pd_targets()

    def task_info(self) -> np.ndarray:
        """``(num_envs, k)`` task information (high-level tasks: the goal of each environment's current
        episode, also right after a reset)."""
        self._check_open()
        return self._core.contact_graph()

    @property
    def frame_metric_names(self) -> list[str]:
        """Columns of ``info["frame_metrics"]``."""
        return list(self._core.frame_metric_names)

    @property
    def max_episode_length(self) -> int:
        """Longest episode in policy steps."""
        return self._core.max_episode_length

    @property
    def config(self) -> dict[str, Any]:
        """The effective configuration (defaults filled in)."""
        return json.loads(self._core.config_json())

    @property
    def clips(self) -> list[tuple[str, int, int]]:
        """(name, skill label, frames) of every clip in the motion library."""
        return self._core.clips()

    @property
    def mjcf_xml(self) -> str:
        """MJCF text of the scene the core compiled."""
        self._check_open()
        return self._core.mjcf_xml

    def mjcf_xml_of(self, i: int) -> str:
        """MJCF text of environment ``i``'s scene: tasks with several object variants (the TokenHSI
        tasks, ``hsi.object_variants``) compile one scene per variant, environment ``i`` using
        variant ``i mod object_variants``; ``mjcf_xml`` is environment 0's."""
        self._check_open()
        return self._core.env_mjcf_xml(int(i))

    @property
    def mjcf_path(self) -> pathlib.Path:
        """A file holding exactly ``mjcf_xml`` (written once to a temporary folder)."""
        if self._mjcf_path is None:
            import hashlib

            xml = self.mjcf_xml
            folder = pathlib.Path(tempfile.gettempdir()) / "skillmimic_rs"
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / f"scene_{hashlib.sha1(xml.encode()).hexdigest()[:16]}.xml"
            if not path.exists():
                tmp = path.with_suffix(f".tmp{os.getpid()}")
                tmp.write_text(xml)
                tmp.replace(path)
            self._mjcf_path = path
        return self._mjcf_path

    def get_state(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo ``(qpos, qvel)`` of environment ``i`` (float64 copies)."""
        self._check_open()
        return self._core.get_qpos(int(i)), self._core.get_qvel(int(i))

    def set_state(self, i: int, qpos, qvel) -> np.ndarray:
        """Overwrite environment ``i``'s ``qpos``/``qvel`` (forward kinematics runs, time, controls
        and warm start are cleared); returns the refreshed observations of all environments. The
        SkillMimic-V2 history window (if on) is left as it was."""
        self._check_open()
        q = np.ascontiguousarray(qpos, dtype=np.float64)
        v = np.ascontiguousarray(qvel, dtype=np.float64)
        self._core.set_state(int(i), q, v, self._obs)
        return self._out(self._obs)

    def history_window(self, i: int) -> np.ndarray | None:
        """(k, 316) SkillMimic-V2 history window of environment ``i`` (oldest frame first), or None
        when the history encoder is off; its embedding fills the last observation entries at the
        next step."""
        self._check_open()
        return self._core.history_window(i)

    @property
    def episode_names(self) -> list[str]:
        """Keys of ``episode_info()``."""
        return list(self._core.episode_names)

    def task_markers(self, i: int = 0) -> list[dict[str, Any]]:
        """The task's visual markers for environment ``i``'s current information row (goal
        spheres, rings, hoops: dicts with ``kind``, world-metre positions and ``rgba``)."""
        self._check_open()
        return self._core.markers(np.ascontiguousarray(self.task_info()[int(i)], dtype=np.float32))

    def episode_info(self) -> dict[str, np.ndarray]:
        """The per-environment episode fields the task declares (``episode_names``; imitation:
        clip index, start/reference frame, progress, length and skill label; tracking: clip and
        reference frame; an empty dict for the other tasks)."""
        self._check_open()
        return self._core.episode_info()

    def reward_terms(self) -> np.ndarray:
        """``(num_envs, terms)`` sub-rewards of the last step (columns: ``reward_term_names``)."""
        self._check_open()
        return self._core.reward_terms()

    def contact_graph(self) -> np.ndarray:
        """``(num_envs, k)`` simulated contact-graph entries of the last step."""
        self._check_open()
        return self._core.contact_graph()[:, : len(self._core.cg_names)]

    # --- helpers ------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed:
            raise RuntimeError("VecEnv is closed")

    def _out(self, a: np.ndarray) -> np.ndarray:
        return a.copy() if self.copy else a

    def _info(self, step: bool) -> dict[str, Any]:
        n = self.num_envs
        every = np.ones(n, bool)
        info: dict[str, Any] = {}
        if self._episode_keys:
            ep = self._core.episode_info()
            for k in self._episode_keys:
                info[k], info["_" + k] = ep[k], every
        if step:
            # columns: reward_term_names, contact_graph_names (task info), frame_metric_names;
            # rows an automatic NEXT_STEP reset took this step carry no step result
            any_reset = bool(self._reset_rows.any())
            stepped = ~self._reset_rows if any_reset else every
            res: dict[str, np.ndarray] = {"reward_terms": self._core.reward_terms()}
            if self._core.cg_names:
                label = self._core.info_label
                res[label] = self.contact_graph() if label == "contact_graph" else self.task_info()
            res["frame_metrics"] = self._core.frame_metrics()
            # MuJoCo's instability warnings (physics reset, episode terminated) per environment
            res["unstable"] = self._core.unstable()
            for k, v in res.items():
                if any_reset:
                    v[self._reset_rows] = 0
                info[k], info["_" + k] = v, stepped
            if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP and self._final_mask.any():
                fm = self._final_mask.copy()
                final = np.empty(n, dtype=object)
                for i in np.flatnonzero(fm):
                    final[i] = self._final_obs[i].copy()
                info["final_obs"], info["_final_obs"] = final, fm
                info["final_obs_dense"] = self._final_obs.copy()
                # the terminal step's reward terms and frame metrics (the reset leaves those rows;
                # the task information rows above already describe the new episode)
                info["final_info"] = {}
                for key in ("reward_terms", "frame_metrics"):
                    info["final_info"][key], info["final_info"]["_" + key] = res[key].copy(), fm.copy()
                info["_final_info"] = fm.copy()
        return info

    def __del__(self):
        try:
            if not self.closed:
                self.close()
        except Exception:
            pass
