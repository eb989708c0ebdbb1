"""`skillmimic export --format onnx`: the graphs pass `onnx.checker`; onnxruntime gives our Rust
inference's actions (and the rl_games forward pass in PyTorch) to 1e-5 on real observations of
the environment, for the skill policy (MLP and modular attention actors), the high-level policy and
the fused high-level graph; the
deployment metadata (model properties = JSON sidecar) agrees with the simulated MuJoCo model."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from conftest import require_module, run_cli

torch = require_module("torch")

from test_rlgames_import import _observations, rlgames_forward, write_rlgames  # noqa: E402


def export(exe, ckpt, out, *extra):
    """Export, check the graph and the metadata; returns (session, sidecar)."""
    run_cli(exe, "export", "--checkpoint", str(ckpt), "--out", str(out), *extra)
    model = onnx.load(str(out))
    onnx.checker.check_model(model, full_check=True)
    assert model.opset_import[0].version >= 17
    side = json.loads((out.parent / (out.name + ".json")).read_text())
    props = {p.key: p.value for p in model.metadata_props}
    assert props.keys() == side.keys()
    for k, v in side.items():
        assert (props[k] if isinstance(v, str) else json.loads(props[k])) == v, k
    for io in (*model.graph.input, *model.graph.output):
        assert io.type.tensor_type.shape.dim[0].dim_param == "batch", io.name
    return ort.InferenceSession(str(out), providers=["CPUExecutionProvider"]), side


def run(sess, x):
    names = [o.name for o in sess.get_outputs()]
    return dict(zip(names, sess.run(None, {"obs": x})))


def test_skill_policy_onnx_matches_rust_and_pytorch_on_env_observations(tmp_path, skillmimic_bin):
    import skillmimic_rs

    env = skillmimic_rs.VecEnv(num_envs=8)
    env.action_space.seed(0)
    x = _observations(env)
    # normaliser statistics fitted to real observations: constant columns get var 0, the
    # hardest case for the float32 constants of the graph
    ck = write_rlgames(tmp_path / "llc.pth", 902, (1024, 512, 512), "mu", 156, fit=x[::2])
    run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "llc.pth"), "--kind", "skill", "--out", str(tmp_path / "llc.safetensors"))
    sess, side = export(skillmimic_bin, tmp_path / "llc.safetensors", tmp_path / "llc.onnx")
    assert side["graph"] == "skill_policy" and side["obs_dim"] == 902 and side["act_dim"] == 156

    out = run(sess, x)
    mu, _ = skillmimic_rs._core.Policy.load(str(tmp_path / "llc.safetensors")).infer(x)
    ref_mu, _ = rlgames_forward(ck, x)
    d_rust, d_torch = np.abs(out["mu"] - mu).max(), np.abs(out["mu"] - ref_mu).max()
    print(f"onnxruntime on {len(x)} env observations: max |d mu| vs Rust {d_rust:.2e}, vs PyTorch rl_games {d_torch:.2e} (max |mu| {np.abs(mu).max():.2f})")
    np.testing.assert_allclose(out["mu"], mu, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out["mu"], ref_mu, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out["actions"], np.clip(mu, -1, 1), rtol=1e-5, atol=1e-5)
    assert (np.abs(mu) > 1).any(), "the clamp output should be exercised"
    # the batch dimension is free
    np.testing.assert_allclose(run(sess, x[:1])["mu"], mu[:1], rtol=1e-5, atol=1e-5)


def test_high_level_and_fused_onnx_match_rust_on_heading_observations(tmp_path, skillmimic_bin):
    import skillmimic_rs

    write_rlgames(tmp_path / "llc.pth", 902, (1024, 512, 512), "mu", 156)
    run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "llc.pth"), "--kind", "skill", "--out", str(tmp_path / "llc.safetensors"))
    henv = skillmimic_rs.VecEnv(num_envs=4, task="heading", llc=str(tmp_path / "llc.safetensors"))
    henv.action_space.seed(0)
    hx = _observations(henv, 8)
    d = hx.shape[1]
    write_rlgames(tmp_path / "hlc.pth", d, (1024, 512), "logits", 3, seed=1, fit=hx)
    run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "hlc.pth"), "--kind", "hlc", "--task", "heading", "--out", str(tmp_path / "hlc.safetensors"))

    sess, side = export(skillmimic_bin, tmp_path / "hlc.safetensors", tmp_path / "hlc.onnx")
    assert [c["label"] for c in side["choices"]] == [12, 13, 11]
    out = run(sess, hx)
    logits, _ = skillmimic_rs._core.Policy.load(str(tmp_path / "hlc.safetensors")).infer(hx)
    np.testing.assert_allclose(out["logits"], logits, rtol=1e-5, atol=1e-5)
    assert (out["choice"] == logits.argmax(1)).all()
    assert (out["skill_label"] == np.array([12, 13, 11])[out["choice"]]).all()

    # the imported controller's configuration names no skill policy: --llc is needed
    r = subprocess.run([str(skillmimic_bin), "export", "--checkpoint", str(tmp_path / "hlc.safetensors"), "--out", str(tmp_path / "f.onnx"), "--fused"], capture_output=True, text=True)
    assert r.returncode != 0 and "--llc" in r.stderr and not (tmp_path / "f.onnx").exists(), r.stderr
    fsess, fside = export(skillmimic_bin, tmp_path / "hlc.safetensors", tmp_path / "fused.onnx", "--fused", "--llc", str(tmp_path / "llc.safetensors"))
    assert fside["graph"] == "fused_high_level" and fside["act_dim"] == 156 and fside["skill_source"]["file"] == "llc.safetensors"
    fout = run(fsess, hx)
    # the skill policy's observation: the state part and the one-hot of the chosen label
    onehot = np.zeros((len(hx), 64), np.float32)
    onehot[np.arange(len(hx)), np.array([12, 13, 11])[logits.argmax(1)]] = 1
    mu, _ = skillmimic_rs._core.Policy.load(str(tmp_path / "llc.safetensors")).infer(np.concatenate([hx[:, :838], onehot], 1))
    print(f"fused graph on {len(hx)} heading observations: max |d actions| {np.abs(fout['actions'] - np.clip(mu, -1, 1)).max():.2e}")
    np.testing.assert_allclose(fout["actions"], np.clip(mu, -1, 1), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(fout["logits"], logits, rtol=1e-5, atol=1e-5)


def test_metadata_matches_the_simulated_model(tmp_path, repo_root, skillmimic_bin):
    import mujoco

    write_rlgames(tmp_path / "p.pth", 902, (32,), "mu", 156)
    run_cli(skillmimic_bin, "import-rlgames", str(tmp_path / "p.pth"), "--kind", "skill", "--out", str(tmp_path / "p.safetensors"))
    _, side = export(skillmimic_bin, tmp_path / "p.safetensors", tmp_path / "p.onnx")
    model = mujoco.MjModel.from_xml_path(str(repo_root / "mjcf" / "skillmimic_full.xml"))
    # the humanoid's ball joints (the ball's own rotation joint belongs to the Ball body)
    ball_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "Ball")
    balls = [model.joint(j).name for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL and model.jnt_bodyid[j] != ball_body]
    assert side["joint_order"] == balls
    for g in side["pd_gains"]:
        dof = model.jnt_dofadr[model.joint(g["joint"]).id]
        assert model.dof_damping[dof] == g["kd"], g
        for axis in "xyz":
            act = model.actuator(f"{g['joint']}_{axis}")
            assert act.gainprm[0] == g["kp"], g
            assert tuple(act.forcerange) == (-side["force_limit_nm"], side["force_limit_nm"])
    assert model.opt.timestep == side["sim_dt"] and side["control_dt"] == side["sim_dt"] * side["substeps"]
    assert side["welded_joints"] == [] and side["hands"] == "full"
    assert side["skill_labels"]["31"] == "layup" and side["source"]["sha256"] and side["obs_layout_version"] == "skillmimic-obs-1"
    blocks = {b["name"]: (b["start"], b["end"]) for b in side["obs_blocks"]}
    import skillmimic_rs

    assert blocks == {k: tuple(v) for k, v in skillmimic_rs._core.OBS_BLOCKS.items()}
    # a safetensors-only option is refused with the reason
    r = subprocess.run([str(skillmimic_bin), "export", "--checkpoint", str(tmp_path / "p.safetensors"), "--out", str(tmp_path / "q.safetensors"), "--fused"], capture_output=True, text=True)
    assert r.returncode != 0 and "--format onnx" in r.stderr, r.stderr


@pytest.mark.parametrize("variant", [[], ["ppo.modular.heads=2", "ppo.modular.scaled=true", "ppo.modular.parts=seven"]])
def test_modular_attention_onnx_matches_rust_and_pytorch(tmp_path, skillmimic_bin, variant):
    import skillmimic_rs
    from skillmimic_rs import _core
    from skillmimic_rs.policy import load_checkpoint

    env = skillmimic_rs.VecEnv(num_envs=8)
    env.action_space.seed(0)
    x = _observations(env)
    ckpt = tmp_path / "modular.safetensors"
    small = ["ppo.modular.embed=32", "ppo.modular.proj_hidden=64", "ppo.modular.controller=[64, 32]", *variant]
    _core.init_policy(str(ckpt), "modular_attention", 902, ("box", 156), [64], seed=5, overrides=small)
    sess, side = export(skillmimic_bin, ckpt, tmp_path / "modular.onnx")
    assert side["graph"] == "skill_policy" and side["policy"] == "modular_attention" and side["act_dim"] == 156
    out = run(sess, x)
    mu, _ = _core.Policy.load(str(ckpt)).infer(x)
    with torch.no_grad():
        ref = load_checkpoint(ckpt).actor(torch.as_tensor(np.clip(x, -5.0, 5.0))).numpy()  # fresh normaliser: mean 0, var 1
    d_rust, d_torch = np.abs(out["mu"] - mu).max(), np.abs(out["mu"] - ref).max()
    print(f"modular onnx {variant}: max |d mu| vs Rust {d_rust:.2e}, vs PyTorch {d_torch:.2e} (max |mu| {np.abs(mu).max():.2f})")
    assert d_rust < 1e-5 and d_torch < 1e-5
    np.testing.assert_array_equal(out["actions"], np.clip(out["mu"], -1, 1))
