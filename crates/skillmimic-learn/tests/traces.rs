//! Recorded traces: behaviour that must not change when the code is restructured.
//!
//! * Every registered task (plus the imitation task with every SkillMimic-V2 part on): 200 steps
//!   of 4 environments from seeded random actions (uniform in [−1, 1] for continuous actions, a
//!   uniform choice for discrete ones), finished environments reset after every step. The
//!   digest covers, per step, the observations, rewards, reward terms, metrics, task
//!   information, and the terminated / truncated / unstable flags, bit for bit.
//! * Every policy family on a task it acts in, plus the motion prior and the full SkillMimic-V2
//!   stack: two PPO iterations through the trainer; the digest covers every checkpoint tensor
//!   and the iterations' learning statistics (timings excluded).
//!
//! The digests are SHA-256 over the little-endian bytes, compared with
//! `tests/fixtures/traces.json`, recorded on a machine with AVX-512. The learner's float results
//! depend on the matrix kernels the CPU selects, so a machine of another class compares its
//! `train/` cases with that class's digests in `tests/fixtures/traces-by-class.json` (the
//! physics' digests are the same on every class). `SKILLMIMIC_UPDATE_TRACES=1` rewrites the
//! current class's digests (only when a change of behaviour is intended; say why in the commit).
//! `SKILLMIMIC_TRACE_DUMP=<folder>`
//! writes each case's raw per-step rows as JSON lines, to find the first step that differs.

mod common;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

use common::{skill_policy, workspace_root};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};
use skillmimic_env::ActionSpace;
use skillmimic_env::registry::TASKS;
use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::trainer::Trainer;

const STEPS: usize = 200;

fn fixture_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/traces.json")
}

fn config(task: &str, tag: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.to_string();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.run.learner_threads = 1;
    c.run.seed = 11;
    c.ppo.horizon = 8;
    c.ppo.minibatch = 16;
    c.ppo.mini_epochs = 2;
    c.ppo.hidden = vec![32, 16];
    c.run.out_dir =
        std::env::temp_dir().join(format!("skillmimic-traces-{tag}-{}", std::process::id()));
    if skillmimic_env::registry::is_high_level(task) {
        c.env.table_mut::<HlcConfig>().llc = skill_policy(&format!("traces-{tag}"));
    }
    c.ppo.token.tokenizer = vec![32];
    c.ppo.token.embed = 16;
    c.ppo.token.layers = 1;
    c.ppo.token.feedforward = 32;
    c.ppo.token.head = vec![32];
    c.ppo.modular.controller = vec![32];
    c.ppo.modular.proj_hidden = 16;
    c.ppo.modular.embed = 8;
    c
}

/// The imitation task with the State Transition Field, the Stitched Trajectory Graph, Adaptive
/// Trajectory Sampling and a (randomly initialised) history encoder.
fn v2_config(tag: &str) -> TrainConfig {
    let mut c = config("imitation", tag);
    let enc = std::env::temp_dir()
        .join(format!("skillmimic-traces-{tag}-{}-enc.safetensors", std::process::id()));
    skillmimic_env::v2::history::random_encoder(60, 3, 5).save(&enc, &Default::default()).unwrap();
    c.env.v2.history.enabled = true;
    c.env.v2.history.encoder = enc;
    c.env.v2.stf.enabled = true;
    c.env.v2.stg.enabled = true;
    c.env.v2.ats.enabled = true;
    c.env.v2.ats.update_interval = 8;
    c
}

/// SHA-256 over little-endian rows, with an optional JSON-lines dump of the rows.
struct Recorder {
    hash: Sha256,
    dump: Option<std::fs::File>,
}

impl Recorder {
    fn new(case: &str) -> Self {
        let dump = std::env::var_os("SKILLMIMIC_TRACE_DUMP").map(|d| {
            let d = PathBuf::from(d);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::File::create(d.join(format!("{case}.jsonl"))).unwrap()
        });
        Self { hash: Sha256::new(), dump }
    }
    fn f32s(&mut self, what: &str, step: usize, xs: &[f32]) {
        for x in xs {
            self.hash.update(x.to_bits().to_le_bytes());
        }
        if let Some(f) = &mut self.dump {
            writeln!(
                f,
                "{{\"step\":{step},\"what\":\"{what}\",\"bits\":{:?}}}",
                xs.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            )
            .unwrap();
        }
    }
    fn u8s(&mut self, what: &str, step: usize, xs: &[u8]) {
        self.hash.update(xs);
        if let Some(f) = &mut self.dump {
            writeln!(f, "{{\"step\":{step},\"what\":\"{what}\",\"values\":{xs:?}}}").unwrap();
        }
    }
    fn finish(self) -> String {
        self.hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// 200 steps of random actions in `c`'s environment; the digest of everything it wrote.
fn env_trace(case: &str, c: &TrainConfig) -> String {
    let mut env = skillmimic_env::registry::make(&c.env).unwrap_or_else(|e| panic!("{case}: {e}"));
    let spec = env.spec().clone();
    let n = env.num_envs();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut rec = Recorder::new(case);
    env.reset_all(Some(3));
    rec.f32s("obs", 0, &env.buffers().obs);
    let mut actions = vec![0.0f32; n * spec.act_dim()];
    for step in 1..=STEPS {
        match spec.action_space {
            ActionSpace::Box { .. } => {
                actions.iter_mut().for_each(|a| *a = rng.random_range(-1.0f32..=1.0))
            }
            ActionSpace::Discrete { n: k } => {
                actions.iter_mut().for_each(|a| *a = rng.random_range(0..k) as f32)
            }
        }
        env.step(&actions).unwrap_or_else(|e| panic!("{case} step {step}: {e}"));
        let b = env.buffers();
        rec.f32s("obs", step, &b.obs);
        rec.f32s("reward", step, &b.reward);
        rec.f32s("terms", step, &b.terms);
        rec.f32s("metrics", step, &b.metrics);
        rec.f32s("info", step, &b.info);
        rec.u8s("terminated", step, &b.terminated);
        rec.u8s("truncated", step, &b.truncated);
        rec.u8s("unstable", step, &b.unstable);
        env.reset_done();
        rec.f32s("obs_after_reset", step, &env.buffers().obs);
    }
    rec.finish()
}

/// Two PPO iterations; the digest of the checkpoint's tensors and the learning statistics.
fn train_trace(case: &str, c: TrainConfig) -> String {
    let out = c.run.out_dir.clone();
    let mut t = Trainer::new(c, None).unwrap_or_else(|e| panic!("{case}: {e}"));
    let mut rec = Recorder::new(case);
    for it in 1..=2 {
        let s = t.iteration().unwrap_or_else(|e| panic!("{case} iteration {it}: {e}"));
        let mut row = vec![
            s.mean_reward,
            s.episode_length,
            s.episode_return,
            s.early_terminations,
            s.actor_loss,
            s.critic_loss,
            s.bounds_loss,
            s.clip_frac,
            s.approx_kl,
            s.value_mean,
            s.disc_loss,
            s.disc_ref,
            s.disc_sim,
        ];
        row.extend(s.reward_terms.iter().map(|(_, v)| *v));
        rec.f32s("stats", it, &row.iter().map(|&x| x as f32).collect::<Vec<_>>());
        rec.hash.update(row.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect::<Vec<_>>());
    }
    let path = out.join("trace.safetensors");
    t.save(&path).unwrap();
    let f = skillmimic_core::tensorfile::TensorFile::open(&path).unwrap();
    let mut names = f.names();
    names.sort();
    // the exact-resume state (`resume.*`: the environments' and streams' state) is checked by
    // tests/exact_resume.rs; the digest covers what training learned
    for name in names.into_iter().filter(|n| !n.starts_with("resume.")) {
        rec.hash.update(name.as_bytes());
        let shape: Vec<Option<usize>> = f.shape(&name).unwrap().into_iter().map(Some).collect();
        if let Ok((_, v)) = f.f32(&name, &shape) {
            rec.f32s(&name, 0, &v);
        } else if let Ok((_, v)) = f.f64(&name, &shape) {
            rec.hash.update(v.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect::<Vec<_>>());
        } else if let Ok((_, v)) = f.i64(&name, &shape) {
            rec.hash.update(v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<_>>());
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    rec.finish()
}

fn all_cases() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for e in TASKS {
        let c = config(e.name, e.name);
        out.insert(format!("env/{}", e.name), env_trace(&format!("env-{}", e.name), &c));
    }
    out.insert("env/imitation+v2".into(), env_trace("env-imitation-v2", &v2_config("env-v2")));
    let families = [
        ("imitation", "gaussian_mlp"),
        ("heading", "categorical_mlp"),
        ("tracking", "modular_attention"),
        ("hsi_follow", "token_transformer"),
        ("hsi_multi", "token_transformer"),
        ("hlc_multi", "token_transformer_categorical"),
    ];
    for (task, family) in families {
        let mut c = config(task, &format!("train-{task}"));
        c.ppo.policy = family.into();
        out.insert(
            format!("train/{task}/{family}"),
            train_trace(&format!("train-{task}-{family}"), c),
        );
    }
    let mut c = v2_config("train-v2");
    c.ppo.policy = "gaussian_mlp".into();
    out.insert("train/imitation+v2/gaussian_mlp".into(), train_trace("train-imitation-v2", c));
    let mut c = config("imitation", "train-amp");
    c.ppo.amp.enabled = true;
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 16;
    c.ppo.amp.buffer = 64;
    out.insert("train/imitation+amp/gaussian_mlp".into(), train_trace("train-imitation-amp", c));
    out
}

/// The class of machine whose learner results a digest holds: the matrix kernels (gemm's runtime
/// dispatch) take other instruction sets, and so round differently, with and without AVX-512.
/// The physics does not depend on it.
fn machine_class() -> String {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        return "x86_64-avx512f".into();
    }
    std::env::consts::ARCH.into()
}

/// The class `traces.json` was recorded on; other classes keep the `train/` digests that differ
/// from it in `traces-by-class.json`.
const BASE_CLASS: &str = "x86_64-avx512f";

fn by_class_path() -> PathBuf {
    fixture_path().with_file_name("traces-by-class.json")
}

type ByClass = BTreeMap<String, BTreeMap<String, String>>;

#[test]
fn every_task_and_family_reproduces_its_recorded_trace() {
    let got = all_cases();
    let path = fixture_path();
    let class = machine_class();
    let read =
        |p: &PathBuf| std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut by_class: ByClass = if by_class_path().exists() {
        serde_json::from_str(&read(&by_class_path())).unwrap()
    } else {
        ByClass::new()
    };
    if std::env::var_os("SKILLMIMIC_UPDATE_TRACES").is_some() {
        if class == BASE_CLASS {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, serde_json::to_string_pretty(&got).unwrap() + "\n").unwrap();
            return;
        }
        // another class: only the learner's digests may differ from the base class's
        let base: BTreeMap<String, String> = serde_json::from_str(&read(&path)).unwrap();
        let mut own = BTreeMap::new();
        for (case, d) in &got {
            if base.get(case) != Some(d) {
                assert!(case.starts_with("train/"), "{case}: the physics differs on {class}");
                own.insert(case.clone(), d.clone());
            }
        }
        by_class.insert(class, own);
        std::fs::write(by_class_path(), serde_json::to_string_pretty(&by_class).unwrap() + "\n")
            .unwrap();
        return;
    }
    let mut want: BTreeMap<String, String> = serde_json::from_str(&read(&path)).unwrap();
    let mut unchecked = false;
    if class != BASE_CLASS {
        match by_class.remove(&class) {
            Some(own) => want.extend(own),
            None => {
                // no digests of this class: the learner's cases are run, not compared
                println!(
                    "machine class {class} has no recorded learner digests: the train/ cases ran \
                        but are not compared (SKILLMIMIC_UPDATE_TRACES=1 records them)"
                );
                want.retain(|k, _| !k.starts_with("train/"));
                unchecked = true;
            }
        }
    }
    let mut diff = Vec::new();
    for (case, d) in &want {
        match got.get(case) {
            Some(g) if g == d => {}
            Some(_) => diff.push(format!("{case}: digest differs")),
            None => diff.push(format!("{case}: no longer recorded")),
        }
    }
    let new =
        got.keys().filter(|k| !want.contains_key(*k) && (!unchecked || !k.starts_with("train/")));
    for case in new {
        diff.push(format!("{case}: new case without a recorded digest"));
    }
    assert!(
        diff.is_empty(),
        "traces differ from {} on machine class {class} (SKILLMIMIC_TRACE_DUMP=<dir> writes the \
            rows):\n{}",
        path.display(),
        diff.join("\n")
    );
}
