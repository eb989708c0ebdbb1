//! SkillMimic-V2 evaluation (reference-facts §9.8) on scripted episodes with known outcomes: the
//! per-episode trackers and the tally behind SR / TSR / εNSR (success rate per skill, a fall
//! fails the attempt) and NR (Σ rewards / Σ steps of the finished episodes), fed synthetic
//! per-step states and rewards instead of a simulation. Positions in metres, velocities in m/s,
//! one step = one policy step.

use skillmimic_env::metrics::FrameState;
use skillmimic_learn::eval::{EpisodeTally, EpisodeTracker, EvalReport, FrameQuartiles, v2_rate};

const RUN: u32 = 13;
const LAYUP: u32 = 31;
/// Skill of the demo clips: no success rule.
const DEMO: u32 = 50;
/// The success runs' horizon (10 s).
const HORIZON: usize = 600;

/// Dribbling in place: root at 0.9 m, the ball 0.5 m in front bouncing (vertical velocity ±2).
fn dribble(t: usize) -> FrameState {
    FrameState {
        root_pos: [0.0, 0.0, 0.9],
        ball_pos: [0.5, 0.0, 0.5],
        ball_vel: [0.0, 0.0, if t.is_multiple_of(2) { 2.0 } else { -2.0 }],
    }
}

/// The character has fallen: root at 0.3 m, the ball lying still beside it.
fn fallen() -> FrameState {
    FrameState { root_pos: [0.0, 0.0, 0.3], ball_pos: [0.5, 0.0, 0.12], ball_vel: [0.0; 3] }
}

/// A layup: the ball goes up to 2.0 m at steps 40..60, then dribbling as above.
fn layup(t: usize) -> FrameState {
    let mut s = dribble(t);
    if (40..60).contains(&t) {
        s.ball_pos[2] = 2.0;
    }
    s
}

/// Feed `steps` frames of `state(t)` with reward `reward` per step into a tracker of `skill`.
fn episode(
    skill: u32,
    steps: usize,
    reward: f32,
    state: impl Fn(usize) -> FrameState,
) -> EpisodeTracker {
    let mut tr = EpisodeTracker::new(skill, 2.0);
    for t in 0..steps {
        tr.step(&state(t), reward);
    }
    assert_eq!(tr.steps(), steps);
    tr
}

fn report(tally: EpisodeTally) -> EvalReport {
    let mut rep = EvalReport::default();
    tally.write_into(&mut rep);
    rep
}

#[test]
fn a_sustained_run_succeeds_and_a_fall_at_step_150_fails() {
    // held for the whole horizon, ended by the time limit
    let ok = episode(RUN, HORIZON, 0.8, dribble);
    assert_eq!(ok.v2_success(false), Some(true));
    // the same until step 150, where the character falls and the episode terminates
    let fell = episode(RUN, 151, 0.2, |t| if t < 150 { dribble(t) } else { fallen() });
    assert_eq!(fell.v2_success(true), Some(false));
    // the rule alone already fails once the root is down after step 100 …
    assert_eq!(fell.v2_success(false), Some(false));
    // … and a run that stops bouncing the ball at step 300 (standing, ball held still) fails too
    let held = episode(RUN, HORIZON, 0.5, |t| {
        let mut s = dribble(t);
        if t >= 300 {
            s.ball_vel = [0.0; 3];
        }
        s
    });
    assert_eq!(held.v2_success(false), Some(false));
    let mut tally = EpisodeTally::default();
    tally.finish(RUN, &ok, false);
    tally.finish(RUN, &fell, true);
    tally.finish(RUN, &held, false);
    let rep = report(tally);
    let run = &rep.per_skill["013"];
    assert_eq!(run.episodes, 3);
    assert!((run.v2_success_rate.unwrap() - 1.0 / 3.0).abs() < 1e-12, "{run:?}");
    assert!((v2_rate(&rep, RUN) - 1.0 / 3.0).abs() < 1e-12);
    assert!((run.fall_rate - 1.0 / 3.0).abs() < 1e-12);
    assert!((run.mean_length - (600.0 + 151.0 + 600.0) / 3.0).abs() < 1e-9);
    // SkillMimic's dribble score: fraction of steps up with the ball near; the fallen episode has
    // 150 good steps of 151
    let v1 = (1.0 + 150.0 / 151.0 + 1.0) / 3.0;
    assert!((run.v1_score.unwrap() - v1).abs() < 1e-12, "{run:?}");
}

#[test]
fn a_fall_after_the_latch_fails_the_attempt() {
    // the layup rule latches before step 300 (ball above 1.8 m with the root up) …
    let ok = episode(LAYUP, HORIZON, 0.6, layup);
    assert_eq!(ok.v2_success(false), Some(true));
    // … so a layup that falls at step 150 still has its latch, but the fall fails the attempt
    let fell = episode(LAYUP, 151, 0.6, |t| if t < 150 { layup(t) } else { fallen() });
    assert_eq!(fell.v2_success(false), Some(true), "the rule latched at step 40");
    assert_eq!(fell.v2_success(true), Some(false), "a fall fails the attempt");
    // a layup that never lifts the ball fails without falling
    let low = episode(LAYUP, HORIZON, 0.6, dribble);
    assert_eq!(low.v2_success(false), Some(false));
    let mut tally = EpisodeTally::default();
    tally.finish(LAYUP, &ok, false);
    tally.finish(LAYUP, &fell, true);
    tally.finish(LAYUP, &low, false);
    let rep = report(tally);
    assert!((v2_rate(&rep, LAYUP) - 1.0 / 3.0).abs() < 1e-12, "{:?}", rep.per_skill);
}

#[test]
fn a_transition_is_scored_with_the_target_skills_rule() {
    // TSR: the episode starts from another skill's state while the condition asks for the run
    // skill; the tracker is built for the condition's skill. The same frames succeed under the
    // run rule and fail under the layup rule (the ball never goes above 1.8 m).
    let as_run = episode(RUN, HORIZON, 0.5, dribble);
    let as_layup = episode(LAYUP, HORIZON, 0.5, dribble);
    assert_eq!(as_run.v2_success(false), Some(true));
    assert_eq!(as_layup.v2_success(false), Some(false));
    let mut tally = EpisodeTally::default();
    tally.finish(RUN, &as_run, false);
    let rep = report(tally);
    assert_eq!(v2_rate(&rep, RUN), 1.0);
    assert_eq!(v2_rate(&rep, LAYUP), 0.0, "a skill without episodes has rate 0");
}

#[test]
fn nr_is_the_step_weighted_mean_reward_of_finished_episodes() {
    // two run episodes (600 steps at 0.8, 151 steps at 0.2) and one demo-skill episode (50
    // steps at 0.5, no success rule)
    let mut tally = EpisodeTally::default();
    tally.finish(RUN, &episode(RUN, HORIZON, 0.8, dribble), false);
    tally.finish(
        RUN,
        &episode(RUN, 151, 0.2, |t| if t < 150 { dribble(t) } else { fallen() }),
        true,
    );
    // an episode still running is not part of NR: it is never passed to `finish`
    let _running = episode(RUN, 30, 100.0, dribble);
    tally.finish(DEMO, &episode(DEMO, 50, 0.5, dribble), false);
    let rep = report(tally);
    let run_nr = (600.0 * 0.8 + 151.0 * 0.2) / 751.0;
    // f32 rewards summed in f64: 0.8 and 0.2 are not exact in f32
    assert!((rep.per_skill["013"].nr - run_nr).abs() < 1e-7, "{}", rep.per_skill["013"].nr);
    assert!((rep.per_skill["050"].nr - 0.5).abs() < 1e-7);
    let nr = (600.0 * 0.8 + 151.0 * 0.2 + 50.0 * 0.5) / 801.0;
    assert!((rep.nr - nr).abs() < 1e-7, "{} vs {nr}", rep.nr);
    // step-weighted, not the mean of per-episode means (0.5)
    assert!((rep.nr - 0.5).abs() > 0.1);
    assert_eq!(rep.episodes, 3);
    assert!((rep.fall_rate - 1.0 / 3.0).abs() < 1e-12);
    assert!((rep.mean_episode_length - 801.0 / 3.0).abs() < 1e-9);
    // no rule for the demo skill: no success rate and no V1 score
    assert_eq!(rep.per_skill["050"].v2_success_rate, None);
    assert_eq!(rep.per_skill["050"].v1_score, None);
    assert_eq!(v2_rate(&rep, DEMO), 0.0);
}

/// Copies of one trajectory are one trial: three episodes fed the same states count as one
/// distinct trajectory, a fourth that differs in one position at one step as another.
#[test]
fn copies_of_one_trajectory_are_counted_once() {
    let mut tally = EpisodeTally::default();
    for _ in 0..3 {
        tally.finish(RUN, &episode(RUN, HORIZON, 0.8, dribble), false);
    }
    let other = episode(RUN, HORIZON, 0.8, |t| {
        let mut s = dribble(t);
        if t == 400 {
            s.ball_pos[0] += 1e-9;
        }
        s
    });
    let rep = report({
        let mut t = tally.clone();
        t.finish(RUN, &other, false);
        t
    });
    assert_eq!(report(tally).per_skill["013"].distinct_episodes, 1);
    assert_eq!((rep.per_skill["013"].episodes, rep.per_skill["013"].distinct_episodes), (4, 2));
}

#[test]
fn fall_frames_are_the_quartiles_of_where_the_falls_ended() {
    // five layups from frame 2 that fall at clip frames 95, 90, 120, 91, 93 and one that reaches
    // the clip's end (frame 160, not a fall): the quartiles are those of the five falls
    let mut tally = EpisodeTally::default();
    for f in [95, 90, 120, 91, 93] {
        let tr = episode(LAYUP, f - 2, 0.3, |t| if t + 3 < f - 2 { layup(t) } else { fallen() });
        tally.finish_at(LAYUP, &tr, true, Some(f));
    }
    tally.finish_at(LAYUP, &episode(LAYUP, 158, 0.6, layup), false, Some(160));
    // a fall the task reports no clip frame for is counted as a fall but has no frame
    tally.finish(RUN, &episode(RUN, 10, 0.1, |_| fallen()), true);
    let rep = report(tally);
    let q = rep.per_skill["031"].fall_frames.expect("five falls");
    // sorted 90 91 93 95 120: nearest ranks 0, 1, 2, 3, 4
    let want = FrameQuartiles { count: 5, min: 90, q1: 91, median: 93, q3: 95, max: 120 };
    assert_eq!(q, want);
    assert!((rep.per_skill["031"].fall_rate - 5.0 / 6.0).abs() < 1e-12);
    assert_eq!(rep.per_skill["013"].fall_frames, None);
    assert_eq!(rep.per_skill["013"].fall_rate, 1.0);
    // nearest rank with four frames: indices round(0.75) = 1, round(1.5) = 2, round(2.25) = 2
    let even = FrameQuartiles::of(&[40, 10, 30, 20]).unwrap();
    assert_eq!((even.min, even.q1, even.median, even.q3, even.max), (10, 20, 30, 30, 40));
    assert_eq!(FrameQuartiles::of(&[]), None);
}
