//! The high-level tasks' success rules (SkillMimic §6.2.4, reference-facts §8.4) on hand-built
//! trajectories whose answer is known: heading (the ball within 0.5 m of the target point,
//! latched), circling (the paper's share of valid frames and the released code's latch),
//! throwing (the ball above 0.3 m for 10 s after the first throw) and scoring (the paper's rule
//! and the released code's "reached" prediction). Positions in metres (world, z up), velocities
//! in m/s, one frame = one low-level step (60 Hz); every body but the root and the ball sits at
//! the origin.

use skillmimic_env::tasks::hlc::Rule;
use skillmimic_env::tasks::hlc::circling::{Circling, CirclingGoal};
use skillmimic_env::tasks::hlc::config::{
    CirclingConfig, HeadingConfig, ScoringConfig, ThrowingConfig,
};
use skillmimic_env::tasks::hlc::heading::{Heading, HeadingGoal};
use skillmimic_env::tasks::hlc::scoring::{Scoring, ScoringGoal};
use skillmimic_env::tasks::hlc::throwing::{ThrowGoal, Throwing};
use skillmimic_sim::{BALL, EnvState};

/// One hand-built state.
struct Frame {
    pos: Vec<f64>,
    quat: Vec<f64>,
    linvel: Vec<f64>,
    zeros: Vec<f64>,
    force: Vec<f64>,
    flags: Vec<u8>,
}

impl Frame {
    /// The root standing at (0, 0, 0.9) and the ball at `ball` moving with `vel`; `force` = the
    /// ball's net contact force (N).
    fn new(ball: [f64; 3], vel: [f64; 3], force: [f64; 3]) -> Self {
        let n = BALL + 1;
        let mut f = Frame {
            pos: vec![0.0; 3 * n],
            quat: [1.0, 0.0, 0.0, 0.0].repeat(n),
            linvel: vec![0.0; 3 * n],
            zeros: vec![0.0; 3 * n],
            force: vec![0.0; 3 * n],
            flags: vec![0; 64],
        };
        f.pos[2] = 0.9;
        f.pos[3 * BALL..].copy_from_slice(&ball);
        f.linvel[3 * BALL..].copy_from_slice(&vel);
        f.force[3 * BALL..].copy_from_slice(&force);
        f
    }

    fn view(&self) -> EnvState<'_> {
        EnvState {
            body_pos: &self.pos,
            body_quat: &self.quat,
            body_linvel: &self.linvel,
            body_angvel: &self.zeros,
            dof_pos: &[],
            dof_vel: &[],
            dof_force: &[],
            contact_force: &self.force,
            contact_pairs: &self.flags,
            touch: &self.flags,
            unstable: false,
        }
    }
}

/// Feed `frames` (steps 1, 2, …) to `rule`; the metrics after each step.
fn run<R: Rule>(rule: &R, goal: &mut R::Goal, frames: &[Frame]) -> Vec<Vec<f32>> {
    let mut terms = vec![0.0; rule.term_names().len()];
    let mut out = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let mut metrics = vec![0.0; rule.metric_names().len()];
        rule.reward(goal, k as u32 + 1, &f.view(), &mut terms, &mut metrics);
        out.push(metrics);
    }
    out
}

const STILL: [f64; 3] = [0.0; 3];

#[test]
fn heading_succeeds_once_the_ball_comes_within_half_a_metre() {
    let rule = Heading(HeadingConfig::default());
    assert_eq!(rule.0.target_height, 1.0);
    // straight at the target point (3, 0, 1): 0.1 m per step, then back out
    let xs: Vec<f64> = (0..=26).chain((0..26).rev()).map(|k| k as f64 * 0.1).collect();
    let path: Vec<Frame> = xs.iter().map(|&x| Frame::new([x, 0.0, 1.0], STILL, STILL)).collect();
    let mut g = HeadingGoal { xy: [3.0, 0.0], success: false };
    let m = run(&rule, &mut g, &path);
    assert_eq!(m[25][1], 0.0, "at 0.5 m: not yet (the rule is < 0.5 m)");
    assert_eq!(m[26][1], 1.0, "at 0.4 m");
    assert_eq!(m.last().unwrap()[1], 1.0, "latched after the ball leaves");
    // passing 0.55 m to the side: never
    let side: Vec<Frame> =
        (0..=60).map(|k| Frame::new([k as f64 * 0.1, 0.55, 1.0], STILL, STILL)).collect();
    let mut g = HeadingGoal { xy: [3.0, 0.0], success: false };
    let m = run(&rule, &mut g, &side);
    let closest = m.iter().map(|r| r[0]).fold(f32::INFINITY, f32::min);
    assert!((closest - 0.55).abs() < 1e-6 && !g.success);
}

#[test]
fn circling_scores_the_share_of_valid_frames() {
    let rule = Circling(CirclingConfig::default());
    let at = |d: f64, speed: f64| Frame::new([d, 0.0, 0.5], [0.0, speed, 0.0], STILL);
    // 60 valid frames (0.2 m off the 3 m ring, 1 m/s), 20 too slow (0.3 m/s), 20 too far (0.6 m)
    let frames: Vec<Frame> = (0..100)
        .map(|k| match k {
            0..60 => at(3.2, 1.0),
            60..80 => at(3.2, 0.3),
            _ => at(3.6, 1.0),
        })
        .collect();
    let mut g = CirclingGoal { xy: [0.0, 0.0], radius: 3.0, ..Default::default() };
    let m = run(&rule, &mut g, &frames);
    let last = m.last().unwrap();
    assert!((last[2] - 0.6).abs() < 1e-6, "valid share {}", last[2]);
    assert_eq!(last[3], 0.0, "the code's latch needs the ball within 0.3 m of the centre");
    let mut g = CirclingGoal { xy: [0.0, 0.0], radius: 3.0, ..Default::default() };
    let m = run(&rule, &mut g, &[at(0.2, 1.0)]);
    assert_eq!((m[0][1], m[0][3]), (0.0, 1.0), "at the centre: the code's latch, no valid frame");
}

#[test]
fn throwing_needs_ten_seconds_above_the_floor_after_the_first_throw() {
    let rule = Throwing(ThrowingConfig::default());
    let flying = |z: f64| Frame::new([0.3, 0.0, z], STILL, STILL);
    // held for 9 steps, free above 1.5 m at step 10 (the first throw), then 0.5–2.5 m
    let mut frames: Vec<Frame> =
        (0..9).map(|_| Frame::new([0.3, 0.0, 1.0], STILL, [0.0, 0.0, 5.0])).collect();
    frames.push(flying(1.6));
    frames.extend((11..=610).map(|k| flying(1.5 + (k as f64 * 0.1).sin())));
    let mut g = ThrowGoal::default();
    let m = run(&rule, &mut g, &frames);
    assert_eq!(g.throw_step, Some(10));
    assert_eq!(m[608][2], 0.0, "step 609: 599 steps after the throw");
    assert_eq!(m[609][2], 1.0, "step 610: 10 s after the throw");
    // the same with the ball down to 0.25 m at step 300: no success
    frames[299] = flying(0.25);
    let mut g = ThrowGoal::default();
    let m = run(&rule, &mut g, &frames);
    assert!(g.dropped && m.last().unwrap()[2] == 0.0);
    // above 1.5 m but still in the hands: not a throw
    let mut g = ThrowGoal::default();
    run(&rule, &mut g, &[Frame::new([0.3, 0.0, 1.7], STILL, [0.0, 0.0, 5.0])]);
    assert_eq!(g.throw_step, None);
}

#[test]
fn scoring_by_the_papers_rule_and_by_the_codes_prediction() {
    let rule = Scoring(ScoringConfig::default());
    let goal = || ScoringGoal { xy: [4.0, 0.0], ..Default::default() };
    // paper: higher than the basket point (4, 0, 2.5) and within 0.3 m of it
    let mut g = goal();
    run(&rule, &mut g, &[Frame::new([4.1, 0.1, 2.45], STILL, STILL)]);
    assert!(!g.success, "below the basket point");
    run(&rule, &mut g, &[Frame::new([4.1, 0.1, 2.6], STILL, STILL)]);
    assert!(g.success, "0.17 m from it, above it");
    // code: at 2.2 m with v_z = 0, the predicted crossing of 2 m is t = sqrt(2·9.8·0.2)/9.8 s away
    let t = (2.0_f64 * 9.8 * 0.2).sqrt() / 9.8;
    let mut g = goal();
    run(&rule, &mut g, &[Frame::new([3.0, 0.0, 2.2], [1.0 / t, 0.0, 0.0], STILL)]);
    assert!(g.reached && g.code_success, "crossing at x = 4.0");
    let mut g = goal();
    run(&rule, &mut g, &[Frame::new([3.0, 0.0, 2.2], [3.0, 0.0, 0.0], STILL)]);
    assert!(!g.reached, "crossing at x = {:.3}: 0.39 m short", 3.0 + 3.0 * t);
    let mut g = goal();
    run(&rule, &mut g, &[Frame::new([3.0, 0.0, 2.2], [1.0 / t, 0.0, 0.0], [0.0, 0.2, 0.0])]);
    assert!(!g.reached, "the ball is touched (0.2 N)");
}
