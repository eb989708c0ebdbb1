"""ONNX export of a policy trained on a TokenHSI task: the deployment metadata describes the 32-DoF
TokenHSI character, not the SkillMimic humanoid — joint order, per-entry action → PD target map,
gains and torque limits checked against the facts table of ``test_hsi_character`` (written from
the facts file, independently of the Rust table) and against PyPI mujoco's compile of
``mjcf/tokenhsi.xml`` (actuators in action order, kp, damping, force range, time step), observation blocks 222 + task, 30 Hz over a
1/120 s step — and onnxruntime gives our Rust inference on the task's observations. The same
checkpoint's video is drawn at the character's 30 Hz policy rate (its saved configuration leaves
``env.character`` empty, the task's default)."""

from __future__ import annotations

import numpy as np

from conftest import run_cli
from test_hsi_character import JOINTS, action_maps
from test_onnx_export import export, run


def gentle_observations(env, steps: int = 5) -> np.ndarray:
    """The observations of `steps` steps of small random actions (0.3 x uniform, action space
    seeded 0) after a reset with seed 1, stacked as float32 rows."""
    env.action_space.seed(0)
    x, _ = env.reset(seed=1)
    xs = [x]
    for _ in range(steps):
        x, *_ = env.step(env.action_space.sample() * 0.3)
        xs.append(x)
    return np.concatenate(xs).astype(np.float32)


def assert_pd_metadata_matches_model(side: dict, model) -> None:
    """The export's joints, gains, force limits and time step against a compiled MuJoCo model of
    the character: each joint of ``joint_order`` drives the actuators ``<joint>_x/_y/_z`` (three
    hinges) or ``<joint>`` (one), which are the model's actuators in action order, with
    kp = ``gainprm[0]``, force range ± the joint's limit and the hinges' damping = kd."""
    import mujoco

    names = [model.actuator(i).name for i in range(model.nu)]
    order = []
    for g in side["pd_gains"]:
        axes = [f"{g['joint']}_{a}" for a in "xyz"]
        acts = axes if axes[0] in names else [g["joint"]]
        for a in acts:
            act = model.actuator(a)
            assert act.gainprm[0] == g["kp"] and tuple(act.forcerange) == (-g["force_limit_nm"], g["force_limit_nm"]), (g, a)
            joint = model.actuator_trnid[act.id, 0]
            assert model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_HINGE and model.dof_damping[model.jnt_dofadr[joint]] == g["kd"], (g, a)
        order += acts
    assert order == names and len(side["action_offset_scale"]) == model.nu, (order, names)  # action column = actuator index
    assert model.opt.timestep == side["sim_dt"]


def test_tokenhsi_policy_exports_with_the_characters_metadata(tmp_path, repo_root, skillmimic_bin):
    import mujoco
    import skillmimic_rs

    out = tmp_path / "sit"
    run_cli(skillmimic_bin, "train", "--preset", "tiny", "--task", "hsi_sit", "--set", "run.iterations=2", "--set", "env.num_envs=8",
            "--set", "ppo.minibatch=64", "--set", "ppo.hidden=[32]", "--set", "run.eval_episodes=1", "--no-video", "--out", str(out))
    sess, side = export(skillmimic_bin, out / "latest.safetensors", tmp_path / "sit.onnx")
    assert side["task"] == "hsi_sit" and side["obs_dim"] == 222 + 38 and side["act_dim"] == 32
    assert side["obs_layout_version"] == "tokenhsi-obs-1"
    assert [(b["start"], b["end"]) for b in side["obs_blocks"]] == [(0, 42), (42, 132), (132, 177), (177, 222), (222, 260)]
    assert side["joint_order"] == [j[1] for j in JOINTS]
    np.testing.assert_allclose(np.array(side["action_offset_scale"]), action_maps(), rtol=0, atol=1e-12)
    assert [(g["joint"], g["kp"], g["kd"], g["force_limit_nm"]) for g in side["pd_gains"]] == [(j[1], j[4], j[5], j[6]) for j in JOINTS]
    assert (side["sim_dt"], side["substeps"]) == (1 / 120, 4) and abs(side["control_dt"] - 1 / 30) < 1e-15
    assert side["skill_labels"] == {} and side["welded_joints"] == []
    assert_pd_metadata_matches_model(side, mujoco.MjModel.from_xml_path(str(repo_root / "mjcf" / "tokenhsi.xml")))
    env = skillmimic_rs.VecEnv(num_envs=8, task="hsi_sit")
    x = gentle_observations(env)
    got = run(sess, x)
    mu, _ = skillmimic_rs._core.Policy.load(str(out / "latest.safetensors")).infer(x)
    print(f"onnxruntime on {len(x)} hsi_sit observations: max |d mu| vs Rust {np.abs(got['mu'] - mu).max():.2e}")
    np.testing.assert_allclose(got["mu"], mu, rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(got["actions"], np.clip(got["mu"], -1, 1))
    env.close()
    # 30 policy steps at 30 Hz = 1 s: 31 states, every 2nd drawn for a 15 fps video (16 frames);
    # at the SkillMimic humanoid's 60 Hz it would be every 4th (8 frames, played twice too fast)
    r = run_cli(skillmimic_bin, "play", "--checkpoint", str(out / "latest.safetensors"), "--steps", "30", "--fps", "15",
                "--video", str(tmp_path / "sit.gif"), "--width", "64", "--height", "48")
    assert "(16 frames at 15 fps)" in r.stdout, r.stdout
