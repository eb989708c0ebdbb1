"""Reference-state initialisation of the Rust environment against the numpy reference.

The observation / reward parity tests (test_env_parity.py) start their MuJoCo shadow from the
VecEnv's own state after each reset, so a wrong reset state (a velocity of the wrong sign or frame,
a joint quaternion built from the wrong exp map, the wrong start frame) would go unnoticed there.
Here the start frame is fixed (``state_init = {frame = N}``) and, after the first reset and after
every automatic reset inside a step, the VecEnv's ``qpos``/``qvel`` must equal the state that
``reference_env.reset_qpos_qvel`` builds from the clip file alone (reference-facts §1.5, §6.1).
For clips without a ball (labels 0 and 10) the ball is placed at random by design, so only the
humanoid part is compared there.
"""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np
import pytest

import reference_env as ref
import skillmimic_rs
from synthetic_clips import demo_variants
from test_env_parity import clip_table

REPO = pathlib.Path(__file__).resolve().parent.parent
# float32 clip storage promoted to float64 on both sides: the states agree to rounding
ATOL = 1e-7


def humanoid_mask(m: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks of the qpos / qvel entries that are not the ball's free joint."""
    jid = ref.free_joint_of_body(m, ref.ball_body_id(m))
    qa, va = int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])
    qm, vm = np.ones(m.nq, bool), np.ones(m.nv, bool)
    qm[qa:qa + 7] = False
    vm[va:va + 6] = False
    return qm, vm


def check_reset_state(env, m, clips, i: int, frame: int, what: str) -> int:
    """Environment i was just reset at `frame` of its clip: its state is the reference's.
    Returns the clip's skill label."""
    ep = env.episode_info()
    c = int(ep["clip"][i])
    clip, dref = clips[c]
    assert int(ep["ref_start"][i]) == frame, f"{what}: env {i} starts at frame {ep['ref_start'][i]}, not {frame}"
    assert int(ep["skill"][i]) == clip["skill"], f"{what}: env {i} skill {ep['skill'][i]} vs clip {clip['skill']}"
    qpos, qvel = env.get_state(i)
    want_q, want_v = ref.reset_qpos_qvel(m, clip, dref, frame)
    if clip["skill"] in ref.BALL_FREE_SKILLS:
        qm, vm = humanoid_mask(m)  # the ball is random for clips without one
        qpos, qvel, want_q, want_v = qpos[qm], qvel[vm], want_q[qm], want_v[vm]
    np.testing.assert_allclose(qpos, want_q, rtol=0, atol=ATOL, err_msg=f"{what}: env {i} qpos (clip {c}, frame {frame})")
    np.testing.assert_allclose(qvel, want_v, rtol=1e-6, atol=ATOL, err_msg=f"{what}: env {i} qvel (clip {c}, frame {frame})")
    return clip["skill"]


def run_resets(files: list[pathlib.Path], frame: int, num_envs: int, steps: int, episode_length: int, seed: int) -> tuple[int, set[int]]:
    """Reset, then step with random actions; check every reset. Returns the number of autoresets
    and the skill labels of the clips checked."""
    cfg = {
        "motion": [str(f) for f in files],
        "state_init": {"frame": frame},
        "episode_length": episode_length,
        "threads": 2,
        "reward": {"variant": "skillmimic", "contact_graph": "exact"},
    }
    env = skillmimic_rs.VecEnv(num_envs=num_envs, config=cfg)
    m = mujoco.MjModel.from_xml_string(env.mjcf_xml)
    clips = clip_table(env, files)
    assert all(frame <= c["num_frames"] - 2 for c, _ in clips), "the fixed frame must not be clamped"
    env.reset(seed=seed)
    skills = {check_reset_state(env, m, clips, i, frame, "reset") for i in range(num_envs)}
    rng = np.random.default_rng(seed)
    resets = 0
    for k in range(steps):
        a = (0.3 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
        _, _, term, trunc, _ = env.step(a)
        for i in np.flatnonzero(term | trunc):
            resets += 1
            skills.add(check_reset_state(env, m, clips, int(i), frame, f"autoreset at step {k}"))
    env.close()
    return resets, skills


@pytest.mark.parametrize("frame", [2, 37])
def test_reset_state_matches_numpy_reference_on_demo_clips(tmp_path, frame):
    files = sorted((REPO / "motions").glob("*.safetensors")) + demo_variants(tmp_path)
    resets, skills = run_resets(files, frame, num_envs=6, steps=40, episode_length=10, seed=frame)
    assert resets >= 12, "the run must include automatic resets"
    assert {0, 10, 50, 51, 52} <= skills, f"every clip must be checked, saw skills {sorted(skills)}"


def test_reset_state_matches_numpy_reference_on_real_clips(shared_dir):
    # the first clip of each skill folder (run and lrun have the largest exp-map headings)
    root = shared_dir / "data/ballplay_m"
    files = [sorted(d.glob("*.pt"))[0] for d in sorted(root.iterdir()) if d.is_dir() and any(d.glob("*.pt"))]
    resets, skills = run_resets(files, 20, num_envs=6, steps=40, episode_length=10, seed=4)
    assert resets >= 12 and len(skills) >= 5, (resets, sorted(skills))
