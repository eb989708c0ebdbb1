//! ONNX export checked with a pure-Rust ONNX runtime (tract), no Python:
//! * a skill policy's graph gives our inference's means and clamped actions (to 1e-5) on real
//!   observations of the imitation task, for batch sizes 1 and N (the batch dimension is dynamic);
//! * a high-level policy's graph gives its logits, argmax and skill label; the fused graph gives
//!   the PD targets the high-level task itself applies for the chosen skill;
//! * the metadata properties and the JSON sidecar hold the same values; bad input is refused
//!   without writing a file.

mod common;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_env::EnvConfig;
use skillmimic_env::VecEnv;
use skillmimic_env::tasks::hlc::HighLevel;
use skillmimic_env::tasks::hlc::heading::Heading;
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::{PpoConfig, TrainConfig};
use skillmimic_learn::onnx::meta::{DeployMeta, Source, source_of};
use skillmimic_learn::onnx::{self, Exported, fused_model, policy_model};
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use tract_onnx::prelude::*;

use common::workspace_root;
use skillmimic_env::tasks::hlc::config::HlcConfig;

fn env_config(task: &str, n: usize) -> EnvConfig {
    let mut c = EnvConfig { task: task.into(), num_envs: n, threads: 2, ..Default::default() };
    c.motion = vec![workspace_root().join("motions")];
    c
}

/// Observations of `steps + 1` consecutive states of the environment under random actions.
fn observations(
    env: &mut dyn skillmimic_env::Env,
    steps: usize,
    act: impl Fn(&mut ChaCha8Rng) -> f32,
) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    env.reset_all(Some(1));
    let mut rows = env.buffers().obs.clone();
    let width = env.num_envs() * env.act_dim();
    for _ in 0..steps {
        let a: Vec<f32> = (0..width).map(|_| act(&mut rng)).collect();
        env.step(&a).unwrap();
        env.reset_done();
        rows.extend_from_slice(&env.buffers().obs);
    }
    rows
}

/// Run the model's bytes in tract on `obs` (`n` rows); outputs in graph order.
fn run_tract(e: &Exported, obs: &[f32], n: usize) -> Vec<Tensor> {
    use onnx_protobuf::Message;
    let bytes = e.model.write_to_bytes().unwrap();
    let model = tract_onnx::onnx()
        .model_for_read(&mut &bytes[..])
        .unwrap()
        .into_optimized()
        .unwrap()
        .into_runnable()
        .unwrap();
    let d = obs.len() / n;
    let input = Tensor::from_shape(&[n, d], obs).unwrap();
    model.run(tvec!(input.into())).unwrap().into_iter().map(|v| v.into_tensor()).collect()
}

fn f32s(t: &Tensor) -> Vec<f32> {
    t.to_plain_array_view::<f32>().unwrap().iter().copied().collect()
}
fn i64s(t: &Tensor) -> Vec<i64> {
    t.to_plain_array_view::<i64>().unwrap().iter().copied().collect()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

fn source() -> Source {
    Source { file: "test.safetensors".into(), sha256: "0".repeat(64), iteration: 7, samples: 99 }
}

fn train_config(task: &str) -> TrainConfig {
    let mut c = TrainConfig::default();
    c.env.task = task.into();
    c
}

/// A policy whose normaliser is fitted to `obs` (near-constant columns get tiny variances, the
/// hardest case for the float32 folding) and whose outputs leave [−1, 1] sometimes.
fn fitted(mut p: Policy, obs: &[f32]) -> Policy {
    p.obs_norm.update(obs);
    for w in p.actor.params_mut().into_iter().rev().skip(1).take(1) {
        w.iter_mut().for_each(|v| *v *= 8.0);
    }
    p
}

#[test]
fn skill_policy_graph_gives_our_actions_on_real_observations() {
    let mut env = skillmimic_env::registry::make(&env_config("imitation", 8)).unwrap();
    let obs = observations(env.as_mut(), 24, |r| r.random_range(-1.0..1.0));
    let n = obs.len() / 902;
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let cfg = PpoConfig { hidden: vec![256, 128, 64], ..Default::default() };
    let p = fitted(Policy::new(902, 156, &cfg, &mut rng), &obs);
    let meta = DeployMeta::new("", "gaussian_mlp", &train_config("imitation"), 902, 156, source())
        .unwrap();
    let e = policy_model(&p, meta).unwrap();
    let names: Vec<&str> = e.meta.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["actions", "mu"]);

    let (mut mu, mut v) = (vec![0.0f32; n * 156], vec![0.0f32; n]);
    p.infer(&obs, n, &mut InferenceBuffers::default(), &mut mu, &mut v, 1);
    let clamped: Vec<f32> = mu.iter().map(|m| m.clamp(-1.0, 1.0)).collect();
    assert!(mu.iter().any(|m| m.abs() > 1.0), "the test policy should exercise the clamp");
    let out = run_tract(&e, &obs, n);
    let (dm, da) = (max_diff(&f32s(&out[1]), &mu), max_diff(&f32s(&out[0]), &clamped));
    println!("skill graph on {n} env observations: max |d mu| {dm:.2e}, max |d actions| {da:.2e}");
    assert!(dm <= 1e-5 && da <= 1e-5);
    // one row at a time: the batch dimension is free
    let one = run_tract(&e, &obs[..902], 1);
    assert!(max_diff(&f32s(&one[1]), &mu[..156]) <= 1e-5);
}

#[test]
fn high_level_and_fused_graphs_give_the_choice_and_the_tasks_pd_targets() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let llc_path = common::skill_policy("onnx-fused");
    // a skill policy with a fitted normaliser, saved where the task loads it from
    let mut imit = skillmimic_env::registry::make(&env_config("imitation", 4)).unwrap();
    let skill_obs = observations(imit.as_mut(), 10, |r| r.random_range(-1.0..1.0));
    let skill = fitted(checkpoint::load(&llc_path, None).unwrap().policy, &skill_obs);
    checkpoint::save(&llc_path, &skill, None, &Progress::default(), "").unwrap();

    let mut c = env_config("heading", 6);
    c.table_mut::<HlcConfig>().llc = llc_path.clone();
    c.table_mut::<HlcConfig>().llc_steps = 1;
    let mut env = skillmimic_env::registry::make(&c).unwrap();
    let d = env.obs_dim();
    let obs = observations(env.as_mut(), 8, |r| r.random_range(0..3) as f32);
    let hl_cfg =
        PpoConfig { hidden: vec![64, 32], policy: "categorical_mlp".into(), ..Default::default() };
    let hl = fitted(
        Policy::build(d, skillmimic_env::ActionSpace::Discrete { n: 3 }, &hl_cfg, &mut rng)
            .unwrap(),
        &obs,
    );
    let meta =
        DeployMeta::new("", "categorical_mlp", &train_config("heading"), d, 3, source()).unwrap();

    // the high-level graph alone
    let n = obs.len() / d;
    let (mut logits, mut v) = (vec![0.0f32; n * 3], vec![0.0f32; n]);
    hl.infer(&obs, n, &mut InferenceBuffers::default(), &mut logits, &mut v, 1);
    let e = policy_model(&hl, meta.clone()).unwrap();
    let out = run_tract(&e, &obs, n);
    assert!(max_diff(&f32s(&out[0]), &logits) <= 1e-5);
    let choice = i64s(&out[1]);
    for (i, &ch) in choice.iter().enumerate() {
        let row = &logits[i * 3..i * 3 + 3];
        let best = (0..3).fold(0, |b, k| if row[k] > row[b] { k } else { b });
        assert_eq!(ch as usize, best);
        assert_eq!(i64s(&out[2])[i], [12, 13, 11][best]);
    }

    // the fused graph against the task: its targets for the graph's choice
    let fused = fused_model(&hl, &skill, meta, source()).unwrap();
    let names: Vec<&str> = fused.meta.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["logits", "choice", "skill_label", "actions", "mu"]);
    env.reset_all(Some(4));
    let mut worst = 0.0f32;
    for _ in 0..10 {
        let now = env.buffers().obs.clone();
        let out = run_tract(&fused, &now, 6);
        let choice: Vec<f32> = i64s(&out[1]).iter().map(|&c| c as f32).collect();
        env.step(&choice).unwrap();
        let hold = env.as_any().downcast_ref::<VecEnv<HighLevel<Heading>>>().unwrap();
        worst = worst.max(max_diff(&f32s(&out[3]), hold.last_targets()));
        env.reset_done();
    }
    println!("fused graph vs the heading task's PD targets: max |d| {worst:.2e}");
    assert!(worst <= 1e-5);
}

#[test]
fn metadata_sidecar_and_refusals() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut p =
        Policy::new(902, 156, &PpoConfig { hidden: vec![16], ..Default::default() }, &mut rng);
    let dir = std::env::temp_dir().join(format!("skillmimic-onnx-meta-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ckpt = dir.join("p.safetensors");
    checkpoint::save(&ckpt, &p, None, &Progress { iteration: 3, samples: 30 }, "").unwrap();
    let src = source_of(&ckpt, 3, 30).unwrap();
    assert_eq!(src.sha256.len(), 64);
    let meta =
        DeployMeta::new("", "gaussian_mlp", &train_config("imitation"), 902, 156, src).unwrap();
    assert_eq!(meta.joint_order.len(), 52);
    let names = |cfg: &TrainConfig, d: usize| {
        skillmimic_learn::onnx::meta::obs_blocks(cfg, d)
            .unwrap()
            .iter()
            .map(|b| format!("{}:{}-{}", b.name, b.start, b.end))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        names(&train_config("imitation"), 905)[10..],
        ["skill:838-902", "history_embedding:902-905"]
    );
    assert_eq!(
        names(&train_config("heading"), 842)[9..],
        ["ball_angvel:835-838", "heading:838-842"]
    );
    assert_eq!(
        names(&train_config("tracking"), 1375)[5..],
        ["fingertip_force:793-823", "reference:823-1375"]
    );
    assert_eq!((meta.control_dt, meta.sim_dt, meta.substeps), (1.0 / 60.0, 1.0 / 120.0, 2));
    let e = policy_model(&p, meta).unwrap();
    let out = dir.join("p.onnx");
    let side = onnx::write(&out, &e).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&side).unwrap()).unwrap();
    assert_eq!(json["obs_layout_version"], "skillmimic-obs-1");
    for prop in &e.model.metadata_props {
        let expect = match &json[&prop.key] {
            serde_json::Value::String(s) => s.clone(),
            other => other.to_string(),
        };
        assert_eq!(prop.value, expect, "property {}", prop.key);
    }
    assert_eq!(e.model.metadata_props.len(), json.as_object().unwrap().len());

    // a non-finite weight: refused, nothing written
    p.actor.params_mut()[0][5] = f32::NAN;
    let bad = dir.join("bad.onnx");
    let meta = DeployMeta::new("", "gaussian_mlp", &train_config("imitation"), 902, 156, source())
        .unwrap();
    let err =
        policy_model(&p, meta.clone()).err().expect("NaN weights must be refused").to_string();
    assert!(err.contains("actor.0.weight") && err.contains("non-finite"), "{err}");
    assert!(!bad.exists());
    // a Gaussian policy is not a high-level policy
    p.actor.params_mut()[0][5] = 0.0;
    let err = fused_model(&p, &p, meta, source()).err().unwrap().to_string();
    assert!(err.contains("categorical_mlp"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
