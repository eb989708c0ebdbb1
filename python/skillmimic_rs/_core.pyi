"""Type stubs of the Rust extension ``skillmimic_rs._core`` (use ``skillmimic_rs.VecEnv``)."""

from typing import Any, Callable

import numpy as np
import numpy.typing as npt

OBS_DIM: int
BUILTIN_DEMO: str
CLIP_FORMAT: str
CLIP_FORMAT_VERSION: int
#: name -> (start, stop) of each block of the observation (Rust ``obs::BLOCKS``)
OBS_BLOCKS: dict[str, tuple[int, int]]
HUMANOID_DIM: int
STATE_DIM: int
#: the SkillMimic humanoid's action width (156); other characters: ``CHARACTERS[name]["act_dim"]``
ACT_DIM: int
#: every registered character (``env.character``) -> act_dim, proprio_dim, num_bodies, hands, ballplay, summary
CHARACTERS: dict[str, dict[str, Any]]
HISTORY_FEATURE_DIM: int
#: reward-term names of the imitation task (Rust ``reward::TERM_NAMES``), columns of its ``CoreEnv.reward_terms()``
TERM_NAMES: tuple[str, ...]
#: columns of ``CoreEnv.frame_metrics()``
FRAME_METRIC_NAMES: tuple[str, ...]
#: keys of an ``[env]`` table that hold input paths (resolved relative to the config file)
CONFIG_PATH_KEYS: tuple[str, ...]
#: Registered tasks (``env.task``) and policy families (``ppo.policy``).
TASKS: tuple[str, ...]
HIGH_LEVEL_TASKS: tuple[str, ...]
POLICY_FAMILIES: tuple[str, ...]

def load_env_config(path: str) -> str:
    """JSON of the ``[env]`` fields a TOML file sets, relative paths resolved by the CLI's rule."""

def load_train_config(path: str, preset: str = "small") -> str:
    """JSON of the training configuration ``skillmimic train --preset PRESET --config PATH`` starts from."""

def resolve_config_path(written: str, config_dir: str) -> str:
    """The CLI's rule for one relative path written in a config file in ``config_dir``."""

def core_version() -> str:
    """Version of the Rust core."""

def cli_main(argv: list[str], own_signals: bool = False) -> int:
    """Run the ``skillmimic`` command-line tool in-process (GIL released); its exit code.

    ``train`` stops after the iteration under way, with a checkpoint, on a signal: with
    ``own_signals`` (a process that is the tool) on SIGINT or SIGTERM as the binary does; without
    it on any signal whose Python handler raises, whose exception (``KeyboardInterrupt``) is then
    raised here."""

class CoreEnv:
    """The batched SkillMimic environment of the Rust core."""

    def __init__(self, config_json: str, autoreset: bool) -> None:
        """Build from a JSON object with the fields of the ``[env]`` config table."""
    def config_json(self) -> str:
        """The effective configuration as JSON (defaults filled in)."""
    @property
    def num_envs(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def act_dim(self) -> int: ...
    @property
    def task(self) -> str:
        """The task's registry name."""
    @property
    def action_space(self) -> tuple[str, int]:
        """("box", dim) or ("discrete", n)."""
    @property
    def max_episode_length(self) -> int:
        """Longest episode in policy steps."""
    @property
    def term_names(self) -> list[str]:
        """Columns of ``reward_terms()``."""
    @property
    def steps_per_action(self) -> int:
        """Simulation steps per policy step (3 for the high-level tasks)."""
    @property
    def choice_labels(self) -> list[int]:
        """Skill label of each discrete choice (high-level tasks); empty otherwise."""
    def set_task_info(self, i: int, values: npt.NDArray[np.float32], obs_out: npt.NDArray[np.float32]) -> None:
        """Move environment i's goal (values in ``cg_names`` order) and write the observations."""
    @property
    def cg_names(self) -> list[str]:
        """Contact-graph entries of the configured mode."""
    @property
    def frame_metric_names(self) -> list[str]:
        """Columns of ``frame_metrics()``."""
    @property
    def mjcf_xml(self) -> str:
        """MJCF text of the compiled scene."""
    def env_mjcf_xml(self, i: int) -> str:
        """MJCF text of environment i's scene (one per object variant)."""
    @property
    def qpos_qvel_sizes(self) -> tuple[int, int]:
        """(nq, nv) of the MuJoCo model."""
    @property
    def closed(self) -> bool: ...
    def clips(self) -> list[tuple[str, int, int]]:
        """(name, skill label, frames) of every clip."""
    def reset_all(self, seed: int | None, obs_out: npt.NDArray[np.float32]) -> None:
        """Reset every environment; writes observations into ``obs_out`` (N, D)."""
    def end_episodes(self, mask: npt.NDArray[np.bool_]) -> None:
        """End-of-episode bookkeeping (ATS) of the masked environments before ``reset_mask``."""
    def reset_mask(self, mask: npt.NDArray[np.bool_], obs_out: npt.NDArray[np.float32]) -> None:
        """Reset the environments selected by ``mask``."""
    def step(
        self,
        actions: npt.NDArray[np.float32],
        obs_out: npt.NDArray[np.float32],
        reward_out: npt.NDArray[np.float32],
        terminated_out: npt.NDArray[np.bool_],
        truncated_out: npt.NDArray[np.bool_],
        final_obs_out: npt.NDArray[np.float32],
        final_mask_out: npt.NDArray[np.bool_],
    ) -> None:
        """One policy step; outputs are written into the given buffers (GIL released while stepping)."""
    def unstable(self) -> npt.NDArray[np.bool_]:
        """(N,) MuJoCo reported a numerical instability during the last step (physics reset, episode terminated)."""
    def reward_terms(self) -> npt.NDArray[np.float32]:
        """(N, 12) sub-rewards of the last step."""
    def contact_graph(self) -> npt.NDArray[np.float32]:
        """(N, 4) contact-graph entries of the last step (padded)."""
    def frame_metrics(self) -> npt.NDArray[np.float32]:
        """(N, 4) evaluation errors of the last step."""
    def pd_targets(self) -> npt.NDArray[np.float32]:
        """(N, 156) PD targets applied in the last simulation step ((N, 0) when the actions are the targets)."""
    def episode_info(self) -> dict[str, npt.NDArray[np.int64]]:
        """clip, ref_start, ref_frame, progress, length, skill per environment."""
    def get_qpos(self, i: int) -> npt.NDArray[np.float64]: ...
    def get_qvel(self, i: int) -> npt.NDArray[np.float64]: ...
    def set_state(self, i: int, qpos: npt.NDArray[np.float64], qvel: npt.NDArray[np.float64], obs_out: npt.NDArray[np.float32]) -> None:
        """Overwrite qpos/qvel of environment ``i`` and refresh all observations."""
    def history_window(self, i: int) -> npt.NDArray[np.float32] | None:
        """(k, 316) history window of environment ``i`` (oldest first), None without the encoder."""
    def close(self) -> None:
        """Release the simulation."""

class Policy:
    """A trained policy evaluated by the Rust inference path."""

    @staticmethod
    def load(path: str) -> "Policy":
        """Load a checkpoint written by ``skillmimic train`` or ``skillmimic export``."""
    @property
    def obs_dim(self) -> int: ...
    @property
    def act_dim(self) -> int: ...
    def infer(self, obs: npt.NDArray[np.float32]) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """Action means (N, act_dim) and values (N,)."""

class Trainer:
    """The PPO trainer of ``skillmimic train`` for one rank (``python -m skillmimic_rs.train``).

    ``argv``: the arguments of ``skillmimic train`` (no program name). ``collective``: None (one
    process) or an object with ``rank``, ``world_size``, ``all_reduce(array)`` (in-place sum) and
    ``broadcast(array)`` (in place, from rank 0), e.g. ``skillmimic_rs.distributed.TorchCollective``.
    """

    def __init__(self, argv: list[str], collective: object | None = None) -> None: ...
    @staticmethod
    def usage() -> str: ...
    def run(self, on_iteration: Callable[[str], None] | None = None) -> str | None:
        """Train to ``run.iterations``; the summary as JSON on rank 0, None on other ranks."""
    def iteration(self) -> str:
        """One iteration; its statistics as JSON."""
    def collect_rollout(self) -> str: ...
    def update_from_rollout(self, stats_json: str | None = None) -> str: ...
    def load_rollout_part(self, other: "Trainer") -> None:
        """This rank's environments of a one-process trainer's rollout."""
    def state(self) -> dict[str, Any]:
        """Parameters, Adam moments, normaliser statistics (float64 arrays), step counts."""
    def save(self, path: str) -> None: ...
    @property
    def rank(self) -> int: ...
    @property
    def world_size(self) -> int: ...
    @property
    def local_envs(self) -> int: ...
    @property
    def iterations(self) -> int: ...
    @property
    def iterations_done(self) -> int: ...
    @property
    def resumed_from(self) -> str | None: ...
    @property
    def config_toml(self) -> str: ...

class HistoryEncoder:
    """A SkillMimic-V2 history encoder file evaluated by the environment's Rust implementation."""

    @staticmethod
    def load(path: str) -> "HistoryEncoder": ...
    @property
    def length(self) -> int: ...
    @property
    def embed_dim(self) -> int: ...
    def embed(self, windows: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """(B, embed_dim) embeddings of (B, length, 316) windows."""

class RunningMeanStd:
    """The trainer's running mean/std normaliser (rl_games update rule)."""

    def __init__(self, dim: int, eps: float = 1e-5, clip: float = 5.0) -> None: ...
    def update(self, x: npt.NDArray[np.float32]) -> None:
        """Merge a batch (N, dim), N >= 2."""
    def normalize(self, x: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]: ...
    @property
    def mean(self) -> npt.NDArray[np.float64]: ...
    @property
    def var(self) -> npt.NDArray[np.float64]: ...
    @property
    def count(self) -> float: ...

def ppo_loss_and_grads(
    checkpoint: str,
    obs_n: npt.NDArray[np.float32],
    actions: npt.NDArray[np.float32],
    old_neglogp: npt.NDArray[np.float32],
    advantages: npt.NDArray[np.float32],
    returns_n: npt.NDArray[np.float32],
    clip: float = 0.2,
    critic_coef: float = 5.0,
    bounds_coef: float = 10.0,
    bound: float = 1.0,
    backend: str = "fast",
    entropy_coef: float = 0.0,
) -> tuple[dict[str, float], dict[str, npt.NDArray[np.float32]]]:
    """PPO losses and parameter gradients of a checkpoint's policy on one minibatch."""

def init_policy(path: str, family: str, obs_dim: int, actions: tuple[str, int], hidden: list[int], seed: int = 0, overrides: list[str] = ...) -> None:
    """Write a freshly initialised policy checkpoint of ``family`` for ``("box", dim)`` or ``("discrete", n)`` actions;
    ``overrides`` are ``--set``-style assignments applied first (e.g. ``"ppo.modular.controller=[32]"``)."""

def register_generator(name: str, callable: Callable[[str, str], object]) -> None:
    """Register ``callable(failed_clip_path, out_dir)`` as the active-learning clip generator ``name`` of this process."""

def transformer_encoder_layer(
    state_dict: dict[str, npt.NDArray[np.float32]], x: npt.NDArray[np.float32], num_heads: int, key_padding_mask: npt.NDArray[np.bool_] | None = None
) -> npt.NDArray[np.float32]:
    """Flat ``(B*S*E,)`` output of skillmimic_nn's transformer encoder layer with PyTorch-named parameters (cross-checks)."""
