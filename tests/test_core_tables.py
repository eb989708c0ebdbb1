"""Tables the Python package takes from the Rust core instead of copying them by hand: the
observation layout, reward-term and frame-metric names, dimensions."""

from __future__ import annotations

import pathlib

import pytest

import skillmimic_rs
from skillmimic_rs import _core
from conftest import require_module


@pytest.fixture(scope="module")
def env():
    e = skillmimic_rs.VecEnv(num_envs=2, config={"episode_length": 8, "threads": 1})
    yield e
    e.close()


def test_obs_blocks_cover_the_observation_contiguously():
    blocks = skillmimic_rs.OBS_BLOCKS
    assert blocks == _core.OBS_BLOCKS
    spans = list(blocks.values())
    assert spans[0][0] == 0 and spans[-1][1] == skillmimic_rs.OBS_DIM == 902
    for (_, stop), (start, _) in zip(spans, spans[1:]):
        assert stop == start, f"gap or overlap in OBS_BLOCKS: {blocks}"
    assert all(stop > start for start, stop in spans)
    assert list(blocks)[0] == "root_height" and list(blocks)[-1] == "skill"
    # the humanoid part ends with the fingertip forces, the state part with the ball
    assert blocks["fingertip_force"][1] == _core.HUMANOID_DIM and blocks["ball_angvel"][1] == _core.STATE_DIM
    assert blocks["skill"] == (_core.STATE_DIM, skillmimic_rs.OBS_DIM)


def test_names_and_dims_match_the_environment(env):
    assert list(skillmimic_rs.TERM_NAMES) == env.reward_term_names and skillmimic_rs.TERM_NAMES[-1] == "total"
    assert list(skillmimic_rs.FRAME_METRIC_NAMES) == env.frame_metric_names
    assert env.single_observation_space.shape == (skillmimic_rs.OBS_DIM,)
    assert env.single_action_space.shape == (skillmimic_rs.ACT_DIM,) == (156,)
    assert _core.CONFIG_PATH_KEYS == ("motion", "v2.history.encoder", "hlc.llc")


def test_character_table_matches_the_shipped_scenes():
    """``CHARACTERS`` against PyPI mujoco's compile of each character's scene in mjcf/ (one
    actuator per action entry, the character's bodies under its root) and the widths the source
    projects state: 823 (SkillMimic's humanoid observation), 222 (TokenHSI's), 358 (PHC's SMPL
    self-observation without shape)."""
    mujoco = require_module("mujoco")
    chars = skillmimic_rs.CHARACTERS
    assert list(chars) == ["skillmimic", "tokenhsi", "smpl"]
    assert chars["skillmimic"]["act_dim"] == skillmimic_rs.ACT_DIM == 156
    assert chars["skillmimic"]["hands"] == ("full", "boxhand") and chars["skillmimic"]["ballplay"]
    assert {k: v["proprio_dim"] for k, v in chars.items()} == {"skillmimic": 823, "tokenhsi": 222, "smpl": 358}
    assert chars["skillmimic"]["proprio_dim"] == _core.HUMANOID_DIM
    scenes = {"skillmimic": "skillmimic_full", "tokenhsi": "tokenhsi", "smpl": "smpl"}
    root = pathlib.Path(__file__).resolve().parents[1] / "mjcf"
    for name, row in chars.items():
        m = mujoco.MjModel.from_xml_path(str(root / f"{scenes[name]}.xml"))
        assert m.nu == row["act_dim"], (name, m.nu, row)
        under_root = sum(1 for b in range(1, m.nbody) if m.body_rootid[b] == m.body_rootid[1])
        assert under_root == row["num_bodies"], (name, under_root, row)
        assert not row["ballplay"] or name == "skillmimic"
        assert row["summary"]


def test_independent_reference_uses_the_same_term_names():
    # tests/reference_*.py is a hand-written numpy reference (kept independent of the package on
    # purpose); its term order must still be the core's, since parity tests compare by column
    import reference_common

    assert tuple(reference_common.REWARD_NAMES) == skillmimic_rs.TERM_NAMES


def test_history_feature_dim_comes_from_the_core():
    require_module("torch")
    from skillmimic_rs import history

    assert history.FEATURE_DIM == _core.HISTORY_FEATURE_DIM == 316
