"""Run under ``torchrun --standalone --nproc-per-node 2``: from one rollout, the data-parallel
update (2 ranks x N/2 environments, gradients and normaliser moments all-reduced over
torch.distributed/gloo) equals the update of 1 process x N environments.

Every rank builds a one-process trainer over all N environments (same seed, hence the same
rollout on every rank), collects a rollout and runs the update (all mini-epochs and
minibatches); then the rank's data-parallel trainer takes its environments of that rollout and
runs the update. Two passes:

* ``as_given``: the given settings. Summation order differs between 1 and 2 ranks (each rank
  sums its members of a minibatch, then the sums are added), so gradients differ at float32
  rounding level; Adam's step m/(sqrt(v)+eps), and the later minibatches' gradients taken at
  the stepped parameters, amplify that in single components (measured with the paper network:
  up to 2e-5 of the largest parameter after 8 steps, 3e-8 norm-wise). Checked: the norm-wise
  relative difference ||a - b|| / ||a|| <= 1e-5 of the parameters, and max |a - b| / max |a|
  <= 1e-5 of the normaliser statistics.
* ``gradients``: the same with lr = 1e-12, so every minibatch's gradient is taken at the same
  parameters in both runs and Adam's moments m and v are sums of those gradients (and their
  squares): max |a - b| / max |a| <= 1e-5 for every state array. Any real difference in the
  data-parallel update (a lost or duplicated sample, a wrong weight, a missed reduction) shows
  here.

Rank 0 writes ``OUT/equivalence.json``; exit 1 when a check fails or the ranks disagree.

Usage: torchrun --standalone --nproc-per-node 2 tests/dist_equivalence.py OUT [train flags...]
"""

from __future__ import annotations

import json
import pathlib
import sys

import numpy as np

TOLERANCE = 1e-5
NORMALISERS = ("obs_mean", "obs_var", "obs_count", "value_mean", "value_var", "value_count")


def _arr(x) -> np.ndarray:
    return np.atleast_1d(np.asarray(x, dtype=np.float64))


def compare(core, comm, out: pathlib.Path, flags: list[str]) -> dict:
    one = core.Trainer(flags + ["--out", str(out / f"one-{comm.rank}")])
    before = one.state()
    one.update_from_rollout(one.collect_rollout())
    want = one.state()
    dp = core.Trainer(flags + ["--out", str(out / "dp")], comm)
    start = dp.state()
    for k in before:
        assert np.array_equal(_arr(start[k]), _arr(before[k])), f"{k}: every rank starts from the one-process state"
    dp.load_rollout_part(one)
    dp.update_from_rollout(None)
    got = dp.state()
    rep = {"local_envs": dp.local_envs, "max_relative": {}, "norm_relative": {}}
    for k in want:
        a, b = _arr(want[k]), _arr(got[k])
        rep["max_relative"][k] = float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(a))), 1e-30))
        rep["norm_relative"][k] = float(np.linalg.norm(a - b) / max(float(np.linalg.norm(a)), 1e-30))
    step_one, step_dp = _arr(want["params"]) - _arr(before["params"]), _arr(got["params"]) - _arr(before["params"])
    rep["update_max_abs"] = float(np.max(np.abs(step_one)))
    rep["update_norm_relative"] = float(np.linalg.norm(step_one - step_dp) / max(float(np.linalg.norm(step_one)), 1e-30))
    # every rank holds the same parameters as rank 0
    mine = _arr(got["params"])
    r0 = mine.copy()
    comm.broadcast(r0)
    same = np.array([float(np.array_equal(mine, r0))])
    comm.all_reduce(same)
    rep["ranks_identical"] = bool(same[0] == comm.world_size)
    return rep


def main() -> int:
    out = pathlib.Path(sys.argv[1])
    flags = sys.argv[2:]
    from skillmimic_rs import _core, distributed

    comm = distributed.init_from_environment("gloo", 120.0)
    assert comm is not None and comm.world_size >= 2, "run me under torchrun with 2 or more ranks"
    try:
        paper = compare(_core, comm, out / "as_given", flags)
        grads = compare(_core, comm, out / "gradients", flags + ["--set", "ppo.lr=1e-12"])
        ok = paper["ranks_identical"] and grads["ranks_identical"] and paper["update_max_abs"] > 0
        ok &= paper["norm_relative"]["params"] <= TOLERANCE
        ok &= all(paper["max_relative"][k] <= TOLERANCE for k in NORMALISERS)
        ok &= all(v <= TOLERANCE for v in grads["max_relative"].values())
        report = {"world_size": comm.world_size, "tolerance": TOLERANCE, "as_given": paper, "gradients": grads, "ok": bool(ok)}
        if comm.rank == 0:
            out.mkdir(parents=True, exist_ok=True)
            (out / "equivalence.json").write_text(json.dumps(report, indent=2))
            print(json.dumps(report, indent=2))
        return 0 if ok else 1
    finally:
        distributed.shutdown()


if __name__ == "__main__":
    sys.exit(main())
