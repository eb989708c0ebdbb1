//! PHC's and ModSkill's tracking evaluation (`tracking_eval`): every motion played once, the
//! success rate over motions, metrics pooled over the steps of all motions and of the successful
//! ones. Known answers: a policy whose PD targets hold the zero pose follows the two standing
//! demo clips within 0.5 m but not a copy of one lifted 1 m into the air (2 of 3 succeed).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::tracking_eval::{MotionResult, evaluate_each_motion, evaluate_motion};
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
    let steps: usize = rows.iter().map(|r| r.steps).sum();
    rows[0]
        .metrics
        .keys()
        .map(|k| {
            let s: f64 = rows.iter().map(|r| r.metrics[k] * r.steps as f64).sum();
            (k.clone(), s / steps as f64)
        })
        .collect()
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
    // pooling: step-weighted means of the rows, all and successful ones
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
