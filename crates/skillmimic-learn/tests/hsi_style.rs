//! The adversarial motion prior of the TokenHSI tasks: real BallPlay-M locomotion clips (run,
//! turn, pick) retargeted onto the TokenHSI character are the reference windows; a discriminator
//! trained on them against windows of a random policy in `hsi_follow` lowers its loss, scores the
//! reference above the policy and gives it the higher style reward. Inside PPO on `hsi_sit` the
//! per-term breakdown shows the task and style parts mixed 0.5 / 0.5, and the discriminator trains.

use skillmimic_learn::amp_reward::AmpReward;
use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_core::shared_data::shared_dir_or_skip;
use skillmimic_env::EnvConfig;
use skillmimic_env::amp::window_of;
use skillmimic_env::tasks::hsi::config::{Discriminators, HsiConfig};
use skillmimic_env::tasks::hsi::style::{
    RELEASED_STYLE_DIM, STYLE_DIM, clip_features, clip_released_features, frame_features,
    load_style_clips, released_features,
};
use skillmimic_env::tasks::multi::config::MultiConfig;
use skillmimic_learn::amp::{DiscConfig, Discriminator};
use skillmimic_motion::Clip;
use skillmimic_motion::retarget_hsi::retarget_to_hsi;

const K: usize = 10;
const CLIPS: [&str; 3] = [
    "run/013_018pickle_run_3.pt",
    "turn/042_018pickle_rturnover_30.pt",
    "pick_40/001_007pickle_pick_000.pt",
];

/// Retarget the BallPlay-M clips into a temporary folder (`tag` names it).
fn retargeted(shared: &std::path::Path, tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sm-hsi-style-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for c in CLIPS {
        let clip = Clip::load_any(&shared.join("data/ballplay_m").join(c)).unwrap();
        let (out, rep) = retarget_to_hsi(&clip);
        assert!(rep.frames > 30, "{rep:?}");
        out.save(&dir.join(format!("{}.safetensors", clip.name))).unwrap();
    }
    dir
}

/// Windows of a random policy (uniform actions in ±0.5) in `hsi_follow`: frames of `dim`
/// features — the proprioception read from the observation ([`STYLE_DIM`]) or the environment's
/// released features of its state ([`RELEASED_STYLE_DIM`]).
fn policy_windows(steps: usize, dim: usize) -> Vec<f32> {
    let c = EnvConfig { task: "hsi_follow".into(), num_envs: 8, threads: 1, ..Default::default() };
    let mut env = skillmimic_env::registry::make(&c).unwrap();
    let (d, a) = (env.obs_dim(), env.act_dim());
    env.reset_all(Some(2));
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut frames: Vec<Vec<f32>> = vec![Vec::new(); 8];
    let mut out = Vec::new();
    let mut style = vec![0.0f32; 8 * env.style_dim()];
    for _ in 0..steps {
        let act: Vec<f32> = (0..8 * a).map(|_| rng.random_range(-0.5..0.5)).collect();
        env.step(&act).unwrap();
        env.style_features(&mut style);
        let b = env.buffers();
        for (i, f) in frames.iter_mut().enumerate() {
            if dim == STYLE_DIM {
                let mut row = vec![0.0f32; STYLE_DIM];
                frame_features(&b.obs[i * d..(i + 1) * d], &mut row);
                f.extend(row);
            } else {
                f.extend_from_slice(&style[i * dim..(i + 1) * dim]);
            }
            if f.len() >= K * dim {
                out.extend_from_slice(&f[f.len() - K * dim..]);
            }
            if b.terminated[i] != 0 || b.truncated[i] != 0 {
                f.clear();
            }
        }
        env.reset_done();
    }
    out
}

fn reference_windows(rows: &[Vec<f32>], n: usize, dim: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    let mut out = vec![0.0f32; n * K * dim];
    for w in out.chunks_exact_mut(K * dim) {
        let c = rng.random_range(0..rows.len());
        let end = rng.random_range(0..rows[c].len() / dim);
        window_of(&rows[c], dim, end, K, w);
    }
    out
}

/// With either per-frame features (the proprioception; the released 129), a discriminator trained
/// on the retargeted clips against a random policy's windows separates them.
#[test]
fn discriminator_separates_retargeted_clips_from_random_policy_windows() {
    let Some(shared) =
        shared_dir_or_skip("discriminator_separates_retargeted_clips_from_random_policy_windows")
    else {
        return;
    };
    let dir = retargeted(&shared, "disc");
    let clips = load_style_clips(std::slice::from_ref(&dir)).unwrap();
    assert_eq!(clips.len(), CLIPS.len());
    for dim in [STYLE_DIM, RELEASED_STYLE_DIM] {
        let rows = if dim == STYLE_DIM {
            clip_features(&clips).unwrap()
        } else {
            clip_released_features(&clips).unwrap()
        };
        assert!(rows.iter().flatten().all(|v| v.is_finite()));
        let sim = policy_windows(40, dim);
        let w = K * dim;
        let n_sim = sim.len() / w;
        assert!(n_sim >= 64, "{n_sim} policy windows");
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let cfg = DiscConfig { hidden: vec![128, 64], lr: 1e-3, ..Default::default() };
        let mut disc = Discriminator::new(w, cfg, &mut rng);
        let mut losses = Vec::new();
        for _ in 0..60 {
            let r = reference_windows(&rows, 64, dim, &mut rng);
            let s: Vec<f32> = (0..64)
                .flat_map(|_| {
                    let k = rng.random_range(0..n_sim);
                    sim[k * w..(k + 1) * w].to_vec()
                })
                .collect();
            losses.push(disc.update(&r, 64, &s, 64).unwrap());
        }
        let (first, last) = (losses[0], losses[losses.len() - 1]);
        println!(
            "{dim} features: discriminator loss {:.4} -> {:.4} (adversarial {:.4} -> {:.4}); mean \
                logits reference {:.2}, policy {:.2}",
            first.total,
            last.total,
            first.adversarial,
            last.adversarial,
            last.mean_ref,
            last.mean_sim
        );
        assert!(last.adversarial < 0.5 * first.adversarial, "the adversarial loss falls");
        assert!(last.mean_ref > last.mean_sim + 1.0, "reference windows score above the policy's");
        let r = reference_windows(&rows, 64, dim, &mut rng);
        let rr = disc.style_reward(&r, 64).iter().sum::<f32>() / 64.0;
        let rs = disc.style_reward(&sim[sim.len() - 64 * w..], 64).iter().sum::<f32>() / 64.0;
        println!("style reward: reference windows {rr:.3}, random-policy windows {rs:.3}");
        assert!(rr > rs);
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_style_reward_mixes_into_ppo_on_a_tokenhsi_task() {
    use skillmimic_learn::trainer::Trainer;
    let Some(shared) = shared_dir_or_skip("the_style_reward_mixes_into_ppo_on_a_tokenhsi_task")
    else {
        return;
    };
    let dir = retargeted(&shared, "ppo");
    let mut c = amp_config("hsi_sit", 8, &dir, "ppo");
    c.env.table_mut::<HsiConfig>().object_variants = 2;
    c.run.iterations = 2;
    c.run.save_every = 2;
    c.run.eval_episodes = 2;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let before = t.extension::<AmpReward>().unwrap().disc().mlp.clone();
    assert_eq!(t.extension::<AmpReward>().unwrap().disc().input_dim(), K * RELEASED_STYLE_DIM);
    let mut seen = Vec::new();
    skillmimic_learn::runner::train_loop(&mut t, |s| seen.push(s.clone())).unwrap();
    let s = &seen[1];
    let term = |name: &str| {
        s.reward_terms
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
            .unwrap_or_else(|| panic!("no term {name} in {:?}", s.reward_terms))
    };
    let (task, style) = (term("task"), term("style"));
    println!(
        "terms {:?}; mixed reward {:.4} = 0.5 x task {task:.4} + 0.5 x style {style:.4}",
        s.reward_terms, s.mean_reward
    );
    assert!((s.mean_reward - 0.5 * (task + style)).abs() < 1e-5);
    assert!(style.is_finite() && style >= 0.0 && s.disc_loss > 0.0);
    assert_ne!(t.extension::<AmpReward>().unwrap().disc().mlp, before, "the discriminator trains");
    // a TokenHSI task without reference clips is refused with the key named
    c.env.table_mut::<HsiConfig>().style_motion.clear();
    let err = Trainer::new(c, None).err().expect("no style clips").to_string();
    assert!(err.contains("env.hsi.style_motion"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

/// `env.hsi.discriminator = "per_task"`: one discriminator per task, each trained on its own
/// task's clips and environments, saved and restored under its task's name.
#[test]
fn multi_task_training_keeps_one_discriminator_per_task() {
    use skillmimic_learn::trainer::Trainer;
    let Some(shared) = shared_dir_or_skip("multi_task_training_keeps_one_discriminator_per_task")
    else {
        return;
    };
    let dir = retargeted(&shared, "multi");
    let mut c = multi_config(&dir, "multi");
    c.env.table_mut::<HsiConfig>().discriminator = Discriminators::PerTask;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let amp = t.extension::<AmpReward>().unwrap();
    let names: Vec<&str> = amp.priors.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["hsi_follow", "hsi_sit"]);
    let before: Vec<_> = amp.priors.iter().map(|p| p.disc.mlp.clone()).collect();
    let s = t.iteration().unwrap();
    assert!(s.disc_loss > 0.0 && s.mean_reward.is_finite());
    for (p, b) in t.extension::<AmpReward>().unwrap().priors.iter().zip(&before) {
        assert_ne!(&p.disc.mlp, b, "{}'s discriminator trains", p.name);
    }
    let a = t.extension::<AmpReward>().unwrap();
    assert_ne!(a.priors[0].disc.mlp, a.priors[1].disc.mlp);
    // per-task tensors survive a checkpoint round trip
    let path = c.run.out_dir.join("c.safetensors");
    t.save(&path).unwrap();
    let f = skillmimic_core::tensorfile::TensorFile::open(&path).unwrap();
    assert!(
        f.names().iter().any(|n| n == "amp.hsi_sit.disc.0.weight")
            && f.names().iter().any(|n| n == "amp.hsi_follow.norm.mean")
    );
    let t2 = Trainer::new(c.clone(), Some(&path)).unwrap();
    for (p, q) in t
        .extension::<AmpReward>()
        .unwrap()
        .priors
        .iter()
        .zip(&t2.extension::<AmpReward>().unwrap().priors)
    {
        assert_eq!(p.disc.mlp, q.disc.mlp, "{} restored", p.name);
    }
    std::fs::remove_dir_all(&c.run.out_dir).ok();
    std::fs::remove_dir_all(dir).ok();
}

/// By default the discriminator reads the released TokenHSI features (129 per frame) of each
/// environment's simulation state — after a training iteration the newest frame of every window is
/// the released function of the state the environment is in — and its reference frames are the
/// same function of the clips' posed frames; `env.hsi.style_features = "proprioception"` switches
/// to the 222-d proprioception.
#[test]
fn the_prior_reads_the_released_features_of_the_state() {
    use skillmimic_env::tasks::hsi::config::StyleFeatures;
    use skillmimic_learn::trainer::Trainer;
    let Some(shared) = shared_dir_or_skip("the_prior_reads_the_released_features_of_the_state")
    else {
        return;
    };
    let dir = retargeted(&shared, "released");
    let mut c = amp_config("hsi_follow", 6, &dir, "released");
    c.ppo.horizon = 8;
    c.ppo.minibatch = 24;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    assert_eq!(t.env.style_dim(), RELEASED_STYLE_DIM);
    assert_eq!(t.extension::<AmpReward>().unwrap().disc().input_dim(), K * RELEASED_STYLE_DIM);
    t.iteration().unwrap();
    let amp = t.extension::<AmpReward>().unwrap();
    assert_eq!(amp.frame_dim(), RELEASED_STYLE_DIM);
    let mut want = vec![0.0f32; RELEASED_STYLE_DIM];
    for i in 0..t.env.num_envs() {
        released_features(&t.env.mujoco().env_state(i), &mut want);
        assert_eq!(amp.last_frame(i), want.as_slice(), "environment {i}'s newest frame");
    }
    // the reference side: every frame of the clips through the same function
    let clips = load_style_clips(std::slice::from_ref(&dir)).unwrap();
    let rows = clip_released_features(&clips).unwrap();
    assert_eq!(rows.len(), clips.len());
    for (r, c) in rows.iter().zip(&clips) {
        assert_eq!(r.len(), c.num_frames * RELEASED_STYLE_DIM);
        assert!(r.iter().all(|x| x.is_finite()));
        // root height column off, as released
        assert!(r.chunks(RELEASED_STYLE_DIM).all(|f| f[0] == 0.0));
    }
    // the switch back to the proprioception
    c.env.table_mut::<HsiConfig>().style_features = StyleFeatures::Proprioception;
    let t = Trainer::new(c.clone(), None).unwrap();
    assert_eq!(t.extension::<AmpReward>().unwrap().disc().input_dim(), K * STYLE_DIM);
    std::fs::remove_dir_all(dir).ok();
    std::fs::remove_dir_all(&c.run.out_dir).ok();
}

/// The released multi-task prior (default): one discriminator whose input is the window followed by
/// the task one-hot; every environment's windows carry its own task's one-hot, the reference
/// windows their clip's task's, and the one discriminator trains and round-trips a checkpoint.
#[test]
fn multi_task_training_conditions_one_discriminator_on_the_task() {
    use skillmimic_learn::trainer::Trainer;
    let Some(shared) =
        shared_dir_or_skip("multi_task_training_conditions_one_discriminator_on_the_task")
    else {
        return;
    };
    let dir = retargeted(&shared, "cond");
    let c = multi_config(&dir, "cond");
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let rows = t.env.task_rows();
    let amp = t.extension::<AmpReward>().unwrap();
    assert_eq!(amp.priors.len(), 1, "one discriminator");
    assert_eq!(amp.disc().input_dim(), K * RELEASED_STYLE_DIM + 2, "window then the task one-hot");
    for (k, (name, r)) in rows.iter().enumerate() {
        for i in r.clone() {
            let mut want = [0.0f32; 2];
            want[k] = 1.0;
            assert_eq!(amp.condition(i), want, "environment {i} runs {name}");
        }
    }
    let before = amp.disc().mlp.clone();
    let s = t.iteration().unwrap();
    assert!(s.disc_loss > 0.0 && s.mean_reward.is_finite());
    let amp = t.extension::<AmpReward>().unwrap();
    assert_ne!(amp.disc().mlp, before, "the conditional discriminator trains");
    // the one-hot stays with the environment's task across the iteration's episodes
    for (k, (_, r)) in rows.iter().enumerate() {
        assert!(r.clone().all(|i| amp.condition(i)[k] == 1.0));
    }
    let path = c.run.out_dir.join("c.safetensors");
    t.save(&path).unwrap();
    let t2 = Trainer::new(c.clone(), Some(&path)).unwrap();
    assert_eq!(t2.extension::<AmpReward>().unwrap().disc().mlp, amp.disc().mlp, "restored");
    std::fs::remove_dir_all(&c.run.out_dir).ok();
    std::fs::remove_dir_all(dir).ok();
}

/// `env.multi.assign = "per_episode"` (the released rule: each episode's task drawn at its
/// reset): the conditional prior's one-hot of every environment is the task it runs now, also
/// after environments changed task; one discriminator per task is refused by both fields.
#[test]
fn per_episode_tasks_carry_their_one_hot_into_the_conditional_prior() {
    use skillmimic_env::tasks::multi::Assign;
    use skillmimic_learn::trainer::Trainer;
    let Some(shared) =
        shared_dir_or_skip("per_episode_tasks_carry_their_one_hot_into_the_conditional_prior")
    else {
        return;
    };
    let dir = retargeted(&shared, "episodes");
    let mut c = multi_config(&dir, "episodes");
    c.env.table_mut::<MultiConfig>().assign = Assign::PerEpisode;
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let start = t.env.row_tasks().to_vec();
    let mut changed = false;
    for _ in 0..3 {
        t.iteration().unwrap();
        let amp = t.extension::<AmpReward>().unwrap();
        let tasks = t.env.row_tasks();
        for (i, &k) in tasks.iter().enumerate() {
            let mut want = [0.0f32; 2];
            want[k as usize] = 1.0;
            assert_eq!(amp.condition(i), want, "environment {i} runs task {k}");
        }
        changed |= tasks != start.as_slice();
    }
    assert!(changed, "no environment changed task in 3 iterations");
    c.env.table_mut::<HsiConfig>().discriminator = Discriminators::PerTask;
    let e = Trainer::new(c.clone(), None).err().expect("refused").to_string();
    assert!(e.contains("env.hsi.discriminator") && e.contains("env.multi.assign"), "{e}");
    std::fs::remove_dir_all(&c.run.out_dir).ok();
    std::fs::remove_dir_all(dir).ok();
}

/// A tiny `hsi_multi` run (follow 2 and sit 6 environments, a small token policy, the motion prior
/// on): follow's clips are the run clip only, sit's all of `dir`; its folder is tagged `tag`.
fn multi_config(dir: &std::path::Path, tag: &str) -> skillmimic_learn::config::TrainConfig {
    let mut c = amp_config("hsi_multi", 8, dir, tag);
    c.env.table_mut::<MultiConfig>().tasks = vec!["hsi_follow".into(), "hsi_sit".into()];
    c.env.table_mut::<MultiConfig>().mix = vec![0.25, 0.75];
    c.env.table_mut::<HsiConfig>().object_variants = 2;
    c.env.table_mut::<HsiConfig>().follow.style_motion =
        vec![dir.join("013_018pickle_run_3.safetensors")];
    c.ppo.policy = "token_transformer".into();
    c.ppo.token.tokenizer = vec![32];
    c.ppo.token.embed = 16;
    c.ppo.token.layers = 1;
    c.ppo.token.feedforward = 32;
    c.ppo.token.head = vec![32];
    c
}

/// A tiny run of `task` on `num_envs` environments (2 threads) with the motion prior on (small
/// networks), the clips of `dir` as its references; its folder is tagged `tag`.
fn amp_config(
    task: &str,
    num_envs: usize,
    dir: &std::path::Path,
    tag: &str,
) -> skillmimic_learn::config::TrainConfig {
    let mut c = skillmimic_learn::config::TrainConfig::preset("tiny").unwrap();
    c.env.task = task.into();
    c.env.num_envs = num_envs;
    c.env.threads = 2;
    c.env.table_mut::<HsiConfig>().style_motion = vec![dir.to_path_buf()];
    c.ppo.hidden = vec![32];
    c.ppo.amp.enabled = true;
    c.ppo.amp.hidden = vec![32];
    c.ppo.amp.batch = 32;
    c.ppo.amp.buffer = 256;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-hsi-{tag}-amp-{}", std::process::id()));
    c
}
