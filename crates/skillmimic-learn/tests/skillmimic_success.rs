//! SkillMimic's success rates as the paper measures them (seed 000 §6.2.4): 10-s trials from
//! distinct reference start states of real BallPlay-M clips (run, pickup, layup), scored by the
//! paper's rules (the rules themselves are checked on hand-built trials in
//! `skillmimic_env::metrics`). A fresh (untrained) policy falls, so the trials end early: a fall
//! must fail pickup and layup and leave the rest of the 10 s invalid for the dribble. No two
//! trials share a start, so none is a copy of another; asking for more trials than a skill has
//! start states runs each start once.

use std::sync::Arc;

use skillmimic_core::shared_data::shared_dir_or_skip;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::eval_skillmimic::{
    SkillMimicEvalConfig, evaluate_skillmimic, normal95, wilson95,
};
use skillmimic_learn::trainer::Trainer;
use skillmimic_motion::{Clip, MotionLibrary};

/// The first `t` frames of `c`.
fn head(c: &Clip, t: usize) -> Clip {
    let mut h = c.clone();
    let n = c.num_frames;
    for v in [
        &mut h.root_pos,
        &mut h.root_rot,
        &mut h.dof_rot,
        &mut h.body_pos,
        &mut h.ball_pos,
        &mut h.ball_rot,
        &mut h.contact,
    ] {
        let width = v.len() / n;
        v.truncate(width * t);
    }
    h.num_frames = t;
    h
}

#[test]
fn the_intervals_by_hand() {
    // Wilson, 0 of 10: upper bound z²/n / (1 + z²/n) = 0.38416 / 1.38416
    let w = wilson95(0.0, 10.0);
    assert_eq!(w[0], 0.0);
    assert!((w[1] - 0.38416 / 1.38416).abs() < 1e-12, "{w:?}");
    // Wilson, 5 of 10: centred on 0.5, half-width z·sqrt(0.025 + z²/400) / (1 + z²/10)
    let w = wilson95(5.0, 10.0);
    let half = 1.96 * (0.025_f64 + 3.8416 / 400.0).sqrt() / 1.38416;
    assert!((w[0] - (0.5 - half)).abs() < 1e-12 && (w[1] - (0.5 + half)).abs() < 1e-12);
    // the dribble fraction: mean 0.5, sample deviation sqrt(0.02 / 3); clamped to [0, 1]
    let x = [0.4, 0.6, 0.5, 0.5];
    let s = (0.02_f64 / 3.0).sqrt();
    let n = normal95(&x);
    assert!((n[0] - (0.5 - 1.96 * s / 2.0)).abs() < 1e-12, "{n:?}");
    assert_eq!(normal95(&[0.0, 1.0, 1.0]).map(|v| (0.0..=1.0).contains(&v)), [true, true]);
}

#[test]
fn trials_are_distinct_ten_second_runs_scored_by_the_papers_rules() {
    let Some(shared) = shared_dir_or_skip("SkillMimic success rates on real clips") else { return };
    let d = shared.join("data/ballplay_m");
    let files = [
        d.join("run/013_018pickle_run_3.pt"),
        d.join("pick_40/001_007pickle_pick_000.pt"),
        d.join("layup/031_015pickle_layup_001_001.pt"),
    ];
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = files.to_vec();
    c.env.num_envs = 8;
    c.run.out_dir =
        std::env::temp_dir().join(format!("sm-skillmimic-success-{}", std::process::id()));
    let t = Trainer::new(c.clone(), None).unwrap();
    let lib = Arc::new(skillmimic_env::load_motion_library(&c.env.motion).unwrap());
    let cfg = SkillMimicEvalConfig { trials: 4, seed: 3, stochastic: false };
    let rep = evaluate_skillmimic(&t.policy, &c.env, &lib, &cfg).unwrap();
    println!(
        "{}",
        serde_json::to_string(
            &rep.per_skill
                .iter()
                .map(|(k, v)| (k, v.success_rate, v.fall_rate))
                .collect::<Vec<_>>()
        )
        .unwrap()
    );
    assert_eq!(rep.per_skill.keys().collect::<Vec<_>>(), ["001", "013", "031"]);
    assert_eq!(rep.trial_steps, 600);
    for (skill, s) in &rep.per_skill {
        assert_eq!(s.trials, 4, "{skill}");
        let mut starts: Vec<_> = s.per_trial.iter().map(|t| (&t.clip, t.start_frame)).collect();
        starts.sort();
        starts.dedup();
        assert_eq!(starts.len(), 4, "{skill}: two trials share a start");
        for t in &s.per_trial {
            assert!((1..=600).contains(&t.steps) && (0.0..=1.0).contains(&t.score), "{t:?}");
            if t.steps < 600 && skill != "013" {
                assert_eq!(t.score, 0.0, "{skill}: a trial that fell cannot succeed: {t:?}");
            }
            if skill == "013" {
                assert!(t.score <= t.steps as f64 / 600.0 + 1e-12, "{t:?}");
            }
        }
        let mean = s.per_trial.iter().map(|t| t.score).sum::<f64>() / 4.0;
        assert!((s.success_rate - mean).abs() < 1e-12);
        assert!(s.ci95[0] <= mean && mean <= s.ci95[1], "{skill}: {:?}", s.ci95);
    }
    // the same evaluation again: the same trials and scores
    let again = evaluate_skillmimic(&t.policy, &c.env, &lib, &cfg).unwrap();
    assert_eq!(serde_json::to_value(&again).unwrap(), serde_json::to_value(&rep).unwrap());

    // a clip of 8 frames has 5 start states (2 … 6): 50 trials asked, each start runs once
    let short =
        head(&lib.get(lib.clips().iter().position(|m| m.clip.skill == 13).unwrap()).clip, 8);
    let small = Arc::new(MotionLibrary::from_clips(vec![short]).unwrap());
    let many = SkillMimicEvalConfig { trials: 50, ..cfg };
    let rep = evaluate_skillmimic(&t.policy, &c.env, &small, &many).unwrap();
    let s = &rep.per_skill["013"];
    assert_eq!((s.trials, s.start_states), (5, 5));
    let mut frames: Vec<usize> = s.per_trial.iter().map(|t| t.start_frame).collect();
    frames.sort();
    assert_eq!(frames, [2, 3, 4, 5, 6]);
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}
