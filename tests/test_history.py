"""SkillMimic-V2 history encoder across languages: an encoder pre-trained by the Rust CLI loads
into the documented PyTorch module (strict state_dict) and gives the same embeddings as the Rust
implementation, which is the one that fills the environment's observation."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from conftest import run_cli
from skillmimic_rs import VecEnv, _core
from skillmimic_rs.history import HistoryEncoder, load_history_encoder


@pytest.fixture(scope="module")
def encoder_file(tmp_path_factory, skillmimic_bin):
    path = tmp_path_factory.mktemp("history") / "encoder.safetensors"
    r = run_cli(skillmimic_bin, "history", "pretrain", "--motion", "builtin:demo", "--out", str(path), "--epochs", "3")
    assert "next-state MSE" in r.stdout
    assert path.with_suffix(".json").exists()
    return path


def test_encoder_file_loads_in_pytorch_with_identical_outputs(encoder_file):
    enc = load_history_encoder(encoder_file)
    assert isinstance(enc, HistoryEncoder)
    assert [k for k in enc.state_dict()] == ["conv1.weight", "conv1.bias", "conv2.weight", "conv2.bias", "conv3.weight", "conv3.bias", "fc.weight", "fc.bias"]
    rust = _core.HistoryEncoder.load(str(encoder_file))
    assert (rust.length, rust.embed_dim) == (60, 3)
    rng = np.random.default_rng(0)
    windows = (0.5 * rng.standard_normal((16, 60, 316))).astype(np.float32)
    windows[:4, :20] = 0.0  # zero-padded history at the start of a clip
    ours = rust.embed(windows)
    with torch.no_grad():
        theirs = enc(torch.from_numpy(windows)).numpy()
    err = np.abs(ours - theirs).max()
    print(f"history encoder Rust vs PyTorch: max abs diff {err:.2e}, |h| max {np.abs(theirs).max():.3f}")
    assert err <= 1e-5 * max(1.0, np.abs(theirs).max())
    np.testing.assert_array_equal(rust.embed(windows), ours)  # deterministic


def test_environment_observation_carries_the_pytorch_embedding(encoder_file):
    enc = load_history_encoder(encoder_file)
    env = VecEnv(3, {"v2": {"history": {"enabled": True, "encoder": str(encoder_file)}}, "state_init": {"frame": 30}}, autoreset_mode="disabled")
    obs, _ = env.reset(seed=0)
    assert obs.shape == (3, 905) and env.single_observation_space.shape == (905,)
    zero = np.zeros((3, 156), np.float32)
    for _ in range(4):
        windows = np.stack([env.history_window(i) for i in range(3)])
        obs, *_ = env.step(zero)
        with torch.no_grad():
            h = enc(torch.from_numpy(windows)).numpy()
        np.testing.assert_allclose(obs[:, 902:], h, rtol=1e-5, atol=1e-5)
    env.close()


def test_bad_encoder_configuration_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="v2.history.encoder"):
        VecEnv(2, {"v2": {"history": {"enabled": True}}})
    missing = tmp_path / "nope.safetensors"
    with pytest.raises(ValueError, match="nope.safetensors"):
        VecEnv(2, {"v2": {"history": {"enabled": True, "encoder": str(missing)}}})
