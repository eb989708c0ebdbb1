//! Distribution of the masked bridging steps N of State Transition Field connections on real
//! BallPlay-M clips (run, lrun, rrun, layup, shot), under each `env.compat` profile: its own
//! noise, connection similarity and step count (reference-facts §9.5; docs/fidelity.md reports
//! the printed histograms).

use std::path::PathBuf;

use skillmimic_core::shared_data::shared_dir_or_skip;
use skillmimic_env::{Compat, EnvConfig, ResetPlan, SkillEnv};

fn histogram(clips: &[PathBuf], compat: Compat, rounds: u64) -> [usize; 11] {
    let n = 64;
    let mut c =
        EnvConfig { num_envs: n, threads: 2, compat, motion: clips.to_vec(), ..Default::default() };
    c.v2.stf.enabled = true;
    c.v2.stf.prob = 1.0;
    let mut env = SkillEnv::from_config(c).unwrap();
    let mut h = [0usize; 11];
    for r in 0..rounds {
        env.reset_all(Some(1000 + r));
        for i in 0..n {
            assert_eq!(env.reset_plan(i), ResetPlan::Connect);
            h[env.episode(i).masked_steps] += 1;
        }
    }
    h
}

#[test]
fn bridging_steps_on_real_clips_under_both_profiles() {
    let Some(shared) = shared_dir_or_skip("bridging_steps_on_real_clips_under_both_profiles")
    else {
        return;
    };
    let d = shared.join("data/ballplay_m");
    let clips: Vec<PathBuf> =
        ["run", "lrun", "rrun", "layup", "shot_style1"].iter().map(|f| d.join(f)).collect();
    let mut means = vec![];
    for compat in [Compat::Paper, Compat::Code] {
        let h = histogram(&clips, compat, 16);
        let total: usize = h.iter().sum();
        let mean = h.iter().enumerate().map(|(k, c)| k * c).sum::<usize>() as f64 / total as f64;
        let pct: Vec<String> =
            h.iter().map(|&c| format!("{:.1}", 100.0 * c as f64 / total as f64)).collect();
        println!(
            "{compat:?}: N = 0..10 in % of {total} connections: [{}], mean N {mean:.2}",
            pct.join(", ")
        );
        // a broken similarity (e.g. always 0) would put every connection at N_max
        assert!(h[10] < total / 2, "{compat:?}: degenerate histogram {h:?}");
        means.push(mean);
    }
    assert!(means[0] != means[1], "the profiles' similarities should differ on real clips");
}
