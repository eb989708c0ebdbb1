"""The 316-d SkillMimic-V2 history feature (reference-facts §9.2, §9.3) against an independent
numpy computation, block by block.

``VecEnv.history_window(i)`` is the (k, 316) window of environment i, oldest frame first, whose
last row is the frame just observed. From the environment's ``qpos`` (and, for reference rows,
from the clip alone) numpy rebuilds every row:

* root height (1) and the positions of bodies 1..52 relative to the root in the heading frame
  (156): entries 0:157;
* the 156 joint exp maps (from the ball-joint quaternions): entries 157:313;
* the ball position in the heading frame with its absolute height (3): entries 313:316, zero for
  clips without a ball (labels 0 and 10), online and in the reference rows.

Checked: after a reset at a fixed frame s the window holds the clip's reference rows s-k+1 .. s-1
(zero rows before frame 0, posed by forward kinematics of the clip) and then the simulated frame;
after every step it is the previous window shifted by one with the new simulated frame appended.
The clips are the demo clips plus the variants of ``synthetic_clips`` (ball-free labels, a turning
root, so that the heading rotation is not the identity). The encoder is a random one written here
(its weights do not matter to the features).
"""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np
import pytest
from safetensors.numpy import save_file

import reference_env as ref
import skillmimic_rs
from synthetic_clips import demo_variants

REPO = pathlib.Path(__file__).resolve().parent.parent
K = 12  # history length of the test encoder
FEATURE_DIM = 316
ATOL = 2e-5  # float32 features of metre / radian sized quantities


def write_encoder(path: pathlib.Path, length: int = K, embed: int = 3) -> pathlib.Path:
    """A random history encoder in the project's file format (Conv1d 316-128-64-32, k = 3, fc)."""
    rng = np.random.default_rng(0)
    dims = [FEATURE_DIM, 128, 64, 32]
    t = {}
    for layer in range(3):
        t[f"conv{layer + 1}.weight"] = (0.05 * rng.standard_normal((dims[layer + 1], dims[layer], 3))).astype(np.float32)
        t[f"conv{layer + 1}.bias"] = np.zeros(dims[layer + 1], np.float32)
    t["fc.weight"] = (0.01 * rng.standard_normal((embed, 32 * length))).astype(np.float32)
    t["fc.bias"] = np.zeros(embed, np.float32)
    meta = {"format": "skillmimic-history-encoder", "format_version": "1", "history_length": str(length), "feature_dim": str(FEATURE_DIM), "embed_dim": str(embed)}
    save_file(t, str(path), metadata=meta)
    return path


def features(m: mujoco.MjModel, d: mujoco.MjData, ball: bool) -> np.ndarray:
    """The 316 features of the posed MuJoCo data (kinematics already run), in numpy."""
    ids = ref.state_body_ids(m)
    pos = np.array(d.xpos[ids], dtype=np.float64)
    root = pos[0]
    hinv = ref.heading_inverse_matrix(np.array(d.xquat[ids[0]], dtype=np.float64))
    local = (pos[1:ref.NUM_BODIES] - root) @ hinv.T
    dof_pos, _ = ref.extract_joints(m, d)
    b = pos[ref.BALL]
    ball_feat = hinv @ np.array([b[0] - root[0], b[1] - root[1], b[2]]) if ball else np.zeros(3)
    return np.concatenate([[root[2]], local.reshape(-1), dof_pos, ball_feat])


def posed(m: mujoco.MjModel, qpos: np.ndarray) -> mujoco.MjData:
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    return d


def reference_row(m, clip, dref, t: int) -> np.ndarray:
    """Feature row of clip frame t (zero before frame 0), from forward kinematics of the clip pose."""
    if t < 0:
        return np.zeros(FEATURE_DIM)
    qpos, _ = ref.reset_qpos_qvel(m, clip, dref, t)
    return features(m, posed(m, qpos), clip["skill"] not in ref.BALL_FREE_SKILLS)


def assert_rows(got: np.ndarray, want: np.ndarray, what: str) -> None:
    """Compare feature rows block by block, naming the block that differs."""
    got, want = np.atleast_2d(got), np.atleast_2d(want)
    for name, sl in (("body positions", slice(0, 157)), ("joint exp maps", slice(157, 313)), ("ball position", slice(313, 316))):
        np.testing.assert_allclose(got[:, sl], want[:, sl], rtol=0, atol=ATOL, err_msg=f"{what}: {name} block")


@pytest.mark.parametrize("frame", [5, 40])
def test_history_window_rows_match_numpy_features(tmp_path, frame):
    files = sorted((REPO / "motions").glob("*.safetensors")) + demo_variants(tmp_path)
    cfg = {
        "motion": [str(f) for f in files],
        "v2": {"history": {"enabled": True, "encoder": str(write_encoder(tmp_path / "enc.safetensors"))}},
        "state_init": {"frame": frame},
        "episode_length": 8,
        "threads": 2,
        "reward": {"contact_graph": "exact"},
    }
    n = 6
    env = skillmimic_rs.VecEnv(num_envs=n, config=cfg)
    m = mujoco.MjModel.from_xml_string(env.mjcf_xml)
    by_name = {f.stem: ref.load_clip(f) for f in files}
    clips = [(c := by_name[name], ref.derive_reference(c)) for name, _, _ in env.clips]

    def sim_row(i: int) -> np.ndarray:
        clip = clips[int(env.episode_info()["clip"][i])][0]
        return features(m, posed(m, env.get_state(i)[0]), clip["skill"] not in ref.BALL_FREE_SKILLS)

    skills = set()

    def check_reset(i: int, what: str) -> None:
        w = env.history_window(i)
        assert w.shape == (K, FEATURE_DIM), w.shape
        clip, dref = clips[int(env.episode_info()["clip"][i])]
        skills.add(clip["skill"])
        want = np.stack([reference_row(m, clip, dref, frame - K + 1 + r) for r in range(K - 1)] + [sim_row(i)])
        assert_rows(w, want, f"{what}, env {i} (skill {clip['skill']})")

    env.reset(seed=frame)
    for i in range(n):
        check_reset(i, "reset")
    rng = np.random.default_rng(frame)
    seen_ball_free = seen_ball = resets = 0
    prev = [env.history_window(i) for i in range(n)]
    for k in range(20):
        _, _, term, trunc, _ = env.step((0.3 * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32))
        for i in range(n):
            w = env.history_window(i)
            if term[i] or trunc[i]:
                resets += 1
                check_reset(i, f"autoreset at step {k}")
            else:
                np.testing.assert_array_equal(w[:-1], prev[i][1:], err_msg=f"step {k} env {i}: the window did not shift by one")
                assert_rows(w[-1], sim_row(i), f"step {k} env {i}: newest row")
            ball_free = int(env.episode_info()["skill"][i]) in ref.BALL_FREE_SKILLS
            seen_ball_free += ball_free
            seen_ball += not ball_free and np.abs(w[-1, 313:]).max() > 0.05
            prev[i] = w
    env.close()
    assert resets >= 2 * n, "the run must include automatic resets"
    assert seen_ball_free and seen_ball, "both ball-free and ball clips must be exercised"
    assert {0, 10, 50, 51, 52} <= skills, f"every clip must be checked, saw skills {sorted(skills)}"
