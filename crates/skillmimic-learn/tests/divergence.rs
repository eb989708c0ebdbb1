//! A run that diverges (`ppo.lr` = 1e3, still a valid setting) stops with an error naming the
//! iteration and the last good checkpoint, and every checkpoint it left loads and is finite.

use std::path::{Path, PathBuf};

use skillmimic_core::shared_data::workspace_root;
use skillmimic_learn::checkpoint;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::runner::train_loop;
use skillmimic_learn::trainer::Trainer;

fn tiny(tag: &str, iterations: usize, lr: f64) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.ppo.lr = lr;
    c.run.iterations = iterations;
    c.run.save_every = 1;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-diverge-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
    c
}

/// Every `.safetensors` file below `dir`.
fn checkpoints(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(checkpoints(&p));
        } else if p.extension().is_some_and(|x| x == "safetensors") {
            v.push(p);
        }
    }
    v
}

/// Every checkpoint of the folder loads (the loader refuses non-finite tensors) and its policy
/// and optimiser state are finite; no temporary file is left.
fn assert_folder_clean(out: &Path) {
    for p in checkpoints(out) {
        let c = checkpoint::load(&p, None).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let finite = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
        assert!(
            c.policy.actor.params().into_iter().chain(c.policy.critic.params()).all(finite),
            "{}",
            p.display()
        );
        let adam = c.adam.unwrap();
        assert!(adam.m.iter().chain(&adam.v).all(|x| finite(x)), "{}", p.display());
        assert!(
            c.policy.value_norm.var.iter().chain(&c.policy.obs_norm.var).all(|x| x.is_finite()),
            "{}",
            p.display()
        );
    }
    let names: Vec<String> = std::fs::read_dir(out.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
}

/// The iteration named by a divergence error.
fn failed_iteration(msg: &str) -> u64 {
    let rest = msg
        .split("training diverged in iteration ")
        .nth(1)
        .unwrap_or_else(|| panic!("no iteration in: {msg}"));
    rest.split(':').next().unwrap().parse().unwrap()
}

#[test]
fn huge_learning_rate_stops_before_a_non_finite_checkpoint() {
    let cfg = tiny("fresh", 10, 1e3);
    let out = cfg.run.out_dir.clone();
    let mut t = Trainer::new(cfg, None).unwrap();
    let err = train_loop(&mut t, |_| {}).expect_err("lr = 1e3 must not train to the end");
    let msg = err.to_string();
    println!("{msg}");
    assert!(matches!(err, skillmimic_learn::LearnError::Diverged(_)), "{err:?}");
    let it = failed_iteration(&msg);
    assert!(it <= 10, "{msg}");
    if it == 1 {
        assert!(msg.contains("no checkpoint of this run was written"), "{msg}");
    } else {
        let want = out.join(format!("checkpoints/iter_{:06}.safetensors", it - 1));
        assert!(msg.contains(&format!("last good checkpoint: {}", want.display())), "{msg}");
    }
    assert!(!out.join(format!("checkpoints/iter_{it:06}.safetensors")).exists());
    assert_folder_clean(&out);
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn divergence_after_a_resume_names_the_checkpoint_it_resumed_from() {
    // two sound iterations, then the same run resumed with lr = 1e3
    let cfg = tiny("resumed", 2, 3e-5);
    let out = cfg.run.out_dir.clone();
    let mut t = Trainer::new(cfg.clone(), None).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
    let resume = out.join("checkpoints/iter_000002.safetensors");
    let mut c2 = cfg;
    c2.run.iterations = 12;
    c2.ppo.lr = 1e3;
    let mut t = Trainer::new(c2, Some(&resume)).unwrap();
    let msg =
        train_loop(&mut t, |_| {}).expect_err("lr = 1e3 must not train to the end").to_string();
    println!("{msg}");
    let it = failed_iteration(&msg);
    assert!((3..=12).contains(&it), "{msg}");
    let want = if it == 3 {
        resume
    } else {
        out.join(format!("checkpoints/iter_{:06}.safetensors", it - 1))
    };
    assert!(msg.contains(&format!("last good checkpoint: {}", want.display())), "{msg}");
    assert_eq!(checkpoint::load(&want, None).unwrap().progress.iteration, it - 1);
    // the log ends at the last finished iteration
    let log = std::fs::read_to_string(out.join("log.jsonl")).unwrap();
    assert_eq!(log.lines().count() as u64, it - 1);
    assert_folder_clean(&out);
    std::fs::remove_dir_all(&out).ok();
}
