"""Issue 19, the Python package under hostile use: every failure is an ordinary exception.

* a ``VecEnv`` too large for the memory this process may take raises ``ValueError`` naming
  ``env.num_envs`` before MuJoCo's allocation would end the interpreter (checked in a subprocess
  under an address-space limit, so the machine's memory is never touched);
* one ``VecEnv`` stepped from two threads at once gives a ``RuntimeError`` that says so (never a
  crash, never a pyo3 "Already borrowed").
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

from skillmimic_rs import VecEnv


def test_vec_env_too_large_for_memory_raises_in_a_limited_process():
    code = textwrap.dedent(
        """
        import resource, sys
        limit = 6 << 30  # 6 GiB of address space; 100 000 environments need about 87 GB
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        import skillmimic_rs
        try:
            skillmimic_rs.VecEnv(100_000)
        except ValueError as e:
            print("VALUE_ERROR", e)
            sys.exit(0)
        print("NO_ERROR")
        sys.exit(3)
        """
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"rc {r.returncode}\nstdout: {r.stdout}\nstderr: {r.stderr[-2000:]}"
    assert "VALUE_ERROR" in r.stdout and "env.num_envs = 100000" in r.stdout and "at most about" in r.stdout, r.stdout
    # the process lived on after the refusal: the message came from Python, not from MuJoCo's exit
    assert "Could not allocate" not in r.stderr


def test_one_vec_env_from_two_threads_gives_a_clear_error():
    env = VecEnv(64)
    env.reset(seed=0)
    actions = np.zeros((64, env.single_action_space.shape[0]), dtype=np.float32)
    errors: list[BaseException] = []
    start = threading.Barrier(2)

    def worker():
        start.wait()
        for _ in range(150):
            try:
                env.step(actions)
            except BaseException as e:  # noqa: BLE001 - we assert on the exact type below
                errors.append(e)

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors, "two threads stepping one VecEnv 150 times each never overlapped"
    for e in errors:
        assert type(e) is RuntimeError, repr(e)
        assert "in use by another thread" in str(e), str(e)
    # the environment is still usable from one thread afterwards
    env.step(actions)
    env.close()


def test_closed_env_raises_runtime_error():
    env = VecEnv(2)
    env.reset(seed=0)
    env.close()
    with pytest.raises(RuntimeError, match="closed"):
        env.step(np.zeros((2, env.single_action_space.shape[0]), dtype=np.float32))


def test_simulation_instability_is_flagged_per_environment():
    env = VecEnv(3)
    env.reset(seed=0)
    actions = np.zeros((3, env.single_action_space.shape[0]), dtype=np.float32)
    _, _, term, _, info = env.step(actions)
    assert info["unstable"].dtype == np.bool_ and not info["unstable"].any()
    qpos, qvel = env.get_state(1)
    env.set_state(1, qpos, np.full_like(qvel, 1e11))  # beyond MuJoCo's mjMAXVAL (1e10): it resets that physics
    _, _, term, _, info = env.step(actions)
    assert info["unstable"].tolist() == [False, True, False], info["unstable"]
    assert term[1], "an unstable step ends the episode"
    env.close()


def test_non_finite_settings_and_normaliser_arguments_are_value_errors():
    from skillmimic_rs import _core

    with pytest.raises(ValueError, match=r"env\.termination_height.*not a finite number"):
        VecEnv(2, termination_height=float("nan"))
    with pytest.raises(ValueError, match=r"env\.reward\.w_p"):
        VecEnv(2, reward={"w_p": float("inf")})
    with pytest.raises(ValueError, match="eps is -1"):
        _core.RunningMeanStd(3, -1.0, 5.0)
    with pytest.raises(ValueError, match="clip is NaN"):
        _core.RunningMeanStd(3, 1e-5, float("nan"))
    rms = _core.RunningMeanStd(3)
    x = np.ones((4, 3), np.float32)
    x[2, 1] = np.nan
    with pytest.raises(ValueError, match="row 2, column 1"):
        rms.update(x)
    assert np.isfinite(rms.mean).all() and np.isfinite(rms.var).all()
