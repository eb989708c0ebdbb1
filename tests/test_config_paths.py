"""Relative paths in a config file mean the same to Python (``load_config`` / ``VecEnv``) and to the
CLI (``--config``): both read the file through the Rust core's ``config_file`` rule."""

from __future__ import annotations

import json
import pathlib
import shutil
import subprocess

import skillmimic_rs
from skillmimic_rs import BUILTIN_DEMO, _core


def _layout(root: pathlib.Path) -> pathlib.Path:
    """``exp/sub`` (relative to ``root``, the working directory) with a clip folder and an
    encoder file next to the config, and a folder that exists only in the working directory."""
    sub = pathlib.Path("exp") / "sub"
    (root / sub / "clips").mkdir(parents=True)
    (root / sub / "enc.safetensors").write_bytes(b"")
    (root / "only_cwd").mkdir()
    return sub


def test_relative_paths_in_a_subfolder_python_equals_rust(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sub = _layout(tmp_path)
    cfg = sub / "cfg.toml"
    cfg.write_text(
        '[env]\nmotion = ["clips", "only_cwd", "missing", "builtin:demo", "/abs/clip.pt"]\nnum_envs = 3\n'
        '[env.v2.history]\nencoder = "enc.safetensors"\n[ppo]\nlr = 1e-4\n'
    )
    py = skillmimic_rs.load_config(cfg)
    rust = json.loads(_core.load_train_config(str(cfg), "tiny"))["env"]
    expected = [str(sub / "clips"), "only_cwd", str(sub / "missing"), BUILTIN_DEMO, "/abs/clip.pt"]
    assert py["motion"] == rust["motion"] == expected
    assert py["v2"]["history"]["encoder"] == rust["v2"]["history"]["encoder"] == str(sub / "enc.safetensors")
    assert py["num_envs"] == rust["num_envs"] == 3
    # every entry is the core's rule applied to what the file says
    written = ["clips", "only_cwd", "missing", BUILTIN_DEMO, "/abs/clip.pt"]
    assert [_core.resolve_config_path(w, str(sub)) for w in written] == expected


def test_file_forms(tmp_path):
    top = tmp_path / "top.toml"
    top.write_text('episode_length = 12\nmotion = ["clips"]\n')
    assert skillmimic_rs.load_config(top) == {"episode_length": 12, "motion": [str(tmp_path / "clips")]}
    ppo_only = tmp_path / "ppo.toml"
    ppo_only.write_text("[ppo]\nlr = 1e-4\n")
    assert skillmimic_rs.load_config(ppo_only) == {}
    bad = tmp_path / "bad.toml"
    bad.write_text("[env\n")
    try:
        skillmimic_rs.load_config(bad)
    except ValueError as e:
        assert "bad.toml" in str(e)
    else:
        raise AssertionError("a TOML syntax error must raise ValueError")


def test_vec_env_runs_on_clips_next_to_its_config(tmp_path, repo_root):
    sub = tmp_path / "exp"
    shutil.copytree(repo_root / "motions", sub / "clips")
    cfg = sub / "cfg.toml"
    cfg.write_text('[env]\nmotion = ["clips"]\nepisode_length = 6\n')
    e = skillmimic_rs.VecEnv(num_envs=2, config=cfg)
    assert e.config["motion"] == [str(sub / "clips")] and len(e.clips) > 0
    e.close()


def test_cli_resolves_like_python(tmp_path, skillmimic_bin, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sub = _layout(tmp_path)
    cfg = sub / "cli.toml"
    cfg.write_text('[env]\nmotion = ["nowhere"]\n')
    (want,) = skillmimic_rs.load_config(cfg)["motion"]
    assert want == str(sub / "nowhere")
    r = subprocess.run(
        [str(skillmimic_bin), "train", "--preset", "tiny", "--config", str(cfg), "--iterations", "1", "--out", "out"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert r.returncode != 0 and f"{want}: no such clip file or folder" in r.stderr, r.stderr
