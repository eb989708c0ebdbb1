"""The ``tracking`` task (ModSkill / PHC motion tracking) against an independent numpy statement of
its formulas on real BallPlay-M clips: the reference frame comes from the clip posed with PyPI
``mujoco`` (reset_qpos_qvel + forward kinematics), the simulated state from a bit-identical PyPI
shadow of each environment; the reward terms (as the released ModSkill code: squared errors
averaged over bodies and components, the power penalty from the drive forces, zero for the first 3
steps), the reference block of the observation and the metrics agree to 1e-5."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import reference_env as ref
import skillmimic_rs
from test_env_parity import Shadow, clip_table

FINGER_WORDS = ("Index", "Middle", "Pinky", "Ring", "Thumb")
CLIPS = ["run/013_018pickle_run_001_001.pt", "layup/031_015pickle_layup_001_001.pt", "pick_40/001_001pickle_pick_001_001.pt"]


def _files(shared_dir):
    root = shared_dir / "data" / "ballplay_m"
    files = [root / c for c in CLIPS if (root / c).exists()]
    if len(files) < 2:
        files = sorted(root.rglob("*.pt"))[:3]
    return files


def _qd(a, b):
    """Angle of a ⊗ conj(b) (rad)."""
    return ref.quat_angle(b, a)


def _frame_state(m, d, clip, dref, t):
    qpos, qvel = ref.reset_qpos_qvel(m, clip, dref, min(t, len(clip["root_pos"]) - 1))
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    return ref.extract_state(m, d)


def _power(m, d, sim):
    """Σ|τ·q̇| over the joint drives: τ = the actuator force of the last sub-step (MuJoCo's
    qfrc_actuator, left in place by mj_step) plus the joint damping at the new rate (−kd·q̇), q̇ the
    joint rate after the step — the read-out's drive force (Isaac Gym's dof_force_tensor)."""
    p = 0.0
    for j in range(52):
        name = m.body(j + 2).name  # MuJoCo body 1 = Pelvis, skeleton joint j moves body j + 1
        adr = m.jnt_dofadr[m.joint(name).id]
        for k in range(3):
            qd = sim["dof_vel"][3 * j + k]
            p += abs((d.qfrc_actuator[adr + k] - m.dof_damping[adr + k] * qd) * qd)
    return p


def _terms(sim, r, bodies, power):
    """The released ModSkill reward: squared errors averaged over bodies and x, y, z components."""
    dp = r["body_pos"][bodies] - sim["body_pos"][bodies]
    th = np.array([_qd(r["body_quat"][b], sim["body_quat"][b]) for b in bodies])
    dv = r["body_linvel"][bodies] - sim["body_linvel"][bodies]
    dw = r["body_angvel"][bodies] - sim["body_angvel"][bodies]
    t = [0.5 * math.exp(-100 * (dp**2).mean()), 0.3 * math.exp(-10 * (th**2).mean()), 0.1 * math.exp(-0.1 * (dv**2).mean()), 0.1 * math.exp(-0.1 * (dw**2).mean()), -0.0005 * power]
    return np.array([*t, sum(t)])


def _ref_block(sim, r, bodies):
    hinv = ref.heading_inverse_matrix(sim["body_quat"][0])
    rot = lambda q: ref.quat_to_mat(q)  # noqa: E731
    rows = []
    for b in bodies:
        dq = ref.quat_mul(r["body_quat"][b], ref.quat_conj(sim["body_quat"][b]))
        rows += [hinv @ (r["body_pos"][b] - sim["body_pos"][b]), ref.tan_norm(hinv @ rot(dq) @ hinv.T), hinv @ (r["body_linvel"][b] - sim["body_linvel"][b]),
                 hinv @ (r["body_angvel"][b] - sim["body_angvel"][b]), hinv @ (r["body_pos"][b] - sim["body_pos"][0]), ref.tan_norm(hinv @ rot(r["body_quat"][b]))]
    return np.concatenate(rows)


def test_tracking_reward_obs_and_metrics_match_numpy_on_real_clips(shared_dir):
    files = _files(shared_dir)
    motion = [str(f) for f in files]
    env = skillmimic_rs.VecEnv(num_envs=3, task="tracking", autoreset_mode="disabled", threads=2, motion=motion)
    clips = clip_table(skillmimic_rs.VecEnv(num_envs=1, motion=motion), files)
    sh = Shadow(env)
    m, d = sh.model, mujoco.MjData(sh.model)
    names = [m.body(i).name for i in range(1, 54)]
    bodies = [b for b, n in enumerate(names) if not any(w in n for w in FINGER_WORDS)]
    assert len(bodies) == 23 and env.single_observation_space.shape[0] == 823 + 24 * 23
    obs, _ = env.reset(seed=2)
    info0 = env.task_info()
    hist = []
    for i in range(env.num_envs):
        sh.copy_state(i)
        c, t0 = int(info0[i, 0]), int(info0[i, 1])
        clip, dref = clips[c]
        st = sh.state(i)
        np.testing.assert_allclose(obs[i, 823:], _ref_block(st, _frame_state(m, d, clip, dref, t0 + 1), bodies), rtol=1e-5, atol=1e-5)
        hist.append([_frame_state(m, d, clip, dref, max(t0 - 1, 0))["body_pos"], st["body_pos"]])
    rng = np.random.default_rng(0)
    done = np.zeros(env.num_envs, bool)
    checked = 0
    for step in range(1, 41):
        a = (0.3 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
        obs, rew, term, trunc, info = env.step(a)
        for i in np.flatnonzero(~done):
            sh.step(i, a[i])
            st = sh.state(i)
            c, t = int(info["task_info"][i, 0]), int(info["task_info"][i, 1])
            clip, dref = clips[c]
            r = _frame_state(m, d, clip, dref, t)
            # the power penalty is zero for the first 3 steps after a reset (released progress_buf <= 3)
            terms = _terms(st, r, bodies, _power(m, sh.datas[i], st) if step > 3 else 0.0)
            np.testing.assert_allclose(info["reward_terms"][i], terms, rtol=1e-5, atol=1e-5)
            assert rew[i] == pytest.approx(terms[-1], rel=1e-5, abs=1e-5)
            if not (term[i] or trunc[i]):
                np.testing.assert_allclose(obs[i, 823:], _ref_block(st, _frame_state(m, d, clip, dref, t + 1), bodies), rtol=1e-5, atol=1e-5)
            # metrics (mm): global and root-relative position errors, velocity and acceleration errors
            x = [hist[i][0], hist[i][1], st["body_pos"]]
            y = [_frame_state(m, d, clip, dref, max(t - k, 0))["body_pos"] for k in (2, 1, 0)]
            g = np.linalg.norm(st["body_pos"][bodies] - r["body_pos"][bodies], axis=1)
            rel = np.linalg.norm((st["body_pos"][bodies] - st["body_pos"][0]) - (r["body_pos"][bodies] - r["body_pos"][0]), axis=1)
            ve = np.linalg.norm((x[2] - x[1] - (y[2] - y[1]))[bodies], axis=1).mean()
            ae = np.linalg.norm((x[2] - 2 * x[1] + x[0] - (y[2] - 2 * y[1] + y[0]))[bodies], axis=1).mean()
            want = 1e3 * np.array([g.mean(), rel.mean(), ve, ae])
            np.testing.assert_allclose(info["frame_metrics"][i, :4], want, rtol=1e-5, atol=1e-4)
            hist[i] = [hist[i][1], st["body_pos"]]
            # the distance rule skips the first step after a reset (released progress_buf > 1)
            assert term[i] == (step > 1 and g.mean() > 0.25)
            checked += 1
            done[i] = term[i] or trunc[i]
    print(f"{checked} environment steps checked; {int(done.sum())} episodes ended")
    assert checked >= 40
    env.close()


def test_eval_runs_whole_clips_from_frame_0_and_refuses_imitation_flags(tmp_path, skillmimic_bin):
    """`skillmimic eval` of a tracking checkpoint: `--start-frame 0` evaluates whole clips (the
    paper's protocol); other start frames and `--horizon` are refused with the reason instead of
    being ignored."""
    import json
    import subprocess

    from conftest import run_cli

    out = tmp_path / "track"
    run_cli(skillmimic_bin, "train", "--preset", "tiny", "--task", "tracking", "--set", "run.iterations=1", "--set", "env.num_envs=8",
            "--set", "ppo.minibatch=64", "--set", "ppo.hidden=[32]", "--set", "run.eval_episodes=1", "--no-video", "--out", str(out))
    ckpt = str(out / "latest.safetensors")
    metrics = tmp_path / "m.json"
    run_cli(skillmimic_bin, "eval", "--checkpoint", ckpt, "--episodes", "4", "--start-frame", "0", "--set", "env.tracking.termination_distance=0.5", "--out", str(metrics))
    m = json.loads(metrics.read_text())
    assert m["task"] == "tracking" and m["episodes"] == 4 and {"g_mpjpe_mm", "success"} <= set(m["final_metrics"])
    for flags in (["--start-frame", "3"], ["--horizon", "100"]):
        r = subprocess.run([str(skillmimic_bin), "eval", "--checkpoint", ckpt, "--episodes", "2", *flags, "--out", str(metrics)], capture_output=True, text=True)
        assert r.returncode != 0 and ("--start-frame" in r.stderr or "--horizon" in r.stderr), r.stderr
