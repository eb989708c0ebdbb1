"""``python -m skillmimic_rs.bench_dist``: data-parallel throughput measured in one run.

Trains the same configuration (default: preset ``small``, the paper's network and PPO settings,
256 environments in total) twice on this machine — 1 process with ``--threads T`` vs
``torchrun --nproc-per-node T`` with one thread per rank — and prints samples/s of each (median
over the iterations after the first), their ratio, and rank 0's time in collective operations per
update. Then it times a bare all-reduce of the network's gradient size (actor + critic, float32)
between the ranks, the number a projection to more machines starts from.

Usage: python -m skillmimic_rs.bench_dist [--ranks 2] [--iterations 6] [train flags...]
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time


def _run(cmd: list[str], env: dict) -> None:
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"benchmark run failed ({' '.join(cmd)}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")


def _stats(out: pathlib.Path) -> dict:
    log = [json.loads(x) for x in (out / "log.jsonl").read_text().splitlines()]
    steady = log[1:] or log
    return {
        "samples_per_s": statistics.median(s["samples_per_s"] for s in steady),
        "allreduce_s": statistics.median(s["allreduce_s"] for s in steady),
        "update_s": statistics.median(s["update_s"] for s in steady),
        "rollout_s": statistics.median(s["rollout_s"] for s in steady),
        "samples_per_iteration": log[0]["samples"],
    }


def _allreduce_probe(floats: int, repeats: int) -> None:
    """Under torchrun: time `repeats` all-reduces of `floats` float32 values; rank 0 prints JSON."""
    import torch
    import torch.distributed as dist

    dist.init_process_group("gloo")
    x = torch.ones(floats, dtype=torch.float32)
    for _ in range(3):
        dist.all_reduce(x)
    dist.barrier()
    t0 = time.perf_counter()
    for _ in range(repeats):
        dist.all_reduce(x)
    dt = (time.perf_counter() - t0) / repeats
    if dist.get_rank() == 0:
        print(json.dumps({"floats": floats, "seconds": dt}))
    dist.destroy_process_group()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m skillmimic_rs.bench_dist", description=__doc__.split("\n\n")[0])
    p.add_argument("--ranks", type=int, default=2, help="ranks (and threads of the 1-process run)")
    p.add_argument("--iterations", type=int, default=6)
    p.add_argument("--allreduce-probe", type=int, default=0, help=argparse.SUPPRESS)
    ours, flags = p.parse_known_args(argv)
    if ours.allreduce_probe:
        _allreduce_probe(ours.allreduce_probe, 20)
        return 0
    if not any(f == "--preset" or f.startswith("--preset=") for f in flags):
        flags = ["--preset", "small", *flags]
    flags += ["--iterations", str(ours.iterations), "--no-video", "--set", "run.eval_episodes=1"]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    env.pop("WORLD_SIZE", None)
    torchrun = str(pathlib.Path(sys.executable).parent / "torchrun")
    k = str(ours.ranks)
    with tempfile.TemporaryDirectory(prefix="skillmimic-bench-dist-") as tmp:
        one, dp = pathlib.Path(tmp, "one"), pathlib.Path(tmp, "dp")
        _run([sys.executable, "-m", "skillmimic_rs.train", *flags, "--threads", k, "--learner-threads", k, "--out", str(one)], env)
        _run([torchrun, "--standalone", "--nproc-per-node", k, "-m", "skillmimic_rs.train", *flags,
              "--threads", "1", "--learner-threads", "1", "--out", str(dp)], env)
        a, b = _stats(one), _stats(dp)
        import safetensors.numpy as stn  # the network size, from the run's checkpoint

        ckpt = stn.load_file(str(dp / "latest.safetensors"))
        grads = sum(v.size for n, v in ckpt.items() if n.startswith(("actor.", "critic.")) and "running" not in n)
        r = subprocess.run([torchrun, "--standalone", "--nproc-per-node", k, "-m", "skillmimic_rs.bench_dist", "--allreduce-probe", str(grads)],
                           env=env, capture_output=True, text=True)
        probe = json.loads(r.stdout.strip().splitlines()[-1]) if r.returncode == 0 else None
    print(f"configuration: {' '.join(flags)}; {a['samples_per_iteration']} samples per iteration")
    print(f"1 process x {k} threads : {a['samples_per_s']:8.0f} samples/s (rollout {a['rollout_s']:.2f} s, update {a['update_s']:.2f} s per iteration)")
    print(f"{k} ranks x 1 thread     : {b['samples_per_s']:8.0f} samples/s (rollout {b['rollout_s']:.2f} s, update {b['update_s']:.2f} s, "
          f"collectives {b['allreduce_s']:.3f} s per iteration, waiting for the slower rank included)")
    print(f"ratio (ranks / process) : {b['samples_per_s'] / a['samples_per_s']:.3f}")
    print(f"per core                : {b['samples_per_s'] / ours.ranks:.0f} samples/s")
    if probe:
        print(f"bare all-reduce of {grads} float32 ({4 * grads / 1e6:.1f} MB, the gradients) between {k} ranks: {1e3 * probe['seconds']:.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
