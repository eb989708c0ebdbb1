//! PHC's and ModSkill's tracking evaluation (`tracking_eval`): every motion played once, the
//! success rate over motions, metrics pooled over the steps of all motions and of the successful
//! ones. Known answers: a policy whose PD targets hold the zero pose follows the two standing
//! demo clips within 0.5 m but not a copy of one lifted 1 m into the air (2 of 3 succeed).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_learn::tracking_eval::{
    MotionResult, evaluate_each_motion, evaluate_motion, one_motion_config,
};
use skillmimic_learn::trainer::Trainer;
use skillmimic_motion::Clip;

/// The demo clips and a lifted copy of the first in a fresh folder; returns (folder, files).
fn clips(root: &Path) -> Vec<PathBuf> {
    std::fs::create_dir_all(root).unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&demo)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let to = root.join(p.file_name().unwrap());
            Clip::load(&p).unwrap().save(&to).unwrap();
            to
        })
        .collect();
    files.sort();
    let mut lifted = Clip::load(&files[0]).unwrap();
    lifted.name = "052_lifted".into();
    lifted.root_pos.iter_mut().skip(2).step_by(3).for_each(|z| *z += 1.0);
    skillmimic_motion::generate::refresh_body_pos(&mut lifted);
    let to = root.join("052_lifted.safetensors");
    lifted.save(&to).unwrap();
    files.push(to);
    files.sort();
    files
}

fn pooled(rows: &[&MotionResult]) -> BTreeMap<String, f64> {
    rows[0]
        .metrics
        .keys()
        .map(|k| {
            let n: usize = rows.iter().map(|r| r.values[k]).sum();
            let s: f64 = rows.iter().map(|r| r.metrics[k] * r.values[k] as f64).sum();
            (k.clone(), s / n as f64)
        })
        .collect()
}

/// The per-step metric rows of one deterministic episode of `file`, stepped here by hand.
fn per_step(policy: &Policy, cfg: &TrainConfig, file: &Path) -> Vec<Vec<f32>> {
    let mut env = skillmimic_env::registry::make(&one_motion_config(cfg, file)).unwrap();
    env.reset_all(Some(0));
    let (mut buf, mut out, mut v) =
        (InferenceBuffers::default(), vec![0.0; policy.actor_outputs()], vec![0.0]);
    let mut a = vec![0.0; env.act_dim()];
    let mut rows = Vec::new();
    loop {
        policy.infer(&env.buffers().obs, 1, &mut buf, &mut out, &mut v, 1);
        policy.mode(&out, 1, &mut a);
        env.step(&a).unwrap();
        let b = env.buffers();
        rows.push(b.metrics.clone());
        if b.terminated[0] != 0 || b.truncated[0] != 0 {
            return rows;
        }
    }
}

fn close(a: &BTreeMap<String, f64>, b: &BTreeMap<String, f64>) {
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (k, v) in a {
        assert!((v - b[k]).abs() <= 1e-9 * v.abs().max(1.0), "{k}: {v} vs {}", b[k]);
    }
}

#[test]
fn every_motion_once_with_success_over_motions_and_pooled_metrics() {
    let root = std::env::temp_dir().join(format!("sm-tracking-eval-{}", std::process::id()));
    let files = clips(&root.join("clips"));
    let mut cfg = TrainConfig::preset("tiny").unwrap();
    cfg.env.task = "tracking".into();
    cfg.env.motion = vec![root.join("clips")];
    cfg.env.num_envs = 8;
    cfg.env.threads = 1;
    cfg.ppo.hidden = vec![32];
    cfg.run.out_dir = root.join("run");
    let mut t = Trainer::new(cfg.clone(), None).unwrap();
    let actor = t.policy.actor.as_mlp_mut().unwrap();
    let last = actor.num_layers() - 1;
    actor.weights[last].fill(0.0);
    actor.biases[last].fill(0.0);

    let r = evaluate_each_motion(&t.policy, &cfg).unwrap();
    for m in &r.per_motion {
        println!("{} {} steps success {} {:?}", m.file.display(), m.steps, m.success, m.metrics);
    }
    // one row per motion file, each file once
    assert_eq!(r.per_motion.iter().map(|m| m.file.clone()).collect::<Vec<_>>(), files);
    assert_eq!((r.motions, r.successes), (3, 2));
    assert!((r.success_rate - 2.0 / 3.0).abs() < 1e-12);
    let lifted = r.per_motion.iter().find(|m| m.file.ends_with("052_lifted.safetensors")).unwrap();
    assert!(!lifted.success);
    // a success plays the whole clip: frames − 1 steps
    for m in r.per_motion.iter().filter(|m| m.success) {
        assert_eq!(m.steps, Clip::load(&m.file).unwrap().num_frames - 1, "{}", m.file.display());
    }
    // the failed motion ends early, at the 0.5 m threshold (after the first step's grace)
    assert!(lifted.steps < Clip::load(&lifted.file).unwrap().num_frames - 1);
    assert!(r.per_motion.iter().all(|m| m.success || m.metrics["g_mpjpe_mm"] > 150.0));
    assert!(r.per_motion.iter().all(|m| !m.metrics.contains_key("success")), "a flag, not a mean");
    // the released bookkeeping: positions after steps 1..N give N position errors, N − 1
    // velocity errors (from step 2) and N − 2 acceleration errors (from step 3)
    for m in &r.per_motion {
        let rows = per_step(&t.policy, &cfg, &m.file);
        assert_eq!(rows.len(), m.steps);
        for (k, name) in ["g_mpjpe_mm", "mpjpe_mm", "vel_err_mm", "acc_err_mm"].iter().enumerate() {
            let skip = [0, 0, 1, 2][k];
            let vals: Vec<f64> = rows[skip..].iter().map(|row| row[k] as f64).collect();
            assert_eq!(m.values[*name], m.steps - skip, "{name}");
            let want = vals.iter().sum::<f64>() / vals.len() as f64;
            assert!(
                (m.metrics[*name] - want).abs() < 1e-9,
                "{name}: {} vs {want}",
                m.metrics[*name]
            );
        }
    }
    // pooling: value-weighted means of the rows, all and successful ones
    let all: Vec<&MotionResult> = r.per_motion.iter().collect();
    close(&r.metrics_all, &pooled(&all));
    let good: Vec<&MotionResult> = r.per_motion.iter().filter(|m| m.success).collect();
    close(&r.metrics_successful, &pooled(&good));
    assert!(r.metrics_successful["g_mpjpe_mm"] < r.metrics_all["g_mpjpe_mm"]);
    // a row is the motion alone (no dependence on the other motions or on the parallel order)
    let alone = evaluate_motion(&t.policy, &cfg, &files[1]).unwrap();
    assert_eq!(alone.metrics, r.per_motion[1].metrics);
    let again = evaluate_each_motion(&t.policy, &cfg).unwrap();
    assert_eq!(serde_json::to_string(&again).unwrap(), serde_json::to_string(&r).unwrap());

    // another task, or the built-in demo (no files), is refused with the field named
    let mut bad = cfg.clone();
    bad.env.task = "imitation".into();
    let e = evaluate_each_motion(&t.policy, &bad).unwrap_err().to_string();
    assert!(e.contains("tracking") && e.contains("imitation"), "{e}");
    let mut demo = cfg.clone();
    demo.env.motion = vec![skillmimic_env::BUILTIN_DEMO.into()];
    let e = evaluate_each_motion(&t.policy, &demo).unwrap_err().to_string();
    assert!(e.contains("env.motion"), "{e}");
    std::fs::remove_dir_all(&root).ok();
}
