"""ModSkill active skill learning with a Python generator (``skillmimic_rs.register_generator``):
clips round-trip through ``skillmimic_rs.motion.read_clip``/``write_clip`` (the Rust loader reads
them back), and in a training run a clip the policy fails on (a demo clip lifted 1 m) is handed to
the Python callable; its valid clip joins the library, its invalid one (sunk 1.5 m into the
floor) is rejected with the filter's reason, and the failed clip's sampling weight grows."""

from __future__ import annotations

import json
import pathlib

import numpy as np

import skillmimic_rs
from skillmimic_rs import _core
from skillmimic_rs.motion import read_clip, write_clip

REPO = pathlib.Path(__file__).resolve().parent.parent


def test_clips_round_trip_through_python(tmp_path):
    src = sorted((REPO / "motions").glob("*.safetensors"))[0]
    clip = read_clip(src)
    assert clip["dof_rot"].shape == (len(clip["root_pos"]), 52, 3) and clip["skill"] >= 0
    write_clip(tmp_path / "copy.safetensors", clip)
    back = read_clip(tmp_path / "copy.safetensors")
    for k in ("root_pos", "root_rot", "dof_rot", "body_pos", "ball_pos", "ball_rot", "contact"):
        assert np.array_equal(back[k], clip[k]), k
    assert (back["name"], back["skill"], back["fps"]) == (clip["name"], clip["skill"], clip["fps"])
    # the Rust loader accepts it: an environment over the written clip
    env = skillmimic_rs.VecEnv(1, motion=[str(tmp_path / "copy.safetensors")], threads=1)
    assert env.clips == [(clip["name"], clip["skill"], len(clip["root_pos"]))]
    env.close()


def test_a_python_generator_feeds_active_learning(tmp_path):
    clips = tmp_path / "clips"
    clips.mkdir()
    demo = sorted((REPO / "motions").glob("*.safetensors"))
    for f in demo:
        write_clip(clips / f.name, read_clip(f))
    lifted = read_clip(demo[0])
    lifted["name"] = "052_lifted"
    lifted["root_pos"][:, 2] += 1.0
    lifted["body_pos"][:, :, 2] += 1.0
    write_clip(clips / "052_lifted.safetensors", lifted)

    calls: list[str] = []

    def probe(failed: str, out_dir: str) -> None:
        c = read_clip(failed)
        calls.append(c["name"])
        ok = dict(c, name=f"{c['name']}~py_ok")
        ok["root_pos"] = c["root_pos"].copy()
        ok["root_pos"][:, 0] += 0.5
        ok["body_pos"] = c["body_pos"].copy()
        ok["body_pos"][:, :, 0] += 0.5
        write_clip(pathlib.Path(out_dir) / "ok.safetensors", ok)
        sunk = dict(c, name=f"{c['name']}~py_sunk")
        sunk["body_pos"] = c["body_pos"] - np.array([0.0, 0.0, 1.5], np.float32)
        write_clip(pathlib.Path(out_dir) / "sunk.safetensors", sunk)

    skillmimic_rs.register_generator("pytest_probe", probe)
    out = tmp_path / "run"
    argv = [
        "--preset", "tiny", "--task", "tracking", "--motion", str(clips), "--out", str(out),
        "--set", "env.num_envs=8", "--set", "env.threads=1", "--set", "run.iterations=2", "--set", "run.eval_episodes=1",
        "--set", "ppo.hidden=[32]", "--set", "run.active.enabled=true", "--set", "run.active.every=1",
        "--set", "run.active.generator=pytest_probe", "--set", "run.active.failure_weight=2.0",
    ]
    _core.Trainer(argv).run()
    rounds = [json.loads(line) for line in (out / "active.jsonl").read_text().splitlines()]
    assert len(rounds) == 1
    r = rounds[0]["report"]
    assert "052_lifted" in r["failed"] and "052_lifted" in calls and sorted(calls) == sorted(r["failed"])
    accepted = {name for name, _ in r["accepted"]}
    rejected = dict((name, why) for name, why in r["rejected"])
    assert "052_lifted~py_ok" in accepted and pathlib.Path(dict(r["accepted"])["052_lifted~py_ok"]).exists()
    assert "below the floor" in rejected["052_lifted~py_sunk"], rejected
    assert r["clip_weights"]["052_lifted"] > 1.0


def test_an_unregistered_generator_is_a_clear_error(tmp_path):
    argv = ["--preset", "tiny", "--task", "tracking", "--out", str(tmp_path / "r"), "--set", "run.active.enabled=true", "--set", "run.active.generator=nope"]
    try:
        _core.Trainer(argv)
    except ValueError as e:
        assert "run.active.generator" in str(e) and "register_generator" in str(e), e
    else:
        raise AssertionError("an unknown generator must be refused")


def test_a_raising_generator_fails_the_round_with_its_message(tmp_path):
    clips = tmp_path / "clips"
    clips.mkdir()
    lifted = read_clip(sorted((REPO / "motions").glob("*.safetensors"))[0])
    lifted["name"] = "lifted"
    lifted["root_pos"][:, 2] += 1.0
    lifted["body_pos"][:, :, 2] += 1.0
    write_clip(clips / "lifted.safetensors", lifted)

    def broken(failed: str, out_dir: str) -> None:
        raise RuntimeError("model weights missing")

    skillmimic_rs.register_generator("pytest_broken", broken)
    argv = [
        "--preset", "tiny", "--task", "tracking", "--motion", str(clips), "--out", str(tmp_path / "r"),
        "--set", "env.num_envs=8", "--set", "env.threads=1", "--set", "run.iterations=2", "--set", "ppo.hidden=[32]",
        "--set", "run.active.enabled=true", "--set", "run.active.every=1", "--set", "run.active.generator=pytest_broken",
    ]
    try:
        _core.Trainer(argv).run()
    except Exception as e:  # noqa: BLE001
        assert "model weights missing" in str(e), e
    else:
        raise AssertionError("the generator's exception must stop training")
