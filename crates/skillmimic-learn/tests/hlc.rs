//! The high-level tasks over a frozen skill policy:
//! * the skill policy inside the environment gives bit-identical PD targets to the same
//!   checkpoint's standalone inference (the learner's `Policy`) on the same observations;
//! * holding a choice for 3 low-level steps = 3 steps of the 1-step environment, also when an
//!   episode ends inside the 3 steps: with the released timing the mean of all 3 rewards, the
//!   flags of any step and the 3rd step's observation; with `timing = "cut"` the mean up to the
//!   episode's end and its terminal observation;
//! * with the released timing an episode's first observation shows the previous episode's goal,
//!   and the next one its own;
//! * bad skill policies and bad actions are clear errors.

use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skillmimic_env::EnvConfig;
use skillmimic_env::VecEnv;
use skillmimic_env::tasks::hlc::HighLevel;
use skillmimic_env::tasks::hlc::config::{HlcConfig, HlcTiming};
use skillmimic_env::tasks::hlc::heading::Heading;
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::PpoConfig;
use skillmimic_learn::policy::{InferenceBuffers, Policy};

fn workspace_root() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A skill policy checkpoint (902 → 156, small widths) with a non-trivial normaliser.
pub fn write_llc(tag: &str) -> PathBuf {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let cfg = PpoConfig { hidden: vec![64, 32], ..Default::default() };
    let mut p = Policy::new(902, 156, &cfg, &mut rng);
    let x: Vec<f32> = (0..902 * 64).map(|_| rng.random_range(-3.0..3.0)).collect();
    p.obs_norm.update(&x);
    // larger output weights so that some means leave [−1, 1] and the clamp matters
    for w in p.actor.params_mut().into_iter().rev().skip(1).take(1) {
        w.iter_mut().for_each(|v| *v *= 20.0);
    }
    let dir = std::env::temp_dir().join(format!("skillmimic-hlc-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("llc.safetensors");
    checkpoint::save(&path, &p, None, &Progress::default(), "").unwrap();
    path
}

fn config(task: &str, llc: &std::path::Path, n: usize) -> EnvConfig {
    let mut c = EnvConfig { task: task.into(), num_envs: n, threads: 2, ..Default::default() };
    c.motion = vec![workspace_root().join("motions")];
    c.table_mut::<HlcConfig>().llc = llc.to_path_buf();
    c
}

fn heading(c: &EnvConfig) -> Box<dyn skillmimic_env::Env> {
    skillmimic_env::registry::make(c).unwrap()
}

#[test]
fn the_skill_policy_inside_the_task_equals_standalone_inference_bit_for_bit() {
    let llc = write_llc("bits");
    let mut env = heading(&config("heading", &llc, 6));
    let standalone = checkpoint::load(&llc, Some((902, 156))).unwrap().policy;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut clamped = 0usize;
    for _ in 0..20 {
        let actions: Vec<f32> = (0..6).map(|_| rng.random_range(0..3) as f32).collect();
        env.step(&actions).unwrap();
        env.reset_done();
        let hold = env.as_any().downcast_ref::<VecEnv<HighLevel<Heading>>>().unwrap();
        let obs = hold.task().llc_observations().to_vec();
        // the observation: state part of the high-level observation | one-hot of the label
        for i in 0..6 {
            let label = [12, 13, 11][actions[i] as usize];
            assert_eq!(obs[i * 902 + 838 + label], 1.0);
            assert_eq!(obs[i * 902 + 838..(i + 1) * 902].iter().sum::<f32>(), 1.0);
        }
        for threads in [1, 2] {
            let (mut mu, mut v, mut a) = (vec![0.0; 6 * 156], vec![0.0; 6], vec![0.0; 6 * 156]);
            standalone.infer(&obs, 6, &mut InferenceBuffers::default(), &mut mu, &mut v, threads);
            standalone.mode(&mu, 6, &mut a);
            clamped += a.iter().filter(|x| x.abs() > 1.0).count();
            let a: Vec<f32> = a.iter().map(|x| x.clamp(-1.0, 1.0)).collect();
            let got = hold.last_targets();
            assert!(
                a.iter().zip(got).all(|(x, y)| x.to_bits() == y.to_bits()),
                "targets differ from standalone inference (threads {threads})"
            );
        }
    }
    assert!(clamped > 0, "the test policy should exercise the clamp");
}

#[test]
fn holding_a_choice_equals_three_single_steps_also_across_a_reset() {
    let llc = write_llc("hold");
    for timing in [HlcTiming::Released, HlcTiming::Cut] {
        for term_h in [0.25, 5.0] {
            held_steps_match(&llc, timing, term_h);
        }
    }
}

/// Released timing: an episode's first observation shows the previous episode's goal (the
/// released loop observes before it draws the new goal), the observation after its first step
/// its own; `cut` shows the new goal at once. Both draw the same goals.
#[test]
fn the_first_observation_of_an_episode_shows_the_previous_goal() {
    let llc = write_llc("timing");
    let make = |timing| {
        let mut c = config("heading", &llc, 2);
        c.table_mut::<HlcConfig>().timing = timing;
        heading(&c)
    };
    let (mut rel, mut cut) = (make(HlcTiming::Released), make(HlcTiming::Cut));
    let old = rel.buffers().info[..2].to_vec();
    let task = 838..842;
    let mask = [true, false];
    rel.reset_envs(&mask);
    cut.reset_envs(&mask);
    let new = rel.buffers().info[..2].to_vec();
    assert_eq!(new, cut.buffers().info[..2].to_vec(), "the same new goal");
    assert_ne!(old, new);
    let (r, c) = (rel.buffers().obs[..842].to_vec(), cut.buffers().obs[..842].to_vec());
    assert_eq!(r[..838], c[..838], "the same state");
    assert_ne!(r[task.clone()], c[task.clone()], "cut: the new goal; released: the old one");
    // the cut environment pointed at the old goal observes what the released one showed
    cut.set_task_info(0, &old).unwrap();
    assert_eq!(cut.buffers().obs[task.clone()], r[task.clone()]);
    cut.set_task_info(0, &new).unwrap();
    // after one step both observe the new goal
    rel.step(&[1.0, 1.0]).unwrap();
    cut.step(&[1.0, 1.0]).unwrap();
    assert_eq!(rel.buffers().obs[..842], cut.buffers().obs[..842]);
}

/// 12 high-level steps of the 3-step heading environment against the 1-step one stepped by hand:
/// `released` — all 3 steps count (mean of the 3 rewards, flags set when any step set them,
/// the 3rd step's observation); `cut` — the steps up to the one that ends the episode (its
/// terminal observation). `term_h` = 5 m: every episode terminates at its second low-level step.
fn held_steps_match(llc: &std::path::Path, timing: HlcTiming, term_h: f64) {
    let mut c3 = config("heading", llc, 4);
    c3.table_mut::<HlcConfig>().termination_height = term_h;
    c3.table_mut::<HlcConfig>().timing = timing;
    c3.threads = 1;
    let mut c1 = c3.clone();
    c1.table_mut::<HlcConfig>().llc_steps = 1;
    let (mut e3, mut e1) = (heading(&c3), heading(&c1));
    assert_eq!(e3.spec().max_episode_steps, 799usize.div_ceil(3));
    assert_eq!(e3.spec().steps_per_action, 3);
    assert_eq!(e3.buffers().obs, e1.buffers().obs);
    let released = timing == HlcTiming::Released;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut resets = 0;
    for _ in 0..12 {
        let actions: Vec<f32> = (0..4).map(|_| rng.random_range(0..3) as f32).collect();
        e3.step(&actions).unwrap();
        let (mut sum, mut count, mut done) = (vec![0.0f32; 4], vec![0usize; 4], vec![false; 4]);
        let (mut term, mut trunc) = (vec![false; 4], vec![false; 4]);
        let mut last_obs = e1.buffers().obs.clone();
        for _ in 0..3 {
            if !released && done.iter().all(|&d| d) {
                break;
            }
            e1.step(&actions).unwrap();
            let b = e1.buffers();
            for i in 0..4 {
                if released || !done[i] {
                    sum[i] += b.reward[i];
                    count[i] += 1;
                    last_obs[i * 842..(i + 1) * 842]
                        .copy_from_slice(&b.obs[i * 842..(i + 1) * 842]);
                    term[i] = if released {
                        term[i] || b.terminated[i] != 0
                    } else {
                        b.terminated[i] != 0
                    };
                    trunc[i] = if released {
                        trunc[i] || b.truncated[i] != 0
                    } else {
                        b.truncated[i] != 0
                    };
                    done[i] |= b.terminated[i] != 0 || b.truncated[i] != 0;
                }
            }
        }
        let b3 = e3.buffers();
        for i in 0..4 {
            if released {
                assert_eq!(count[i], 3);
            }
            assert_eq!(
                b3.reward[i],
                sum[i] / count[i] as f32,
                "env {i}: mean of the low-level rewards"
            );
            assert_eq!(b3.terminated[i] != 0, term[i], "env {i}: terminated");
            assert_eq!(b3.truncated[i] != 0, trunc[i] && !term[i], "env {i}: truncated");
        }
        assert_eq!(b3.obs, last_obs, "the observation of the transition's last counted step");
        resets += done.iter().filter(|&&d| d).count();
        // the 1-step environment went on stepping the finished ones: reset both the same way
        let mask = done.clone();
        e3.reset_envs(&mask);
        e1.reset_envs(&mask);
        assert_eq!(e3.buffers().obs, e1.buffers().obs, "new episodes start identically");
        assert_eq!(e3.buffers().info, e1.buffers().info, "and with the same goals");
    }
    if term_h > 1.0 {
        assert!(resets >= 12 * 4, "every transition ends inside the hold");
    }
}

#[test]
fn bad_skill_policies_and_actions_are_clear_errors() {
    let llc = write_llc("bad");
    let mut env = heading(&config("heading", &llc, 2));
    let e = env.step(&[0.0, 3.0]).unwrap_err().to_string();
    assert!(e.contains("environment 1") && e.contains("0..3"), "{e}");
    let e = env.step(&[0.5, 1.0]).unwrap_err().to_string();
    assert!(e.contains("0.5"), "{e}");
    let e = skillmimic_env::registry::make(&config("heading", &PathBuf::new(), 2))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("env.hlc.llc") && e.contains("--llc"), "{e}");
    let e = skillmimic_env::registry::make(&config(
        "heading",
        &PathBuf::from("/nonexistent/llc.safetensors"),
        2,
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("/nonexistent/llc.safetensors"), "{e}");
    // a policy of another size (a stand policy: observation 826)
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let p = Policy::new(826, 156, &PpoConfig { hidden: vec![8], ..Default::default() }, &mut rng);
    let other = llc.with_file_name("stand.safetensors");
    checkpoint::save(&other, &p, None, &Progress::default(), "").unwrap();
    let e =
        skillmimic_env::registry::make(&config("scoring", &other, 2)).err().unwrap().to_string();
    assert!(e.contains("826") && e.contains("902"), "{e}");
    // a skill policy trained on the box-hand humanoid drives only that humanoid
    let p = checkpoint::load(&llc, None).unwrap().policy;
    let boxed = llc.with_file_name("box.safetensors");
    checkpoint::save(&boxed, &p, None, &Progress::default(), "[env]\nhands = \"box\"\n").unwrap();
    let e =
        skillmimic_env::registry::make(&config("throwing", &boxed, 2)).err().unwrap().to_string();
    assert!(e.contains("env.hands") && e.contains("box"), "{e}");
    let mut c = config("throwing", &boxed, 2);
    c.hands = "box".into();
    assert!(skillmimic_env::registry::make(&c).is_ok());
}

#[test]
fn high_level_logits_start_glorot_uniform_with_zero_bias() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let cfg = PpoConfig {
        policy: "categorical_mlp".into(),
        hidden: vec![1024, 512],
        ..Default::default()
    };
    let p =
        Policy::build(842, skillmimic_env::ActionSpace::Discrete { n: 3 }, &cfg, &mut rng).unwrap();
    let params = p.actor.params();
    let (w, b) = (params[params.len() - 2], params[params.len() - 1]);
    let bound = (6.0f32 / (512.0 + 3.0)).sqrt();
    let max = w.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    // Glorot bound ≈ 0.108; PyTorch's default for fan_in 512 would be 1/√512 ≈ 0.044
    assert!(max <= bound && max > 0.9 * bound, "max |w| {max}, Glorot bound {bound}");
    assert!(b.iter().all(|&x| x == 0.0));
}

#[test]
fn high_level_defaults_are_the_released_controller_settings() {
    // reference-facts §8.3: 65 536 samples in 2 minibatches (scoring: 4), max epochs 2 000
    // (scoring: 6 000); a count the run chose stays
    let llc = write_llc("defaults");
    for (task, parts, iterations) in [("heading", 2, 2000), ("scoring", 4, 6000)] {
        let mut c = skillmimic_learn::config::TrainConfig::preset("paper").unwrap();
        c.env.task = task.into();
        c.env.table_mut::<HlcConfig>().llc = llc.clone();
        c.use_high_level_defaults();
        assert_eq!(c.ppo.policy, "categorical_mlp");
        assert_eq!(c.ppo.minibatch * parts, c.batch_size(), "{task}");
        assert_eq!(c.run.iterations, iterations, "{task}");
        let mut tiny = skillmimic_learn::config::TrainConfig::preset("tiny").unwrap();
        tiny.env.task = task.into();
        tiny.use_high_level_defaults();
        assert_eq!(tiny.run.iterations, 5, "{task}: the preset's count stays");
    }
    std::fs::remove_file(&llc).ok();
}
