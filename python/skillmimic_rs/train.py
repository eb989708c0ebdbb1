"""``python -m skillmimic_rs.train``: PPO training with the arguments of ``skillmimic train``,
in one process or data-parallel under ``torchrun``.

One process::

    python -m skillmimic_rs.train --preset small --out runs/a

Two ranks on this machine, one core each (``env.num_envs`` is the total of all ranks)::

    torchrun --standalone --nproc-per-node 2 -m skillmimic_rs.train --preset small --out runs/a

Every rank steps its share of the environments and computes gradients on its members of each
minibatch; gradients, normaliser moments and advantage statistics are all-reduced, so every
rank takes the update one process would take (``crates/skillmimic-learn/src/collective``).
Rank 0 writes the logs, checkpoints, evaluation and ``summary.json``. Under torchrun, the
thread counts default to the cores of the machine divided by the ranks on it.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _has_flag(argv: list[str], name: str) -> bool:
    return any(a == name or a.startswith(name + "=") for a in argv)


def _describe(s: dict) -> str:
    return (
        f"iteration {s['iteration']}: {s['samples_per_s']:.0f} samples/s  reward/step {s['mean_reward']:.4f}  "
        f"ep.len {s['episode_length']:.1f}  falls {100 * s['early_terminations']:.0f}%  "
        f"all-reduce {s['allreduce_s']:.2f} s"
    )


def _stop_on_signals() -> list[int]:
    """SIGINT and SIGTERM stop training after the current iteration with a checkpoint, as they
    stop ``skillmimic train``: the handler raises KeyboardInterrupt, which the trainer takes at
    its next check between iterations. SIGTERM is what torchrun's agent, a batch scheduler or
    ``kill`` sends; SIGINT is handled even where the process started with it ignored (a
    background job of a non-interactive shell). A second signal ends the process at once (the
    handlers go back to the defaults). Returns the list that receives the signal's number."""
    caught: list[int] = []

    def on_signal(signum: int, _frame) -> None:
        caught.append(signum)
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_DFL)
        raise KeyboardInterrupt

    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, on_signal)
    return caught


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(
        prog="python -m skillmimic_rs.train",
        add_help=False,
        description="Data-parallel options (the other arguments are those of `skillmimic train`).",
    )
    p.add_argument("--dist-backend", default="gloo", help="torch.distributed backend: gloo (CPU, default) or nccl")
    p.add_argument("--dist-timeout", type=float, default=300.0, help="seconds a collective operation may wait for the other ranks")
    p.add_argument("--log-every", type=int, default=0, help="print every this many iterations (0: about 20 lines per run)")
    p.add_argument("-h", "--help", action="store_true")
    ours, rest = p.parse_known_args(argv)

    from . import _core
    from . import distributed

    if ours.help:
        print(p.format_help())
        print(_core.Trainer.usage())
        return 0
    world = distributed.launched_world_size()
    local_world = int(os.environ.get("LOCAL_WORLD_SIZE", "1"))
    if world > 1:
        per_rank = str(max(1, _cores() // max(local_world, 1)))
        if not _has_flag(rest, "--threads"):
            rest += ["--threads", per_rank]
        if not _has_flag(rest, "--learner-threads"):
            rest += ["--learner-threads", per_rank]
    try:
        comm = distributed.init_from_environment(ours.dist_backend, ours.dist_timeout)
    except (RuntimeError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    rank = comm.rank if comm is not None else 0
    try:
        try:
            trainer = _core.Trainer(rest, comm)
        except ValueError as e:
            msg = str(e).strip()
            msg = msg if msg.startswith("error:") else f"error: {msg}"
            print(msg.replace("error:", f"error (rank {rank}):", 1) if world > 1 else msg, file=sys.stderr)
            return 2 if "Usage" in msg else 1
        if rank == 0:
            what = f"{world} ranks x {trainer.local_envs} environments" if world > 1 else f"{trainer.local_envs} environments"
            resumed = f", resumed from {trainer.resumed_from} at iteration {trainer.iterations_done}" if trainer.resumed_from else ""
            print(f"training on {what}{resumed}", flush=True)
        # re-entered after its last checkpoint (a restart under torchrun): only the finish is left
        complete = trainer.resumed_from is not None and trainer.iterations_done >= trainer.iterations
        every = ours.log_every or max(1, trainer.iterations // 20)
        last = trainer.iterations
        first = None
        start = time.time()

        def on_iteration(js: str) -> None:
            nonlocal first
            if rank != 0:
                return
            s = json.loads(js)
            first = s["iteration"] if first is None else first
            if s["iteration"] in (first, last) or s["iteration"] % every == 0:
                print(_describe(s), flush=True)

        caught = _stop_on_signals() if __name__ == "__main__" else []
        try:
            summary = trainer.run(on_iteration)
        except RuntimeError as e:
            print(f"error (rank {rank}): {e}" if world > 1 else f"error: {e}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print(f"interrupted at iteration {trainer.iterations_done}; checkpoint saved, continue with --resume latest", file=sys.stderr)
            # the shell's convention for a process ended by a signal: 128 + its number
            return 128 + (caught[0] if caught else signal.SIGINT)
        if summary is not None:
            s = json.loads(summary)
            out = os.path.dirname(s["metrics"])
            if complete:
                print(f"the run was already complete at iteration {s['iterations']} ({s['samples']} samples): evaluated it and "
                      f"wrote its summary; mean reward/step {s['early_mean_reward']:.4f} -> {s['late_mean_reward']:.4f}")
            else:
                print(
                    f"trained {s['iterations']} iterations ({s['samples']} samples) on {s['world_size']} rank(s) in "
                    f"{time.time() - start:.1f} s; {s['samples_per_s']:.0f} samples/s; mean all-reduce "
                    f"{s['mean_allreduce_s']:.3f} s per iteration; mean reward/step {s['early_mean_reward']:.4f} -> {s['late_mean_reward']:.4f}"
                )
            print(f"checkpoint {s['checkpoint']}")
            print(f"summary    {os.path.join(out, 'summary.json')}")
        return 0
    finally:
        distributed.shutdown()


if __name__ == "__main__":
    sys.exit(main())
