//! SkillMimic-V2 end to end: pre-train the history encoder on clips (the prediction loss falls
//! well below its start), save and reload it (identical embeddings, equal to a hand-written
//! forward of the saved tensors), train a tiny policy with the
//! full V2 stack (obs 905) and evaluate SR / TSR / εNSR / NR.

use std::sync::Arc;

use skillmimic_core::shared_data::{shared_dir_or_skip, workspace_root};
use skillmimic_env::v2::history::{FEATURE_DIM, HistoryEncoder, reference_features};
use skillmimic_env::{EnvConfig, load_motion_library};
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::eval::{V2EvalConfig, evaluate_v2};
use skillmimic_learn::history_pretrain::{PretrainConfig, PretrainData, pretrain};
use skillmimic_learn::trainer::Trainer;
use skillmimic_nn::history_reference::torch_reference_embedding;
use skillmimic_sim::Scene;

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("sm-v2-{}-{name}", std::process::id()))
}

fn pretrain_on(
    paths: &[std::path::PathBuf],
    epochs: usize,
) -> (HistoryEncoder, skillmimic_learn::history_pretrain::PretrainReport) {
    let lib = load_motion_library(paths).unwrap();
    let scene = Arc::new(
        Scene::new(skillmimic_env::registry::scene_options(&EnvConfig::default()).unwrap())
            .unwrap(),
    );
    let features = reference_features(scene, &lib).unwrap();
    let labels = (0..lib.len()).map(|c| lib.get(c).clip.skill).collect();
    let data = PretrainData::new(features, labels);
    let cfg = PretrainConfig { epochs, ..Default::default() };
    pretrain(&data, &cfg, |e, l, lr| println!("epoch {e}: loss {l:.6} lr {lr:.1e}")).unwrap()
}

#[test]
fn pretraining_lowers_the_prediction_loss_and_the_encoder_round_trips() {
    let (enc, rep) = pretrain_on(&[workspace_root().join("motions")], 8);
    println!(
        "demo clips: {} samples, next-state MSE {:.5} -> {:.5}, epoch loss {:.5} -> {:.5}",
        rep.samples,
        rep.initial_prediction_mse,
        rep.final_prediction_mse,
        rep.first_epoch_loss,
        rep.last_epoch_loss
    );
    assert!(rep.final_prediction_mse < 0.5 * rep.initial_prediction_mse, "{rep:?}");
    assert!(rep.last_epoch_loss < rep.first_epoch_loss);
    let path = tmp("enc.safetensors");
    enc.save(&path, &Default::default()).unwrap();
    let back = HistoryEncoder::load(&path).unwrap();
    assert_eq!(back, enc);
    let window: Vec<f32> = (0..60 * FEATURE_DIM).map(|i| ((i % 97) as f32 - 48.0) * 0.01).collect();
    let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
    enc.embed(&window, &mut a);
    back.embed(&window, &mut b);
    assert_eq!(a, b, "the reloaded encoder gives the same embedding");
    // the pre-trained weights compute what the PyTorch module would: a forward written out from
    // the saved tensors (independent of the encoder's own passes)
    let want = torch_reference_embedding(&back, &window);
    for (k, (&x, &y)) in a.iter().zip(&want).enumerate() {
        assert!((x - y).abs() <= 1e-4 * (1.0 + y.abs()), "embedding {k}: {x} vs hand-written {y}");
    }
    assert!(want.iter().any(|y| y.abs() > 1e-3), "a non-trivial embedding {want:?}");
    // a file that is not an encoder is refused with its name
    let bad = tmp("not_enc.safetensors");
    skillmimic_core::tensorfile::write_atomic(&bad, &[], &Default::default()).unwrap();
    let e = HistoryEncoder::load(&bad).unwrap_err().to_string();
    assert!(e.contains("not_enc.safetensors") && e.contains("format"), "{e}");
    let _ = std::fs::remove_file(path);
    let _ = std::fs::remove_file(bad);
}

#[test]
fn full_v2_stack_trains_and_evaluates() {
    let enc_path = tmp("stack_enc.safetensors");
    skillmimic_env::v2::history::random_encoder(60, 3, 5)
        .save(&enc_path, &Default::default())
        .unwrap();
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.env.v2.history.enabled = true;
    c.env.v2.history.encoder = enc_path.clone();
    c.env.v2.stf.enabled = true;
    c.env.v2.stg.enabled = true;
    c.env.v2.ats.enabled = true;
    c.env.v2.ats.update_interval = 8;
    c.run.iterations = 2;
    c.run.out_dir = tmp("stack_run");
    let mut t = Trainer::new(c.clone(), None).unwrap();
    assert_eq!(t.env.obs_dim(), 905);
    let last = skillmimic_learn::runner::train_loop(&mut t, |s| {
        assert!(s.mean_reward.is_finite() && s.critic_loss.is_finite())
    })
    .unwrap();
    let ck = skillmimic_learn::checkpoint::load(&last, Some((905, 156))).unwrap();
    assert_eq!(ck.policy.obs_dim(), 905);
    let lib = t
        .env
        .as_any()
        .downcast_ref::<skillmimic_env::SkillEnv>()
        .expect("imitation task")
        .library()
        .clone();
    let vcfg = V2EvalConfig { episodes: 2, horizon: 20, num_envs: 2, ..Default::default() };
    let rep = evaluate_v2(&t.policy, &c.env, &lib, &vcfg, 0).unwrap();
    // the demo skills (50, 51) have no success rule: NR only
    assert_eq!(rep.skills_without_rule, vec![50, 51]);
    assert!(rep.nr.values().all(|v| v.is_finite() && *v >= 0.0));
    let _ = std::fs::remove_file(enc_path);
}

#[test]
fn v2_metrics_on_two_real_skills() {
    let Some(shared) = shared_dir_or_skip("V2 metrics on real clips") else { return };
    let clips = [
        shared.join("data/ballplay_m/run/013_018pickle_run_3.pt"),
        shared.join("data/ballplay_m/layup/031_015pickle_layup_001_001.pt"),
    ];
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = clips.to_vec();
    c.env.num_envs = 8;
    c.env.threads = 2;
    c.env.v2.stf.enabled = true;
    c.run.iterations = 1;
    c.run.out_dir = tmp("real_run");
    let mut t = Trainer::new(c.clone(), None).unwrap();
    skillmimic_learn::runner::train_loop(&mut t, |_| {}).unwrap();
    let lib = t
        .env
        .as_any()
        .downcast_ref::<skillmimic_env::SkillEnv>()
        .expect("imitation task")
        .library()
        .clone();
    let vcfg = V2EvalConfig { episodes: 2, horizon: 30, num_envs: 2, ..Default::default() };
    let rep = evaluate_v2(&t.policy, &c.env, &lib, &vcfg, 0).unwrap();
    println!("{}", serde_json::to_string(&rep).unwrap());
    assert_eq!(rep.sr.keys().collect::<Vec<_>>(), vec!["013", "031"]);
    assert_eq!(rep.eps_nsr.len(), 2);
    assert_eq!(rep.tsr.keys().collect::<Vec<_>>(), vec!["013->031", "031->013"]);
    for v in rep.sr.values().chain(rep.tsr.values()).chain(rep.eps_nsr.values()) {
        assert!((0.0..=1.0).contains(v));
    }
    assert!(rep.nr.values().all(|v| v.is_finite() && *v > 0.0));
    // every case's trials are distinct trajectories: SR and TSR by their sampled actions, εNSR
    // by its perturbed starts
    assert_eq!(rep.distinct.len(), 6, "{:?}", rep.distinct);
    assert!(rep.distinct.values().all(|&n| n == 2), "{:?}", rep.distinct);
    // with the mean action, the episodes from frame 2 are copies of one trajectory: seen as one
    let copies = V2EvalConfig { sampled_actions: false, ..vcfg };
    let rep = evaluate_v2(&t.policy, &c.env, &lib, &copies, 0).unwrap();
    assert_eq!(rep.distinct["sr/013"], 1, "{:?}", rep.distinct);
    assert_eq!(rep.distinct["eps_nsr/013"], 2, "{:?}", rep.distinct);
}
