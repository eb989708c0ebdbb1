//! `env.multi.assign = "per_episode"` (TokenHSI's released multi-task rule: each episode's task
//! drawn from the mix at its reset) and the paused environments it rests on: a paused row is
//! not simulated and never done; with one task the rule is the fixed split bit for bit; with two,
//! tasks change between episodes in the mix's proportion, each row's mask is its current task's,
//! a terminal observation under autoreset is the finished episode's task's, and a saved state
//! continues bit for bit.

use skillmimic_env::tasks::multi::Assign;
use skillmimic_env::tasks::multi::config::MultiConfig;
use skillmimic_env::{Env, EnvConfig, registry};

/// Deterministic actions in [−1, 1] for step `t`.
fn actions(n: usize, a: usize, t: usize) -> Vec<f32> {
    (0..n * a).map(|j| (((j * 7919 + t * 104_729) % 2001) as f32 / 1000.0 - 1.0) * 0.8).collect()
}

fn multi(tasks: &[&str], mix: &[f64], n: usize, assign: Assign) -> EnvConfig {
    let mut cfg =
        EnvConfig { task: "hsi_multi".into(), num_envs: n, threads: 1, ..Default::default() };
    let m = cfg.table_mut::<MultiConfig>();
    m.tasks = tasks.iter().map(|s| s.to_string()).collect();
    m.mix = mix.to_vec();
    m.assign = assign;
    cfg
}

/// The task a row's observation says it runs (its mask entry; one group per task here).
fn mask_task(env: &dyn Env, obs: &[f32], r: usize, k: usize) -> usize {
    let d = env.obs_dim();
    let mask = &obs[(r + 1) * d - k..(r + 1) * d];
    assert_eq!(mask.iter().filter(|&&x| x == 1.0).count(), 1, "row {r}: mask {mask:?}");
    mask.iter().position(|&x| x == 1.0).unwrap()
}

/// The trainer's loop (reset_done, then step), `steps` times from step `from`; every buffer after
/// each step, concatenated.
fn run(env: &mut dyn Env, from: usize, steps: usize) -> Vec<f32> {
    let (n, a) = (env.num_envs(), env.act_dim());
    let mut out = Vec::new();
    for t in from..from + steps {
        env.reset_done();
        env.step(&actions(n, a, t)).unwrap();
        let b = env.buffers();
        out.extend_from_slice(&b.obs);
        out.extend_from_slice(&b.reward);
        out.extend_from_slice(&b.terms);
        out.extend_from_slice(&b.metrics);
        out.extend(b.terminated.iter().chain(&b.truncated).map(|&x| x as f32));
    }
    out
}

#[test]
fn a_paused_environment_is_not_simulated_and_never_reset() {
    let cfg =
        EnvConfig { task: "hsi_follow".into(), num_envs: 3, threads: 1, ..Default::default() };
    let mut env = registry::make(&cfg).unwrap();
    env.reset_all(Some(3));
    let (n, a) = (env.num_envs(), env.act_dim());
    let frozen = (env.mujoco().env_qpos(1).to_vec(), env.mujoco().env_qvel(1).to_vec());
    env.set_paused(1, true).unwrap();
    let mut others_moved = false;
    for t in 0..150 {
        env.reset_done();
        let before = env.mujoco().env_qpos(0).to_vec();
        env.step(&actions(n, a, t)).unwrap();
        others_moved |= env.mujoco().env_qpos(0) != before.as_slice();
        assert_eq!(env.mujoco().env_qpos(1), frozen.0.as_slice(), "step {t}: paused row moved");
        assert_eq!(env.mujoco().env_qvel(1), frozen.1.as_slice());
        assert!(!env.buffers().done(1), "step {t}: a paused row is never done");
    }
    assert!(others_moved);
    // resumed and reset, it runs again
    env.set_paused(1, false).unwrap();
    let mut mask = vec![false; n];
    mask[1] = true;
    env.reset_envs(&mask);
    let start = env.mujoco().env_qpos(1).to_vec();
    env.step(&actions(n, a, 0)).unwrap();
    assert_ne!(env.mujoco().env_qpos(1), start.as_slice());
    assert!(env.set_paused(7, true).unwrap_err().to_string().contains("out of range"));
}

#[test]
fn with_one_task_per_episode_tasks_equal_the_fixed_split_bit_for_bit() {
    let mut fixed = registry::make(&multi(&["hsi_follow"], &[], 4, Assign::Fixed)).unwrap();
    let mut drawn = registry::make(&multi(&["hsi_follow"], &[], 4, Assign::PerEpisode)).unwrap();
    fixed.reset_all(Some(11));
    drawn.reset_all(Some(11));
    let (x, y) = (run(fixed.as_mut(), 0, 160), run(drawn.as_mut(), 0, 160));
    assert_eq!(x.len(), y.len());
    let first = x.iter().zip(&y).position(|(a, b)| a.to_bits() != b.to_bits());
    assert_eq!(first, None, "first differing entry");
    assert_eq!(drawn.row_tasks(), &[0, 0, 0, 0]);
    assert!(fixed.row_tasks().is_empty());
}

#[test]
fn tasks_are_drawn_per_episode_from_the_mix_and_the_mask_follows() {
    let n = 6;
    let mut env =
        registry::make(&multi(&["hsi_follow", "hsi_climb"], &[0.25, 0.75], n, Assign::PerEpisode))
            .unwrap();
    env.reset_all(Some(5));
    assert_eq!(env.task_rows().len(), 2);
    let a = env.act_dim();
    let mut starts = [0usize; 2];
    let mut changed = 0;
    for t in 0..900 {
        let before = env.row_tasks().to_vec();
        let done: Vec<bool> = (0..n).map(|r| env.buffers().done(r)).collect();
        env.reset_done();
        for r in 0..n {
            let now = env.row_tasks()[r] as usize;
            if done[r] {
                starts[now] += 1;
                changed += usize::from(now != before[r] as usize);
            } else {
                assert_eq!(now, before[r] as usize, "step {t}: row {r} changed task mid-episode");
            }
            assert_eq!(mask_task(env.as_ref(), &env.buffers().obs, r, 2), now, "step {t} row {r}");
        }
        env.step(&actions(n, a, t)).unwrap();
    }
    let total = starts[0] + starts[1];
    assert!(total >= 60, "episodes started: {starts:?}");
    assert!(changed > 0, "no environment changed task");
    // the share of episodes drawn for climb, within 4.5 binomial standard deviations of 0.75
    let share = starts[1] as f64 / total as f64;
    let sd = (0.75f64 * 0.25 / total as f64).sqrt();
    assert!((share - 0.75).abs() < 4.5 * sd, "climb share {share} of {total} episodes");
}

#[test]
fn under_autoreset_the_terminal_observation_is_the_finished_episodes_task() {
    let n = 6;
    let mut env =
        registry::make(&multi(&["hsi_follow", "hsi_climb"], &[0.5, 0.5], n, Assign::PerEpisode))
            .unwrap();
    env.set_autoreset(true);
    env.reset_all(Some(9));
    let a = env.act_dim();
    let mut switched = 0;
    for t in 0..900 {
        let before = env.row_tasks().to_vec();
        env.step(&actions(n, a, t)).unwrap();
        let b = env.buffers();
        for r in 0..n {
            let now = env.row_tasks()[r] as usize;
            assert_eq!(mask_task(env.as_ref(), &b.obs, r, 2), now);
            if b.final_mask[r] != 0 {
                assert!(b.done(r), "an ended episode's flags are kept");
                assert_eq!(mask_task(env.as_ref(), &b.final_obs, r, 2), before[r] as usize);
                switched += usize::from(now != before[r] as usize);
            } else {
                assert_eq!(now, before[r] as usize);
            }
        }
    }
    assert!(switched > 0, "no environment changed task");
}

#[test]
fn a_saved_state_continues_bit_for_bit() {
    let cfg = multi(&["hsi_follow", "hsi_climb"], &[0.5, 0.5], 4, Assign::PerEpisode);
    let mut env = registry::make(&cfg).unwrap();
    env.reset_all(Some(2));
    run(env.as_mut(), 0, 120);
    let saved = env.save_state().unwrap();
    let tasks = env.row_tasks().to_vec();
    let x = run(env.as_mut(), 120, 200);
    let mut other = registry::make(&cfg).unwrap();
    other.reset_all(Some(77));
    other.restore_state(&saved).unwrap();
    assert_eq!(other.row_tasks(), tasks.as_slice());
    let y = run(other.as_mut(), 120, 200);
    assert!(x.iter().zip(&y).all(|(a, b)| a.to_bits() == b.to_bits()) && x.len() == y.len());
    // a state saved under one rule is refused under the other, naming the rule
    let fixed = multi(&["hsi_follow", "hsi_climb"], &[0.5, 0.5], 4, Assign::Fixed);
    let e = registry::make(&fixed).unwrap().restore_state(&saved).unwrap_err().to_string();
    assert!(e.contains("env.multi.assign"), "{e}");
}

#[test]
fn per_episode_tasks_are_refused_for_high_level_tasks() {
    let mut cfg = EnvConfig { task: "hlc_multi".into(), num_envs: 2, ..Default::default() };
    cfg.table_mut::<MultiConfig>().assign = Assign::PerEpisode;
    let e = registry::make(&cfg).err().expect("refused").to_string();
    assert!(e.contains("env.multi.assign"), "{e}");
}
