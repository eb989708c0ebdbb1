"""Interactive play without a screen: the keyboard/mouse logic, and the clear message on a headless
machine (the viewer itself needs a display)."""

from __future__ import annotations

import numpy as np
import pytest

from skillmimic_rs import interactive as ia


def test_keys_pick_the_task_choice_carrying_the_label():
    c = ia.Controller([31, 1, 2, 12, 13, 11, 31], has_policy=True)
    assert c.choose(4) == 4  # the policy chooses until a key takes over
    c.on_key(263)  # left arrow: 011 dribble left
    assert c.choose(4) == 5
    c.on_key(ord("E"))  # layup: the first choice with label 31
    assert c.choose(0) == 0 and "031" in c.message
    c.on_key(ord("R"))  # 034 is not a scoring choice: unchanged, with a message
    assert c.choose(2) == 0 and "not a choice" in c.message
    c.on_key(ia.KEY_POLICY)
    assert c.choose(3) == 3
    c.on_key(ord("L"))
    c.on_key(ord("I"))
    c.on_key(ord("I"))
    assert c.take_moves() == (0.5, 1.0) and c.take_moves() == (0.0, 0.0)


def test_without_a_policy_the_first_choice_is_held():
    c = ia.Controller([12, 13, 11], has_policy=False)
    assert c.choose(None) == 0
    c.on_key(265)
    assert c.choose(None) == 1


def test_a_floor_double_click_gives_its_world_point_once():
    p = np.array([1.5, -2.0, 0.0])
    assert np.allclose(ia.floor_click(0, p, None), p)
    assert ia.floor_click(0, p, p) is None  # the same click again
    assert ia.floor_click(3, p, None) is None  # a body, not the floor
    assert ia.floor_click(0, np.zeros(3), None) is None  # nothing selected yet


def test_headless_machines_get_a_clear_message(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(ia.sys, "platform", "linux")
    with pytest.raises(RuntimeError, match="needs a display.*--video"):
        ia.play("heading", "unused.safetensors")
    assert ia.main(["--task", "heading", "--llc", "unused.safetensors"]) == 2


def test_moving_the_goal_changes_the_task_observation(tmp_path):
    import pathlib

    import skillmimic_rs

    llc = tmp_path / "llc.safetensors"
    skillmimic_rs._core.init_policy(str(llc), "gaussian_mlp", 902, ("box", 156), [16], 3)
    repo = pathlib.Path(__file__).resolve().parent.parent
    env = skillmimic_rs.VecEnv(2, task="circling", llc=llc, motion=[str(repo / "motions")], threads=1)
    obs, _ = env.reset(seed=1)
    assert env.choice_labels == [12, 13, 11]
    qpos, _ = env.get_state(1)
    goal = np.array([qpos[0] + 3.0, qpos[1], 2.5], np.float32)  # 3 m along world +x, radius 2.5
    new = env.set_task_info(1, goal)
    assert np.allclose(env.task_info()[1], goal)
    assert np.array_equal(new[0], obs[0]) and not np.array_equal(new[1], obs[1])
    # bearing (world frame) now points along +x; loc has length 3 m; radius entry 2.5
    assert np.allclose(new[1, 840:843], [1.0, 0.0, 2.5], atol=1e-5)
    assert abs(np.hypot(*new[1, 838:840]) - 3.0) < 1e-4
    with pytest.raises(ValueError, match="3 finite values"):
        env.set_task_info(0, [1.0, 2.0])


def test_the_viewer_plays_the_checkpoints_whole_configuration(tmp_path):
    """`skillmimic play --interactive` hands the checkpoint's effective configuration to the viewer
    (`--config`): every [env] key applies, not only the task, the skill policy and the clips."""
    import pathlib

    import skillmimic_rs

    llc = tmp_path / "llc.safetensors"
    skillmimic_rs._core.init_policy(str(llc), "gaussian_mlp", 902, ("box", 156), [16], 3)
    motions = pathlib.Path(__file__).resolve().parent.parent / "motions"
    cfg = tmp_path / "hlc.toml"
    cfg.write_text(f'[env]\ntask = "heading"\nmotion = ["{motions}"]\nthreads = 1\n\n[env.hlc]\nllc = "{llc}"\nepisode_length = 500\n\n[env.heading]\nsuccess_radius = 0.7\n\n[ppo]\nlr = 1e-4\n')
    env = ia.viewer_env("heading", llc, config=cfg)
    assert env.config["hlc"]["episode_length"] == 500 and env.config["heading"]["success_radius"] == 0.7
    assert env.num_envs == 1 and env.choice_labels == [12, 13, 11]
    env.close()
