"""Data-parallel training on ``torch.distributed``: the collective operations of the Rust learner.

``torchrun`` (or SLURM's ``srun`` with the same variables) starts one process per rank with
``RANK``, ``WORLD_SIZE``, ``LOCAL_RANK``, ``LOCAL_WORLD_SIZE``, ``MASTER_ADDR`` and ``MASTER_PORT``
set. :func:`init_from_environment` joins the process group (gloo on CPU: the learner's tensors
live in host memory) and returns a :class:`TorchCollective`, which the Rust trainer calls for
every reduction: it all-reduces gradients, normaliser moments and advantage statistics, and
receives rank 0's parameters at start (see ``crates/skillmimic-learn/src/collective``).

PyTorch is needed only here (``pip install torch``); one-process training does not import it.
"""

from __future__ import annotations

import datetime
import os

import numpy as np


class TorchCollective:
    """In-place ``all_reduce`` (sum) and ``broadcast`` (from rank 0) of float32/float64 numpy
    arrays over the default ``torch.distributed`` process group.

    With the ``nccl`` backend the buffer is copied to ``cuda:LOCAL_RANK`` for the operation and
    back (the learner itself computes on the CPU); with ``gloo`` the numpy memory is used as is.
    """

    def __init__(self, device: str | None = None):
        import torch.distributed as dist

        self._dist = dist
        self.rank = dist.get_rank()
        self.world_size = dist.get_world_size()
        self.device = device

    def _run(self, arr: np.ndarray, op) -> None:
        import torch

        t = torch.from_numpy(arr)
        if self.device is None:
            op(t)
        else:
            g = t.to(self.device)
            op(g)
            t.copy_(g.cpu())

    def all_reduce(self, arr: np.ndarray) -> None:
        self._run(arr, lambda t: self._dist.all_reduce(t, op=self._dist.ReduceOp.SUM))

    def broadcast(self, arr: np.ndarray) -> None:
        self._run(arr, lambda t: self._dist.broadcast(t, src=0))


def launched_world_size() -> int:
    """``WORLD_SIZE`` of the launcher (1 when the process was not started by torchrun/srun)."""
    return int(os.environ.get("WORLD_SIZE", "1"))


def init_from_environment(backend: str = "gloo", timeout_s: float = 300.0) -> TorchCollective | None:
    """Join the process group described by the launcher's environment variables; None for a
    single process. ``timeout_s`` bounds every collective operation: a rank that stops
    answering (hung, or its machine gone without closing its connections) makes the others
    fail after at most this long; a rank that dies closes its connections and the others fail
    at their next operation."""
    if launched_world_size() <= 1:
        return None
    try:
        import torch
        import torch.distributed as dist
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise RuntimeError("data-parallel training needs PyTorch: pip install torch") from e
    if backend not in ("gloo", "nccl"):
        raise ValueError(f"--dist-backend: '{backend}', expected gloo or nccl")
    device = None
    if backend == "nccl":
        if not torch.cuda.is_available():
            raise RuntimeError("--dist-backend nccl needs CUDA GPUs; use gloo on CPU machines")
        device = f"cuda:{int(os.environ.get('LOCAL_RANK', '0'))}"
        torch.cuda.set_device(device)
    if not dist.is_initialized():
        timeout = datetime.timedelta(seconds=timeout_s)
        rank, world = int(os.environ["RANK"]), launched_world_size()
        # torchrun keeps one key-value store across restarts of the workers: without a per-attempt
        # prefix, a restarted rank can read the address its dead predecessor published and fail
        # to connect (measured: "Gloo connectFullMesh failed … Connection refused" after a kill -9)
        agent = os.environ.get("TORCHELASTIC_USE_AGENT_STORE") == "True"
        store = dist.TCPStore(
            os.environ["MASTER_ADDR"], int(os.environ["MASTER_PORT"]), world,
            is_master=(not agent and rank == 0), timeout=timeout, multi_tenant=not agent,
        )
        attempt = os.environ.get("TORCHELASTIC_RESTART_COUNT", "0")
        store = dist.PrefixStore(f"skillmimic_rs/attempt_{attempt}/", store)
        dist.init_process_group(backend=backend, store=store, rank=rank, world_size=world, timeout=timeout)
    return TorchCollective(device)


def shutdown() -> None:
    """Leave the process group (if joined)."""
    try:
        import torch.distributed as dist
    except ImportError:  # pragma: no cover
        return
    if dist.is_initialized():
        dist.destroy_process_group()
