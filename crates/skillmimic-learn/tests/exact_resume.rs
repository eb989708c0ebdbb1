//! A run resumed from a checkpoint continues exactly as if it had never stopped: for every task
//! family (imitation with and without the SkillMimic-V2 parts, the motion prior, a high-level
//! task, tracking, a TokenHSI task and the TokenHSI multi-task environment), four iterations in
//! one go and the same run stopped after two and resumed from its checkpoint write the same
//! `log.jsonl` rows (all but the timings) and byte-identical checkpoints. Also: a checkpoint
//! resumed with another environment configuration is refused naming the keys, or resumed with
//! fresh episodes where `run.fresh_episodes` asks for it; one without the saved state or with an
//! older layout of it (an older version's) resumes with fresh episodes. Active skill learning,
//! whose rounds change the library and its weights while the run trains, resumes exactly with the
//! original configuration.

mod common;
use common::{skill_policy, workspace_root};
use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_env::tasks::multi::config::MultiConfig;
use skillmimic_env::tasks::tracking::config::TrackingConfig;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::runner::train_loop;
use skillmimic_learn::trainer::Trainer;

fn out_dir(tag: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("sm-exact-resume-{tag}-{}", std::process::id()))
}

/// A tiny run of `task` (4 environments, 2 threads, horizon 8, 4 iterations, checkpoints every 2).
fn config(task: &str, character: &str, tag: &str) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.into();
    c.env.character = character.into();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 2;
    c.ppo.horizon = 8;
    c.ppo.minibatch = 16;
    c.ppo.mini_epochs = 2;
    c.ppo.hidden = vec![32];
    c.run.iterations = 4;
    c.run.save_every = 2;
    c.run.out_dir = out_dir(tag);
    c
}

/// The log rows without their timings (wall-clock seconds and rates).
fn rows(dir: &std::path::Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("log.jsonl")).unwrap();
    text.lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            let m = v.as_object_mut().unwrap();
            m.retain(|k, _| !(k.ends_with("_s") || k == "samples_per_s"));
            v
        })
        .collect()
}

/// Train `c` to its end through the runner's loop (from `resume` when given).
fn run(c: TrainConfig, resume: Option<&std::path::Path>) {
    let mut t = Trainer::new(c, resume).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
}

/// Train `c` in one go, then again stopped at iteration 2 and resumed from its checkpoint (same
/// folder, so the checkpoints' metadata agree too); both must agree bit for bit.
fn straight_and_resumed(c: TrainConfig) {
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    run(c.clone(), None);
    let (want_rows, want) = (rows(&dir), std::fs::read(dir.join("latest.safetensors")).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();

    let mut first = c.clone();
    first.run.iterations = 2;
    run(first, None);
    let mid = dir.join("checkpoints/iter_000002.safetensors");
    run(c.clone(), Some(&mid));
    let task = &c.env.task;
    let got_rows = rows(&dir);
    assert_eq!(got_rows.len(), 4, "{task}: {got_rows:?}");
    for (k, (a, b)) in want_rows.iter().zip(&got_rows).enumerate() {
        assert_eq!(a, b, "{task}: log row {} differs after the resume", k + 1);
    }
    let got = std::fs::read(dir.join("latest.safetensors")).unwrap();
    assert!(got == want, "{task}: the final checkpoint differs after the resume");
    // the saved state is part of the compared files: it is there and restores
    let f = skillmimic_core::tensorfile::TensorFile::open(&mid).unwrap();
    assert!(f.u8(skillmimic_learn::trainer::resume::TENSOR).unwrap().len() > 1000, "{task}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn imitation_resumes_exactly() {
    straight_and_resumed(config("imitation", "", "imitation"));
}

#[test]
fn imitation_with_the_v2_parts_resumes_exactly() {
    let mut c = config("imitation", "", "v2");
    let enc = out_dir("v2-encoder.safetensors");
    skillmimic_env::v2::history::random_encoder(60, 3, 5).save(&enc, &Default::default()).unwrap();
    c.env.v2.history.enabled = true;
    c.env.v2.history.encoder = enc.clone();
    c.env.v2.stf.enabled = true;
    c.env.v2.stg.enabled = true;
    c.env.v2.ats.enabled = true;
    c.env.v2.ats.update_interval = 5;
    straight_and_resumed(c);
    let _ = std::fs::remove_file(enc);
}

/// [`config`] of the imitation task with the motion prior on (discriminator [32], batch 16,
/// buffer 64).
fn with_prior(tag: &str) -> TrainConfig {
    let mut c = config("imitation", "", tag);
    c.ppo.amp.enabled = true;
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 16;
    c.ppo.amp.buffer = 64;
    c
}

#[test]
fn the_motion_prior_resumes_exactly() {
    straight_and_resumed(with_prior("amp"));
}

#[test]
fn a_high_level_task_resumes_exactly() {
    let mut c = config("heading", "", "heading");
    c.env.table_mut::<HlcConfig>().llc = skill_policy("exact-resume");
    c.ppo.policy = "categorical_mlp".into();
    straight_and_resumed(c);
}

#[test]
fn tracking_resumes_exactly() {
    straight_and_resumed(config("tracking", "smpl", "tracking"));
}

/// The released per-minibatch discriminator schedule with its per-frame normaliser: the replay
/// buffer (full after the first iteration, then the keep rule), its draws and the normaliser
/// resume exactly.
#[test]
fn the_motion_prior_resumes_exactly_with_the_released_schedule() {
    let mut c = with_prior("amp-mb");
    c.ppo.amp.batch = 8;
    c.ppo.amp.buffer = 24;
    c.ppo.amp.schedule = skillmimic_learn::config::AmpSchedule::PerMinibatch;
    c.ppo.amp.replay_keep = 0.5;
    c.ppo.amp.normalizer = skillmimic_learn::config::AmpNormalizer::PerFrame;
    straight_and_resumed(c);
}

#[test]
fn a_tokenhsi_task_resumes_exactly() {
    straight_and_resumed(config("hsi_sit", "", "sit"));
}

#[test]
fn the_tokenhsi_multi_task_environment_resumes_exactly() {
    let mut c = config("hsi_multi", "", "multi");
    c.env.table_mut::<MultiConfig>().tasks = vec!["hsi_follow".into(), "hsi_carry".into()];
    c.ppo.policy = "token_transformer".into();
    common::tiny_token(&mut c.ppo);
    straight_and_resumed(c);
}

#[test]
fn another_environment_configuration_is_refused_or_started_fresh() {
    let c = config("imitation", "", "refuse");
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    let mut first = c.clone();
    first.run.iterations = 2;
    let mut t = Trainer::new(first, None).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
    drop(t);
    let ck = dir.join("latest.safetensors");
    let mut other = c.clone();
    other.env.episode_length = c.env.episode_length + 7;
    let e = Trainer::new(other.clone(), Some(&ck)).err().expect("refused").to_string();
    assert!(
        e.contains("env.episode_length") && e.contains("fresh_episodes") && e.contains("latest"),
        "{e}"
    );
    other.run.fresh_episodes = true;
    let mut t = Trainer::new(other, Some(&ck)).unwrap();
    assert_eq!(t.progress.iteration, 2);
    t.iteration().unwrap();
    // the thread count does not change results: not a difference
    let mut threads = c.clone();
    threads.env.threads = 1;
    assert!(Trainer::new(threads, Some(&ck)).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Train `c` on `world` in-process ranks (from `resume` when given), each rank through the
/// runner's loop as under torchrun.
fn on_ranks(c: &TrainConfig, world: usize, resume: Option<&std::path::Path>) {
    let group = skillmimic_learn::collective::threads::ThreadGroup::new_group(world);
    std::thread::scope(|s| {
        for g in group {
            let c = c.clone();
            s.spawn(move || {
                let mut t = Trainer::with_collective(c, resume, Box::new(g)).unwrap();
                train_loop(&mut t, |_| {}).unwrap();
            });
        }
    });
}

#[test]
fn a_data_parallel_run_resumes_exactly_with_the_same_world_size() {
    let mut c = with_prior("dp");
    c.env.num_envs = 6;
    c.env.threads = 1;
    c.ppo.minibatch = 16;
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    on_ranks(&c, 2, None);
    let (want_rows, want) = (rows(&dir), std::fs::read(dir.join("latest.safetensors")).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
    let mut first = c.clone();
    first.run.iterations = 2;
    on_ranks(&first, 2, None);
    let mid = dir.join("checkpoints/iter_000002.safetensors");
    on_ranks(&c, 2, Some(&mid));
    let got_rows = rows(&dir);
    assert_eq!(got_rows.len(), 4);
    for (k, (a, b)) in want_rows.iter().zip(&got_rows).enumerate() {
        assert_eq!(a, b, "2 ranks: log row {} differs after the resume", k + 1);
    }
    assert!(std::fs::read(dir.join("latest.safetensors")).unwrap() == want, "2 ranks: differs");
    // another world size: possible, with fresh episodes (not exact)
    let mut more = c.clone();
    more.run.iterations = 5;
    let mut t = Trainer::new(more, Some(&dir.join("latest.safetensors"))).unwrap();
    assert_eq!(t.progress.iteration, 4);
    t.iteration().unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_checkpoint_without_the_state_resumes_with_fresh_episodes() {
    let mut c = config("imitation", "", "old");
    c.run.iterations = 2;
    // checkpoints without the run's state, as older versions wrote them
    c.run.save_run_state = false;
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    let mut t = Trainer::new(c.clone(), None).unwrap();
    train_loop(&mut t, |_| {}).unwrap();
    drop(t);
    let old = dir.join("latest.safetensors");
    let f = skillmimic_core::tensorfile::TensorFile::open(&old).unwrap();
    assert!(!f.has(skillmimic_learn::trainer::resume::TENSOR));
    c.run.save_run_state = true;
    c.run.iterations = 3;
    let mut t = Trainer::new(c, Some(&old)).unwrap();
    assert_eq!(t.progress.iteration, 2);
    t.iteration().unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Active skill learning (ModSkill's rounds grow the library and re-weight it while the run
/// trains) resumed with the run's original configuration ends exactly as the uninterrupted run:
/// (a) from a checkpoint followed by rounds it does not know of (as a kill after a round leaves
/// the folder: the later rounds' clips and lines of `active.jsonl` must go), (b) from the last
/// checkpoint of a shorter run, written without the round of its last iteration (the resume runs
/// that round first).
#[test]
fn active_learning_resumes_exactly() {
    let mut c = config("tracking", "", "active");
    c.env.table_mut::<TrackingConfig>().success_distance = 0.02; // every clip fails every round
    c.run.active.enabled = true;
    c.run.active.every = 1;
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    run(c.clone(), None);
    let read = |p: &str| std::fs::read(dir.join(p)).unwrap();
    let (want_rows, want, want_active) =
        (rows(&dir), read("latest.safetensors"), read("active.jsonl"));
    let clips = || std::fs::read_dir(dir.join("generated")).unwrap().count();
    let all = clips();
    let check = |case: &str| {
        let got_rows = rows(&dir);
        assert_eq!(got_rows.len(), 4, "{case}");
        for (k, (a, b)) in want_rows.iter().zip(&got_rows).enumerate() {
            assert_eq!(a, b, "{case}: log row {} differs after the resume", k + 1);
        }
        assert!(read("active.jsonl") == want_active, "{case}: the rounds differ");
        assert!(read("latest.safetensors") == want, "{case}: the final checkpoint differs");
    };
    // (a) the finished run's folder resumed from iteration 2: round 3's clips go, then come back
    let mid = dir.join("checkpoints/iter_000002.safetensors");
    let mut t = Trainer::new(c.clone(), Some(&mid)).unwrap();
    let at_mid = clips();
    println!("generated clips: {all} after the run, {at_mid} at iteration 2");
    assert!(at_mid < all, "round 3's clips were not removed");
    train_loop(&mut t, |_| {}).unwrap();
    drop(t);
    check("after later rounds");
    // (b) a run of 2 iterations (no round after its last), continued to 4
    std::fs::remove_dir_all(&dir).unwrap();
    let mut first = c.clone();
    first.run.iterations = 2;
    run(first, None);
    run(c.clone(), Some(&dir.join("latest.safetensors")));
    check("a shorter run continued");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A checkpoint whose saved state has an older layout (format 1, before the high-level tasks'
/// slots held the goal their first observation shows) resumes with fresh episodes, not an error.
#[test]
fn a_state_of_an_older_layout_resumes_with_fresh_episodes() {
    use safetensors::tensor::{Dtype, TensorView};
    let mut c = config("imitation", "", "older");
    c.run.iterations = 2;
    let dir = c.run.out_dir.clone();
    let _ = std::fs::remove_dir_all(&dir);
    run(c.clone(), None);
    let ck = dir.join("latest.safetensors");
    // the envelope of the saved state, written as format 1
    #[derive(serde::Serialize)]
    struct Envelope {
        format: u32,
        world: usize,
        env_config: String,
        ranks: Vec<Vec<u8>>,
    }
    let old = postcard::to_allocvec(&Envelope {
        format: 1,
        world: 1,
        env_config: String::new(),
        ranks: vec![vec![0; 8]],
    })
    .unwrap();
    let bytes = std::fs::read(&ck).unwrap();
    let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let name = skillmimic_learn::trainer::resume::TENSOR;
    let mut views: Vec<(String, TensorView<'_>)> =
        st.tensors().into_iter().filter(|(n, _)| n != name).collect();
    views.push((name.to_string(), TensorView::new(Dtype::U8, vec![old.len()], &old).unwrap()));
    std::fs::write(&ck, safetensors::serialize(views, meta.metadata().clone()).unwrap()).unwrap();
    c.run.iterations = 3;
    let mut t = Trainer::new(c, Some(&ck)).expect("an older layout resumes fresh");
    assert_eq!(t.progress.iteration, 2);
    t.iteration().unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}
