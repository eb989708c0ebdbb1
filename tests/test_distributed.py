"""Data-parallel training on torch.distributed (gloo), launched as users launch it:

* equivalence: ``torchrun --standalone --nproc-per-node 2`` runs ``tests/dist_equivalence.py``
  (2 ranks x N/2 environments vs 1 process x N, the paper network, from one rollout);
* faults: ``kill -9`` of one rank under torchrun ends the job non-zero within 60 s and
  ``--resume latest`` continues from the last checkpoint with another world size; torchrun's
  restarts (``--max-restarts 3``, SIGKILL of a rank three times, once inside a checkpoint
  write) plus ``--resume latest`` end exactly as the uninterrupted job, and a kill after the final
  checkpoint restarts into the finish only; without torchrun's
  agent (ranks started by hand, as a scheduler may), the surviving rank ends with a clear error.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
TORCHRUN = pathlib.Path(sys.executable).parent / "torchrun"
TINY = ["--preset", "tiny", "--num-envs", "8", "--threads", "1", "--learner-threads", "1", "--no-video"]


def _env() -> dict:
    e = dict(os.environ)
    e.pop("WORLD_SIZE", None)
    e["OMP_NUM_THREADS"] = "1"
    return e


def _torchrun(*args: str) -> list[str]:
    assert TORCHRUN.exists(), f"{TORCHRUN} missing: PyTorch is part of python/requirements-test.txt"
    return [str(TORCHRUN), "--standalone", *args]


def test_two_ranks_take_the_update_of_one_process(tmp_path):
    flags = ["--preset", "tiny", "--num-envs", "16", "--threads", "1", "--learner-threads", "1",
             "--set", "ppo.horizon=16", "--set", "ppo.minibatch=64", "--set", "ppo.mini_epochs=2",
             "--set", "ppo.hidden=[1024, 512, 512]"]
    cmd = _torchrun("--nproc-per-node", "2", str(REPO / "tests" / "dist_equivalence.py"), str(tmp_path), *flags)
    r = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True, timeout=600)
    report_path = tmp_path / "equivalence.json"
    assert report_path.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    rep = json.loads(report_path.read_text())
    print(json.dumps({k: rep[k]["max_relative"] | {"params (norm-wise)": rep[k]["norm_relative"]["params"]} for k in ("as_given", "gradients")} | {"update (norm-wise)": rep["as_given"]["update_norm_relative"]}, indent=1))
    assert rep["ok"] and r.returncode == 0, json.dumps(rep, indent=1)
    assert rep["as_given"]["local_envs"] == 8
    for k in ("as_given", "gradients"):
        assert rep[k]["ranks_identical"]
        assert rep[k]["max_relative"]["obs_var"] <= 1e-5 and rep[k]["max_relative"]["value_var"] <= 1e-5
    assert all(v <= 1e-5 for v in rep["gradients"]["max_relative"].values())
    assert rep["as_given"]["norm_relative"]["params"] <= 1e-5


def _wait_for_checkpoints(d: pathlib.Path, n: int, procs: list[subprocess.Popen], timeout: float = 240.0) -> None:
    t0 = time.time()
    while len(list((d / "checkpoints").glob("iter_*.safetensors"))) < n:
        for p in procs:
            if p.poll() is not None:
                out, err = p.communicate()
                pytest.fail(f"a rank ended early (rc {p.returncode}): {out[-2000:]} {err[-2000:]}")
        assert time.time() - t0 < timeout, "no checkpoints"
        time.sleep(0.2)


def _rank_pid(out: pathlib.Path, rank: int) -> int:
    """PID of the training worker of `rank` for the run writing into `out` (Linux /proc)."""
    for p in pathlib.Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            cmd = (p / "cmdline").read_bytes().split(b"\0")
            env = (p / "environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"skillmimic_rs.train" in cmd and str(out).encode() in cmd and f"RANK={rank}".encode() in env and b"torchrun" not in cmd[1 if len(cmd) > 1 else 0]:
            if any(c.endswith(b"torchrun") for c in cmd[:2]):
                continue
            return int(p.name)
    raise AssertionError(f"no worker of rank {rank} for {out}")


def _alive(out: pathlib.Path) -> list[int]:
    found = []
    for p in pathlib.Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                cmd = (p / "cmdline").read_bytes()
            except OSError:
                continue
            if b"skillmimic_rs.train" in cmd and str(out).encode() in cmd:
                found.append(int(p.name))
    return found


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds the ranks through /proc")
def test_kill_one_rank_then_resume_with_another_world_size(tmp_path):
    out = tmp_path / "run"
    cmd = _torchrun("--nproc-per-node", "2", "--max-restarts", "0", "-m", "skillmimic_rs.train", *TINY,
                    "--iterations", "100000", "--set", "run.save_every=2", "--out", str(out), "--dist-timeout", "30")
    job = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _wait_for_checkpoints(out, 2, [job])
        os.kill(_rank_pid(out, 1), signal.SIGKILL)
        t0 = time.time()
        job.communicate(timeout=90)
        took = time.time() - t0
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    print(f"kill -9 of rank 1: torchrun ended with rc {job.returncode} after {took:.1f} s")
    assert job.returncode != 0 and took <= 60.0
    time.sleep(1.0)
    assert not _alive(out), "a rank outlived the job"
    # resume on one process (another world size) from the newest checkpoint, 2 iterations on
    newest = max(int(p.stem.split("_")[1]) for p in (out / "checkpoints").glob("iter_*.safetensors"))
    target = newest + 2
    r = subprocess.run(_torchrun("--nproc-per-node", "1", "-m", "skillmimic_rs.train", *TINY, "--resume", "latest",
                                 "--out", str(out), "--iterations", str(target)),
                       cwd=REPO, env=_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    m = re.search(r"resumed from .*latest\.safetensors at iteration (\d+)", r.stdout)
    assert m and int(m.group(1)) in (newest, newest - 2), r.stdout[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["iterations"] == target and summary["world_size"] == 1
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert log[-1]["iteration"] == target and log[-1]["world_size"] == 1


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds the ranks through /proc")
def test_motion_prior_trains_under_torchrun_and_resumes(tmp_path):
    """The adversarial motion prior on 2 torchrun ranks: the style reward is in the log, the
    discriminator is in rank 0's checkpoint, and one process resumes it."""
    out = tmp_path / "run"
    amp = ["--set", "ppo.amp.enabled=true", "--set", "ppo.amp.hidden=[32]", "--set", "ppo.amp.batch=32", "--set", "ppo.amp.buffer=256"]
    r = subprocess.run(_torchrun("--nproc-per-node", "2", "-m", "skillmimic_rs.train", *TINY, *amp, "--iterations", "2", "--out", str(out)),
                       cwd=REPO, env=_env(), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    terms = dict(rows[-1]["reward_terms"])
    assert rows[-1]["world_size"] == 2 and terms["style"] > 0.0 and rows[-1]["disc_loss"] > 0.0, rows[-1]
    from safetensors import safe_open

    with safe_open(str(out / "latest.safetensors"), framework="numpy") as f:
        assert "amp.disc.0.weight" in f.keys() and int(f.get_tensor("amp.optim.step")) > 0
    r = subprocess.run([sys.executable, "-m", "skillmimic_rs.train", *TINY, *amp, "--iterations", "3", "--resume", "latest", "--out", str(out)],
                       cwd=REPO, env=_env(), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and "resumed from" in r.stdout, r.stdout[-2000:] + r.stderr[-3000:]


def _rows(out: pathlib.Path) -> list[dict]:
    """The log rows without their timings."""
    rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    return [{k: v for k, v in r.items() if not (k.endswith("_s") or k == "samples_per_s")} for r in rows]


def _tensors(path: pathlib.Path) -> dict:
    from safetensors.numpy import load_file

    return load_file(str(path))


def _rank_pids(out: pathlib.Path, rank: int) -> set[int]:
    """PIDs of every live training worker of `rank` for the run writing into `out`."""
    found = set()
    for pid in _alive(out):
        try:
            cmd = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            env = pathlib.Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if f"RANK={rank}".encode() in env and not any(c.endswith(b"torchrun") for c in cmd[:2]):
            found.add(pid)
    return found


def _new_worker(out: pathlib.Path, rank: int, seen: set[int], job: subprocess.Popen) -> int | None:
    """The worker of `rank` that torchrun started after the ones in `seen` (None: the job ended)."""
    t0 = time.time()
    while job.poll() is None:
        fresh = _rank_pids(out, rank) - seen
        if fresh:
            return min(fresh)
        assert time.time() - t0 < 240, f"torchrun started no new worker of rank {rank}"
        time.sleep(0.05)
    return None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds the ranks through /proc")
def test_torchrun_restarts_resume_exactly_and_finish(tmp_path):
    """A torchrun job killed with SIGKILL three times and restarted by torchrun each time: rank 0
    inside a checkpoint write once 2 to 4 checkpoints exist (the writer's test pause,
    SKILLMIMIC_TEST_WRITE_PAUSE_MS, holds the write open halfway), then at moments drawn from a
    fixed seed rank 1 within 3 s after the restarted job's first log write (rollouts, updates,
    checkpoint writes) and rank 0 within 40 % of the uninterrupted job's wall time after it starts
    (start-up, rendezvous or training). Each restart resumes from the
    newest checkpoint (same world size), and the job ends exactly as the one never interrupted:
    the same log rows but the timings, the same checkpoint tensors."""
    import random

    iters = "16"
    ref = tmp_path / "reference"
    t0 = time.time()
    r = subprocess.run(_torchrun("--nproc-per-node", "2", "-m", "skillmimic_rs.train", *TINY, "--iterations", iters,
                                 "--set", "run.save_every=2", "--out", str(ref)),
                       cwd=REPO, env=_env(), capture_output=True, text=True, timeout=600)
    took = time.time() - t0
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    out = tmp_path / "run"
    cmd = _torchrun("--nproc-per-node", "2", "--max-restarts", "3", "-m", "skillmimic_rs.train", *TINY,
                    "--iterations", iters, "--set", "run.save_every=2", "--resume", "latest", "--out", str(out))
    env = _env() | {"SKILLMIMIC_TEST_WRITE_PAUSE_MS": "300"}
    job = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    rng = random.Random(44)
    kills, seen = [], set()

    def kill(pid: int, what: str) -> None:
        seen.update(_rank_pids(out, 0) | _rank_pids(out, 1))
        try:
            os.kill(pid, signal.SIGKILL)
            kills.append(what)
        except ProcessLookupError:
            pass

    try:
        # 1: rank 0 inside a checkpoint write, once 2 to 4 checkpoints exist (`latest` among them)
        _wait_for_checkpoints(out, rng.randint(2, 4), [job])
        pid = _new_worker(out, 0, seen, job)
        t1 = time.time()
        while not any(out.rglob(f"*.safetensors.tmp{pid}")):
            assert job.poll() is None and time.time() - t1 < 120, "no checkpoint write to kill"
            time.sleep(0.01)
        kill(pid, "rank 0 inside a checkpoint write")
        partial = list(out.rglob(f"*.safetensors.tmp{pid}"))
        assert partial, "the kill missed the write"
        kills[-1] = f"rank 0 inside the write of {partial[0].relative_to(out)}"
        # 2: rank 1 at a random moment of the restarted job's training (after its first log write)
        pid = _new_worker(out, 1, seen, job)
        started = time.time_ns()
        while job.poll() is None and (out / "log.jsonl").stat().st_mtime_ns < started:
            time.sleep(0.02)
        wait = rng.uniform(0.0, 3.0)
        time.sleep(wait)
        if pid is not None:
            kill(pid, f"rank 1 {wait:.1f} s into the restarted job's training")
        # 3: rank 0 at a random moment after it starts (start-up, rendezvous or training)
        pid = _new_worker(out, 0, seen, job)
        if pid is not None:
            wait = rng.uniform(0.2, 0.4 * took)
            time.sleep(wait)
            kill(pid, f"rank 0 {wait:.1f} s after it started")
        stdout, stderr = job.communicate(timeout=300)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    print("killed:", "; ".join(kills), "| resumed at iterations", re.findall(r"resumed from .* at iteration (\d+)", stdout))
    assert len(kills) >= 2, kills
    assert job.returncode == 0, stdout[-2000:] + stderr[-3000:]
    assert re.search(r"resumed from .*latest\.safetensors at iteration [1-9]", stdout), stdout[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["iterations"] == int(iters) and summary["world_size"] == 2
    assert _rows(out) == _rows(ref)
    for name in ["latest.safetensors", *(f"checkpoints/iter_{k:06d}.safetensors" for k in range(2, int(iters) + 1, 2))]:
        want, got = _tensors(ref / name), _tensors(out / name)
        assert "resume.state" in got and sorted(got) == sorted(want), name
        differ = [k for k in want if not (want[k].dtype == got[k].dtype and (want[k] == got[k]).all())]
        assert not differ, f"{name}: tensors differ after the restarts: {differ}"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds the ranks through /proc")
def test_a_rank_killed_after_the_final_checkpoint_restarts_into_the_finish(tmp_path):
    """Rank 0 killed after it wrote the final checkpoint, during its end-of-run evaluation: torchrun
    restarts the job, `--resume latest` finds the run at `run.iterations` and only finishes it
    (evaluation, summary), exit 0; nothing is trained again and the checkpoint and log stay."""
    iters = 4
    out = tmp_path / "run"
    cmd = _torchrun("--nproc-per-node", "2", "--max-restarts", "1", "-m", "skillmimic_rs.train", *TINY,
                    "--iterations", str(iters), "--set", "run.save_every=2", "--set", "run.eval_episodes=256",
                    "--resume", "latest", "--out", str(out))
    job = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    final, latest = out / "checkpoints" / f"iter_{iters:06d}.safetensors", out / "latest.safetensors"
    try:
        pid = _new_worker(out, 0, set(), job)
        t0 = time.time()
        # the final checkpoint and then `latest` (written after it) are complete
        while not (final.exists() and latest.exists() and not list(out.glob("latest.safetensors.tmp*"))
                   and latest.stat().st_mtime_ns >= final.stat().st_mtime_ns):
            assert job.poll() is None and time.time() - t0 < 300, "the job ended before its final checkpoint"
            time.sleep(0.005)
        saved, log = latest.read_bytes(), (out / "log.jsonl").read_text()
        assert job.poll() is None and not (out / "summary.json").exists(), "the job finished before the kill"
        os.kill(pid, signal.SIGKILL)
        stdout, stderr = job.communicate(timeout=300)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 0, stdout[-2000:] + stderr[-3000:]
    assert re.search(rf"resumed from .*latest\.safetensors at iteration {iters}", stdout), stdout[-2000:]
    assert f"already complete at iteration {iters}" in stdout, stdout[-2000:]
    assert latest.read_bytes() == saved and (out / "log.jsonl").read_text() == log
    assert [r["iteration"] for r in _rows(out)] == list(range(1, iters + 1))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["iterations"] == iters and summary["world_size"] == 2 and summary["samples_per_s"] == 0.0
    assert (out / "metrics.json").exists()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_by_hand(out: pathlib.Path, timeout_s: int) -> list[subprocess.Popen]:
    """Two ranks started without torchrun (the variables a scheduler would set)."""
    port = str(_free_port())
    procs = []
    for rank in range(2):
        env = _env() | {"RANK": str(rank), "LOCAL_RANK": str(rank), "WORLD_SIZE": "2", "LOCAL_WORLD_SIZE": "2",
                        "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": port}
        procs.append(subprocess.Popen([sys.executable, "-m", "skillmimic_rs.train", *TINY, "--iterations", "100000",
                                       "--set", "run.save_every=2", "--out", str(out), "--dist-timeout", str(timeout_s)],
                                      cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
    return procs


def _rank0_after(tmp_path, timeout_s: int, hurt_rank1) -> tuple[int, float, str]:
    """Start 2 ranks by hand, wait for a checkpoint, do `hurt_rank1(process)`, and return rank 0's
    exit code, the seconds it took to end, and its stderr."""
    out = tmp_path / "run"
    procs = _start_by_hand(out, timeout_s)
    try:
        _wait_for_checkpoints(out, 1, procs)
        hurt_rank1(procs[1])
        t0 = time.time()
        _, err = procs[0].communicate(timeout=120)
        took = time.time() - t0
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    print(f"rank 0 ended after {took:.1f} s: {err.strip().splitlines()[-1]}")
    return procs[0].returncode, took, err


def test_without_the_agent_the_surviving_rank_fails_clearly(tmp_path):
    rc, took, err = _rank0_after(tmp_path, 30, lambda p: p.kill())
    assert rc == 1 and took <= 60.0
    assert "error (rank 0): distributed:" in err, err[-2000:]


def test_a_stopped_rank_makes_the_other_time_out(tmp_path):
    """A rank that stops answering without closing its connections (SIGSTOP: a hung process
    or a frozen machine): the other fails after --dist-timeout, not never."""
    rc, took, err = _rank0_after(tmp_path, 10, lambda p: p.send_signal(signal.SIGSTOP))
    assert rc == 1 and took <= 40.0
    assert "error (rank 0): distributed:" in err and "Timed out" in err, err[-2000:]


@pytest.mark.parametrize("signum,ignored", [(signal.SIGINT, True), (signal.SIGTERM, False)], ids=["sigint-ignored-at-start", "sigterm"])
def test_a_signal_stops_the_python_trainer_with_a_checkpoint(tmp_path, signum, ignored):
    """SIGINT (Ctrl-C, `kill -INT`) and SIGTERM (torchrun's agent, a scheduler, `kill`) stop
    `python -m skillmimic_rs.train` after the current iteration with a checkpoint and exit
    128 + the signal's number. SIGINT is sent to a child started with it ignored, as a background
    job of a non-interactive shell starts: the trainer handles it all the same."""
    out = tmp_path / "run"
    # on a hang, faulthandler prints every thread's stack when the test aborts the child
    env = dict(_env(), PYTHONFAULTHANDLER="1")
    p = subprocess.Popen([sys.executable, "-m", "skillmimic_rs.train", *TINY, "--iterations", "100000", "--set", "run.save_every=1000",
                          "--out", str(out)], cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN if ignored else signal.SIG_DFL))
    try:
        t0 = time.time()
        while not (out / "log.jsonl").exists() or len((out / "log.jsonl").read_text().splitlines()) < 3:
            assert p.poll() is None and time.time() - t0 < 120, "the trainer did not start"
            time.sleep(0.2)
        p.send_signal(signum)
        try:
            _, err = p.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGABRT)
            _, err = p.communicate(timeout=30)
            raise AssertionError(f"no exit within 120 s of signal {signum}; the trainer's stacks:\n{err[-6000:]}") from None
    finally:
        if p.poll() is None:
            p.kill()
    m = re.search(r"interrupted at iteration (\d+); checkpoint saved", err)
    assert p.returncode == 128 + signum and m, (p.returncode, err[-2000:])
    assert (out / "checkpoints" / f"iter_{int(m.group(1)):06d}.safetensors").exists()
    assert (out / "latest.safetensors").exists() and not (out / "summary.json").exists()
