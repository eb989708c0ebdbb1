//! Active skill learning on the tracking task: a clip the policy fails on (a copy of a demo clip
//! lifted 1 m into the air) is handed to the generator, the valid generated clip joins the
//! library, the invalid one is rejected with the filter's reason, and the rebuilt environment
//! samples the failed clip more often.

use skillmimic_learn::amp_reward::AmpReward;
use std::sync::{Arc, Mutex};

use rand::{RngCore, SeedableRng};
use skillmimic_env::tasks::tracking::Tracking;
use skillmimic_env::tasks::tracking::config::TrackingConfig;
use skillmimic_env::vec_env::VecEnv;
use skillmimic_learn::active::{ActiveConfig, apply, round};
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::trainer::Trainer;
use skillmimic_motion::Clip;
use skillmimic_motion::generate::{GenError, Generator, mirror};

/// Returns the mirror image (valid) and a copy sunk 1.5 m into the floor (invalid).
struct Probe(Arc<Mutex<Vec<String>>>);

impl Generator for Probe {
    fn name(&self) -> String {
        "probe".into()
    }
    fn generate(
        &mut self,
        failed: &Clip,
        _library: &[Clip],
        _rng: &mut dyn RngCore,
    ) -> Result<Vec<Clip>, GenError> {
        self.0.lock().unwrap().push(failed.name.clone());
        let mut sunk = failed.clone();
        sunk.name = format!("{}~sunk", failed.name);
        sunk.body_pos.iter_mut().skip(2).step_by(3).for_each(|z| *z -= 1.5);
        Ok(vec![mirror(failed), sunk])
    }
}

fn probabilities(t: &Trainer) -> Vec<f64> {
    t.env.as_any().downcast_ref::<VecEnv<Tracking>>().unwrap().task().clip_probabilities()
}

/// The demo clips and a copy of the first lifted 1 m into the air (`052_lifted`, the last in
/// library order) under a fresh folder, and a tracking trainer over them whose policy's PD targets
/// hold the zero pose: it follows the standing demo clips within 0.5 m but cannot follow the
/// floating one. Returns (folder, trainer).
fn lifted_setup(tag: &str) -> (std::path::PathBuf, Trainer) {
    let root = std::env::temp_dir().join(format!("sm-active-{tag}-{}", std::process::id()));
    let clips = root.join("clips");
    std::fs::create_dir_all(&clips).unwrap();
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions");
    let mut names = Vec::new();
    for e in std::fs::read_dir(&demo).unwrap() {
        let p = e.unwrap().path();
        let c = Clip::load(&p).unwrap();
        c.save(&clips.join(p.file_name().unwrap())).unwrap();
        names.push(c.name);
    }
    names.sort();
    let mut lifted = Clip::load(&clips.join(format!("{}.safetensors", names[0]))).unwrap();
    lifted.name = "052_lifted".into();
    lifted.root_pos.iter_mut().skip(2).step_by(3).for_each(|z| *z += 1.0);
    skillmimic_motion::generate::refresh_body_pos(&mut lifted);
    lifted.save(&clips.join("052_lifted.safetensors")).unwrap();

    let mut cfg = TrainConfig::preset("tiny").unwrap();
    cfg.env.task = "tracking".into();
    cfg.env.motion = vec![clips.clone()];
    cfg.env.num_envs = 8;
    cfg.env.threads = 1;
    cfg.ppo.hidden = vec![32];
    cfg.run.out_dir = root.join("run");
    let mut t = Trainer::new(cfg, None).unwrap();
    let actor = t.policy.actor.as_mlp_mut().unwrap();
    let last = actor.num_layers() - 1;
    actor.weights[last].fill(0.0);
    actor.biases[last].fill(0.0);
    (root, t)
}

#[test]
fn a_failed_clip_gets_generated_clips_and_more_weight() {
    let (root, mut t) = lifted_setup("generative");
    let before = probabilities(&t);
    let seen = Arc::new(Mutex::new(Vec::new()));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let report = round(
        &t.policy,
        &t.cfg,
        &mut Probe(seen.clone()),
        &ActiveConfig { failure_weight: 2.0, ..ActiveConfig::default() },
        None,
        &mut rng,
    )
    .unwrap();
    println!("{report:?}");
    assert_eq!(report.evaluated, 3);
    assert_eq!(report.failed, vec!["052_lifted".to_string()]);
    assert_eq!(*seen.lock().unwrap(), vec!["052_lifted".to_string()]);
    assert_eq!(report.accepted.len(), 1);
    assert!(report.accepted[0].1.exists());
    assert_eq!(report.rejected.len(), 1);
    assert!(report.rejected[0].1.contains("below the floor"), "{:?}", report.rejected);
    assert_eq!(report.clip_weights.get("052_lifted"), Some(&2.0));
    apply(&mut t, &report).unwrap();
    let after = probabilities(&t);
    assert_eq!(after.len(), 4, "the generated clip joined the library");
    // library order: sorted paths, the lifted clip is the last file of the first folder
    let lifted_at = 2;
    println!("probability of the failed clip: {:.3} -> {:.3}", before[lifted_at], after[lifted_at]);
    assert!(after[lifted_at] > before[lifted_at]);
    assert!(t.config_toml().contains("052_lifted"));
    t.iteration().unwrap();
    std::fs::remove_dir_all(&root).ok();
}

/// The released `auto_pmcp` modes: `hard` draws only this round's failed clips, `soft` weighs
/// each clip by the rounds it failed (earlier rounds from `active.jsonl`); neither generates.
#[test]
fn the_released_hard_and_soft_modes_reweight_without_generating() {
    use skillmimic_learn::active::{ActiveMode, released_weights};
    let (root, mut t) = lifted_setup("modes");
    let names: Vec<String> = ["050_a", "051_b", "052_c"].map(String::from).to_vec();
    let earlier = [("050_a".to_string(), 2)].into_iter().collect();
    let w = |m, failed: &[&str]| {
        let failed: Vec<String> = failed.iter().map(|s| s.to_string()).collect();
        released_weights(m, &names, &failed, &earlier).into_values().collect::<Vec<f64>>()
    };
    assert_eq!(w(ActiveMode::Hard, &["052_c"]), [0.0, 0.0, 1.0]);
    assert_eq!(w(ActiveMode::Hard, &["050_a", "052_c"]), [1.0, 0.0, 1.0]);
    assert_eq!(w(ActiveMode::Soft, &["052_c"]), [2.0, 0.0, 1.0]);
    assert_eq!(w(ActiveMode::Soft, &["050_a"]), [3.0, 0.0, 0.0]);
    assert!(w(ActiveMode::Hard, &[]).is_empty() && w(ActiveMode::Soft, &[]).is_empty(), "all 1");

    // on the lifted set: only the lifted clip fails; a probe that panics shows nothing generates
    struct NoGenerator;
    impl Generator for NoGenerator {
        fn name(&self) -> String {
            "none".into()
        }
        fn generate(
            &mut self,
            _: &Clip,
            _: &[Clip],
            _: &mut dyn RngCore,
        ) -> Result<Vec<Clip>, GenError> {
            panic!("the hard and soft modes generate nothing")
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let hard = ActiveConfig { mode: ActiveMode::Hard, ..ActiveConfig::default() };
    let r = round(&t.policy, &t.cfg, &mut NoGenerator, &hard, None, &mut rng).unwrap();
    assert_eq!(r.failed, vec!["052_lifted".to_string()]);
    assert!(r.accepted.is_empty() && r.rejected.is_empty());
    apply(&mut t, &r).unwrap();
    assert_eq!(probabilities(&t), [0.0, 0.0, 1.0], "only the failed clip is drawn");
    t.iteration().unwrap();
    // soft: an earlier round in which the first demo clip failed twice is in active.jsonl
    let first = r.clip_weights.keys().next().unwrap().clone();
    let line = serde_json::json!({"iteration": 5, "report": {"failed": [first, first]}});
    std::fs::write(t.cfg.run.out_dir.join("active.jsonl"), format!("{line}\n")).unwrap();
    let soft = ActiveConfig { mode: ActiveMode::Soft, ..ActiveConfig::default() };
    let r = round(&t.policy, &t.cfg, &mut NoGenerator, &soft, None, &mut rng).unwrap();
    apply(&mut t, &r).unwrap();
    assert_eq!(probabilities(&t), [2.0 / 3.0, 0.0, 1.0 / 3.0]);
    // every weight 0 is refused naming the key
    let mut none = t.cfg.clone();
    none.env.table_mut::<TrackingConfig>().clip_weights =
        r.clip_weights.keys().map(|k| (k.clone(), 0.0)).collect();
    let err = Trainer::new(none, None).err().unwrap().to_string();
    assert!(err.contains("env.tracking.clip_weights"), "{err}");
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn training_runs_rounds_with_the_model_free_generator() {
    let root = std::env::temp_dir().join(format!("sm-active-run-{}", std::process::id()));
    let mut cfg = TrainConfig::preset("tiny").unwrap();
    cfg.env.task = "tracking".into();
    cfg.env.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    cfg.env.num_envs = 8;
    cfg.env.threads = 1;
    cfg.env.table_mut::<TrackingConfig>().success_distance = 0.02; // every clip fails: the generator is called for each
    cfg.ppo.hidden = vec![32];
    cfg.run.iterations = 2;
    cfg.run.active.enabled = true;
    cfg.run.active.every = 1;
    cfg.run.out_dir = root.clone();
    let mut t = Trainer::new(cfg.clone(), None).unwrap();
    skillmimic_learn::runner::train_loop(&mut t, |_| {}).unwrap();
    let log = std::fs::read_to_string(root.join("active.jsonl")).unwrap();
    let first: serde_json::Value = serde_json::from_str(log.lines().next().unwrap()).unwrap();
    println!("{first}");
    assert_eq!(log.lines().count(), 1, "one round after iteration 1 (none after the last)");
    assert_eq!(first["report"]["evaluated"], 2);
    assert!(
        first["report"]["accepted"].as_array().unwrap().len() >= 2,
        "mirror and time warp of each failed clip"
    );
    assert!(t.cfg.env.motion.contains(&root.join("generated")));
    // the task must be tracking
    let mut bad = cfg.clone();
    bad.env.task = "imitation".into();
    let err = Trainer::new(bad, None).err().unwrap().to_string();
    assert!(err.contains("run.active.enabled") && err.contains("tracking"), "{err}");
    std::fs::remove_dir_all(&root).ok();
}

/// The optional motion-prior filter (`run.active.disc_score_min`, the released code's rule): the
/// score is the mean sigmoid(D) over the clip's windows; a discriminator biased towards "fake"
/// rejects the valid generated clips with the score in the reason, one biased towards "real" keeps
/// them; an end-to-end run with the prior enabled applies it.
#[test]
fn the_discriminator_filter_scores_generated_clips() {
    use skillmimic_env::amp::{FEATURE_DIM, clip_features};
    let root = std::env::temp_dir().join(format!("sm-active-disc-{}", std::process::id()));
    let mut cfg = TrainConfig::preset("tiny").unwrap();
    cfg.env.task = "tracking".into();
    cfg.env.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    cfg.env.num_envs = 8;
    cfg.env.threads = 1;
    cfg.env.table_mut::<TrackingConfig>().success_distance = 0.02; // every clip fails
    cfg.ppo.hidden = vec![32];
    cfg.ppo.amp.enabled = true;
    cfg.ppo.amp.hidden = vec![16];
    cfg.run.out_dir = root.clone();
    let t = Trainer::new(cfg.clone(), None).unwrap();
    let mut disc = t.extension::<AmpReward>().unwrap().disc().clone();
    // the score against windows cut by hand from the posed clip's features
    let clip =
        Clip::load(&skillmimic_motion::library::find_clip_files(&cfg.env.motion[0]).unwrap()[0])
            .unwrap();
    let lib = skillmimic_motion::MotionLibrary::from_clips(vec![clip.clone()]).unwrap();
    let scene = std::sync::Arc::new(
        skillmimic_sim::Scene::new(skillmimic_env::registry::scene_options(&cfg.env).unwrap())
            .unwrap(),
    );
    let f = clip_features(scene, &lib).unwrap().remove(0);
    let k = cfg.ppo.amp.window;
    let mut want = 0.0;
    for end in k - 1..clip.num_frames {
        let x: Vec<f32> = f[(end + 1 - k) * FEATURE_DIM..(end + 1) * FEATURE_DIM].to_vec();
        let l = disc.logits(&x, 1)[0] as f64;
        want += 1.0 / (1.0 + (-l).exp());
    }
    want /= (clip.num_frames + 1 - k) as f64;
    let got = skillmimic_learn::active::disc_score(&mut disc, &clip, &cfg).unwrap();
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");

    let a = ActiveConfig { disc_score_min: 0.5, ..ActiveConfig::default() };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let last = disc.mlp.biases.len() - 1;
    disc.mlp.biases[last][0] = -50.0;
    let mut model_free = skillmimic_motion::generate::ModelFree::default();
    let fake = round(&t.policy, &t.cfg, &mut model_free, &a, Some(&mut disc), &mut rng).unwrap();
    assert!(fake.accepted.is_empty() && !fake.rejected.is_empty());
    assert!(
        fake.rejected.iter().all(|(_, why)| why.contains("motion-prior score")),
        "{:?}",
        fake.rejected
    );
    disc.mlp.biases[last][0] = 50.0;
    let real = round(&t.policy, &t.cfg, &mut model_free, &a, Some(&mut disc), &mut rng).unwrap();
    assert_eq!(
        real.accepted.len(),
        fake.rejected.len(),
        "the same clips pass a discriminator that calls everything real"
    );
    let err =
        round(&t.policy, &t.cfg, &mut model_free, &a, None, &mut rng).err().unwrap().to_string();
    assert!(err.contains("disc_score_min") && err.contains("ppo.amp.enabled"), "{err}");
    // configuration: the filter needs the prior
    let mut bad = cfg.clone();
    bad.run.active.enabled = true;
    bad.run.active.disc_score_min = 0.5;
    bad.ppo.amp.enabled = false;
    let err = Trainer::new(bad, None).err().unwrap().to_string();
    assert!(err.contains("run.active.disc_score_min"), "{err}");
    // end to end: a run with the prior and the filter
    let mut run = cfg.clone();
    run.run.iterations = 2;
    run.run.active.enabled = true;
    run.run.active.every = 1;
    run.run.active.disc_score_min = 0.5;
    let mut t = Trainer::new(run, None).unwrap();
    skillmimic_learn::runner::train_loop(&mut t, |_| {}).unwrap();
    let log = std::fs::read_to_string(root.join("active.jsonl")).unwrap();
    let first: serde_json::Value = serde_json::from_str(log.lines().next().unwrap()).unwrap();
    let n = first["report"]["accepted"].as_array().unwrap().len()
        + first["report"]["rejected"].as_array().unwrap().len();
    assert!(n >= 2, "{first}");
    std::fs::remove_dir_all(&root).ok();
}

/// Active learning stays in one process: a data-parallel run with it is refused at the start on
/// every rank (none left waiting).
#[test]
fn active_learning_is_refused_data_parallel_at_the_start() {
    use skillmimic_learn::collective::threads::ThreadGroup;
    let mut cfg = TrainConfig::preset("tiny").unwrap();
    cfg.env.task = "tracking".into();
    cfg.env.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    cfg.env.num_envs = 8;
    cfg.env.threads = 1;
    cfg.ppo.hidden = vec![32];
    cfg.run.active.enabled = true;
    cfg.run.out_dir = std::env::temp_dir().join(format!("sm-active-dp-{}", std::process::id()));
    let errs: Vec<String> = std::thread::scope(|s| {
        let hs: Vec<_> = ThreadGroup::new_group(2)
            .into_iter()
            .map(|g| {
                let c = cfg.clone();
                s.spawn(move || {
                    Trainer::with_collective(c, None, Box::new(g))
                        .err()
                        .map(|e| e.to_string())
                        .unwrap_or_default()
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(
        errs.iter().all(|e| e.contains("run.active.enabled") && e.contains("one process")),
        "{errs:?}"
    );
}
