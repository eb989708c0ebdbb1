//! Evaluation metrics (library functions used by the `eval` command and by Python).
//!
//! * Imitation quality (SkillMimic seed 000 §6.2): per frame, Acc = ball error < 0.2 m ∧ body
//!   error < 0.1 m ∧ contact graph equal to the reference; E_b-mpjpe = mean Euclidean error of
//!   root + 17 key bodies (mm); E_o-mpjpe = ball position error (mm); E_cg = mean squared error of
//!   the contact-graph entries.
//! * Skill success rules of SkillMimic (seed 000 §6.2) and SkillMimic-V2's metric classes
//!   (reference-facts §9.8), as per-episode trackers fed one frame at a time.

use crate::hoi::dist;
use crate::tasks::imitation::NUM_FRAME_METRICS;

/// Accumulates per-frame imitation errors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImitationMetrics {
    pub frames: usize,
    pub accurate: usize,
    pub body_err_sum: f64,
    pub ball_err_sum: f64,
    pub cg_err_sum: f64,
}

impl ImitationMetrics {
    /// Add one frame (`[body_err m, ball_err m, cg_match 0/1, cg_sq_err]`, see
    /// `env::FRAME_METRIC_NAMES`).
    pub fn add(&mut self, m: &[f32]) {
        debug_assert_eq!(m.len(), NUM_FRAME_METRICS);
        self.frames += 1;
        if is_accurate(m[0] as f64, m[1] as f64, m[2] != 0.0) {
            self.accurate += 1;
        }
        self.body_err_sum += m[0] as f64;
        self.ball_err_sum += m[1] as f64;
        self.cg_err_sum += m[3] as f64;
    }
    /// Accuracy in percent.
    pub fn acc_percent(&self) -> f64 {
        100.0 * self.accurate as f64 / self.frames.max(1) as f64
    }
    /// E_b-mpjpe in millimetres.
    pub fn body_mpjpe_mm(&self) -> f64 {
        1000.0 * self.body_err_sum / self.frames.max(1) as f64
    }
    /// E_o-mpjpe in millimetres.
    pub fn ball_mpjpe_mm(&self) -> f64 {
        1000.0 * self.ball_err_sum / self.frames.max(1) as f64
    }
    /// E_cg.
    pub fn cg_error(&self) -> f64 {
        self.cg_err_sum / self.frames.max(1) as f64
    }
}

/// The Acc rule of one frame: ball error < 0.2 m, body error < 0.1 m, contacts correct.
pub fn is_accurate(body_err: f64, ball_err: f64, contacts_correct: bool) -> bool {
    ball_err < 0.2 && body_err < 0.1 && contacts_correct
}

/// What a success tracker sees of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameState {
    pub root_pos: [f64; 3],
    pub ball_pos: [f64; 3],
    pub ball_vel: [f64; 3],
}

impl FrameState {
    /// The root (body 0) position and the ball's position and velocity of a simulation state
    /// (world frame, m and m/s).
    pub fn of(st: &skillmimic_sim::EnvState<'_>) -> Self {
        use skillmimic_sim::BALL;
        Self { root_pos: st.pos(0), ball_pos: st.pos(BALL), ball_vel: st.linvel(BALL) }
    }
}

/// The success rule families.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkillKind {
    /// Dribbling locomotion: run (13), left run (11), right run (12).
    Run,
    /// Layups: layup (31), turnaround layup (34).
    Layup,
    /// Shots: shot styles 5, 6, 7 and the V2 shot label 9.
    Shot,
    /// Pickup (1).
    Pickup,
}

/// The success rule family of a skill label, if it has one.
pub fn skill_kind(label: u32) -> Option<SkillKind> {
    match label {
        11..=13 => Some(SkillKind::Run),
        31 | 34 => Some(SkillKind::Layup),
        5..=7 | 9 => Some(SkillKind::Shot),
        1 => Some(SkillKind::Pickup),
        _ => None,
    }
}

/// SkillMimic-V2 success tracker of one episode (`tasks/metric` rules, reference-facts §9.8).
///
/// * Run: OK(t) = root z > 0.5 ∧ ‖ball − root‖ < 1.5 ∧ |ball v_z| > 1e-5; before step 100 success
///   latches when OK ever holds, from step 100 on it must hold at every step.
/// * Layup: before step 300 latch when root z > 0.5 ∧ ball z > 1.8; from 300 on require
///   root z > 0.5 ∧ |ball v_z| > 1e-5.
/// * Shot: target = the clip's highest ball position; before 300 latch when root z > 0.5 ∧
///   |ball z − target z| < 0.2; from 300 on require root z > 0.5.
/// * Pickup: success when more than 60 steps have root z > 0.5 ∧ ‖ball − root‖ < 0.5.
#[derive(Clone, Debug, PartialEq)]
pub struct V2Success {
    kind: SkillKind,
    target_height: f64,
    success: bool,
    count: usize,
}

impl V2Success {
    /// A tracker for `kind`; `target_height` is the highest ball z of the reference clip (shots).
    pub fn new(kind: SkillKind, target_height: f64) -> Self {
        Self { kind, target_height, success: false, count: 0 }
    }

    /// Feed the state after step `t` (0-based step index of the episode).
    pub fn update(&mut self, t: usize, s: &FrameState) {
        let up = s.root_pos[2] > 0.5;
        match self.kind {
            SkillKind::Run => {
                let ok = up && dist(s.ball_pos, s.root_pos) < 1.5 && s.ball_vel[2].abs() > 1e-5;
                self.success = if t < 100 { self.success || ok } else { self.success && ok };
            }
            SkillKind::Layup => {
                if t < 300 {
                    self.success |= up && s.ball_pos[2] > 1.8;
                } else {
                    self.success &= up && s.ball_vel[2].abs() > 1e-5;
                }
            }
            SkillKind::Shot => {
                if t < 300 {
                    self.success |= up && (s.ball_pos[2] - self.target_height).abs() < 0.2;
                } else {
                    self.success &= up;
                }
            }
            SkillKind::Pickup => {
                if up && dist(s.ball_pos, s.root_pos) < 0.5 {
                    self.count += 1;
                }
                self.success = self.count > 60;
            }
        }
    }

    /// Success so far.
    pub fn success(&self) -> bool {
        self.success
    }
}

/// SkillMimic's success rules (seed 000 §6.2.4) as a tracker of one episode, fed one frame
/// (policy step) at a time.
///
/// * Pickup: the ball is above 1 m at the end.
/// * Dribble (run skills): a frame is valid when root z > 0.5 m ∧ ‖ball − root‖ < 1.5 m; score =
///   valid frames ÷ frames.
/// * Layup & shot: |max ball height − target height| < 0.1 m (target = the highest ball z of the
///   skill's clip) and the root is above 0.5 m at the end.
///
/// Two denominators and ends:
/// * [`V1Success::trial`], the paper's test: a trial of a fixed number of frames (10 s = 600 at
///   60 Hz). A trial that ends earlier (a fall) leaves the rest of its frames invalid (dribble)
///   and fails the other rules, which are judged at the trial's last frame; frames past the trial
///   are ignored.
/// * [`V1Success::new`], a project measure over whatever episode was played: the dribble fraction
///   divides by the frames played (a fall is not penalised) and the other rules are judged at
///   the episode's last frame.
#[derive(Clone, Debug, PartialEq)]
pub struct V1Success {
    kind: SkillKind,
    target_height: f64,
    /// The paper's fixed trial length (frames), or `None` for the per-episode measure.
    trial: Option<usize>,
    frames: usize,
    valid: usize,
    max_ball_z: f64,
    last: Option<FrameState>,
}

/// Frames of SkillMimic's test trial: 10 s at the 60 Hz control rate.
pub const TRIAL_FRAMES: usize = 600;

impl V1Success {
    /// The per-episode measure (see the type's documentation).
    pub fn new(kind: SkillKind, target_height: f64) -> Self {
        Self {
            kind,
            target_height,
            trial: None,
            frames: 0,
            valid: 0,
            max_ball_z: f64::NEG_INFINITY,
            last: None,
        }
    }

    /// The paper's test trial of `frames` frames ([`TRIAL_FRAMES`] = 10 s).
    pub fn trial(kind: SkillKind, target_height: f64, frames: usize) -> Self {
        Self { trial: Some(frames.max(1)), ..Self::new(kind, target_height) }
    }

    /// Feed the state after the next frame.
    pub fn update(&mut self, s: &FrameState) {
        if self.trial.is_some_and(|n| self.frames >= n) {
            return;
        }
        self.frames += 1;
        if s.root_pos[2] > 0.5 && dist(s.ball_pos, s.root_pos) < 1.5 {
            self.valid += 1;
        }
        self.max_ball_z = self.max_ball_z.max(s.ball_pos[2]);
        self.last = Some(*s);
    }

    /// Whether a trial has run its full length (always true for the per-episode measure).
    pub fn completed(&self) -> bool {
        self.trial.is_none_or(|n| self.frames >= n)
    }

    /// Score in [0, 1]: the dribble fraction, or 0/1 for the other skills.
    pub fn score(&self) -> f64 {
        let Some(last) = self.last else { return 0.0 };
        let ok = |b: bool| f64::from(u8::from(b && self.completed()));
        match self.kind {
            SkillKind::Run => self.valid as f64 / self.trial.unwrap_or(self.frames) as f64,
            SkillKind::Pickup => ok(last.ball_pos[2] > 1.0),
            SkillKind::Layup | SkillKind::Shot => {
                ok((self.max_ball_z - self.target_height).abs() < 0.1 && last.root_pos[2] > 0.5)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fs(root_z: f64, ball: [f64; 3], vz: f64) -> FrameState {
        FrameState { root_pos: [0.0, 0.0, root_z], ball_pos: ball, ball_vel: [0.0, 0.0, vz] }
    }

    #[test]
    fn imitation_metrics_by_hand() {
        let mut m = ImitationMetrics::default();
        m.add(&[0.05, 0.1, 1.0, 0.0]); // accurate
        m.add(&[0.15, 0.1, 1.0, 0.0]); // body too far
        m.add(&[0.05, 0.3, 1.0, 0.0]); // ball too far
        m.add(&[0.05, 0.1, 0.0, 0.5]); // contacts wrong
        assert_eq!(m.acc_percent(), 25.0);
        assert!((m.body_mpjpe_mm() - 75.0).abs() < 1e-4); // inputs are f32
        assert!((m.ball_mpjpe_mm() - 150.0).abs() < 1e-4);
        assert!((m.cg_error() - 0.125).abs() < 1e-12);
    }

    #[test]
    fn v2_run_rule_latches_then_must_hold() {
        let mut r = V2Success::new(SkillKind::Run, 0.0);
        r.update(0, &fs(0.9, [0.5, 0.0, 0.5], 0.0)); // ball not moving vertically
        assert!(!r.success());
        r.update(1, &fs(0.9, [0.5, 0.0, 0.5], 1.0));
        assert!(r.success());
        r.update(100, &fs(0.9, [0.5, 0.0, 0.5], -2.0));
        assert!(r.success());
        r.update(101, &fs(0.4, [0.5, 0.0, 0.5], -2.0)); // fell
        assert!(!r.success());
        r.update(102, &fs(0.9, [0.5, 0.0, 0.5], -2.0)); // cannot recover after step 100
        assert!(!r.success());
    }

    #[test]
    fn v2_layup_shot_pickup_rules() {
        let mut l = V2Success::new(SkillKind::Layup, 0.0);
        l.update(10, &fs(0.9, [0.0, 0.0, 1.9], 0.0));
        l.update(300, &fs(0.9, [0.0, 0.0, 0.2], 0.5));
        assert!(l.success());
        l.update(301, &fs(0.9, [0.0, 0.0, 0.12], 0.0)); // ball dead on the floor
        assert!(!l.success());
        let mut s = V2Success::new(SkillKind::Shot, 2.8);
        s.update(5, &fs(0.9, [0.0, 0.0, 2.65], 0.0));
        assert!(s.success());
        let mut p = V2Success::new(SkillKind::Pickup, 0.0);
        for t in 0..61 {
            p.update(t, &fs(0.9, [0.2, 0.0, 0.9], 0.0));
        }
        assert!(p.success());
        assert_eq!(skill_kind(13), Some(SkillKind::Run));
        assert_eq!(skill_kind(34), Some(SkillKind::Layup));
        assert_eq!(skill_kind(9), Some(SkillKind::Shot));
        assert_eq!(skill_kind(42), None);
    }

    #[test]
    fn v1_scores() {
        let mut d = V1Success::new(SkillKind::Run, 0.0);
        d.update(&fs(0.9, [1.0, 0.0, 0.5], 0.0));
        d.update(&fs(0.9, [2.0, 0.0, 0.5], 0.0));
        d.update(&fs(0.3, [0.1, 0.0, 0.5], 0.0));
        d.update(&fs(0.9, [0.1, 0.0, 0.5], 0.0));
        assert_eq!(d.score(), 0.5);
        let mut l = V1Success::new(SkillKind::Layup, 2.5);
        l.update(&fs(0.9, [0.0, 0.0, 2.45], 0.0));
        l.update(&fs(0.9, [0.0, 0.0, 0.5], 0.0));
        assert_eq!(l.score(), 1.0);
        let mut p = V1Success::new(SkillKind::Pickup, 0.0);
        p.update(&fs(0.9, [0.0, 0.0, 0.5], 0.0));
        assert_eq!(p.score(), 0.0);
    }

    /// The paper's 10-s trial by hand: a dribble that falls at 6 s scores 0.6 (the per-episode
    /// measure gives 1.0); pickup and layup are judged at the 600th frame and fail when the trial
    /// ended before it; frames after the trial do not count.
    #[test]
    fn the_ten_second_trial_by_hand() {
        let dribbling = fs(0.9, [0.5, 0.0, 0.5], 2.0);
        let mut trial = V1Success::trial(SkillKind::Run, 0.0, TRIAL_FRAMES);
        let mut episode = V1Success::new(SkillKind::Run, 0.0);
        for _ in 0..360 {
            trial.update(&dribbling);
            episode.update(&dribbling);
        }
        assert!(!trial.completed());
        assert!((trial.score() - 0.6).abs() < 1e-12, "{}", trial.score());
        assert_eq!(episode.score(), 1.0);
        // 10 s with the first 100 frames fallen, then 40 frames past the trial (ignored)
        let mut late = V1Success::trial(SkillKind::Run, 0.0, TRIAL_FRAMES);
        for t in 0..640 {
            late.update(&if t < 100 { fs(0.3, [0.5, 0.0, 0.1], 0.0) } else { dribbling });
        }
        assert!(late.completed());
        assert!((late.score() - 500.0 / 600.0).abs() < 1e-12, "{}", late.score());

        let held = fs(0.9, [0.0, 0.0, 1.2], 0.0);
        let mut p = V1Success::trial(SkillKind::Pickup, 0.0, TRIAL_FRAMES);
        for _ in 0..599 {
            p.update(&held);
        }
        assert_eq!(p.score(), 0.0, "ended one frame before 10 s: not judged a success");
        p.update(&held);
        assert_eq!(p.score(), 1.0);

        let mut l = V1Success::trial(SkillKind::Layup, 2.5, TRIAL_FRAMES);
        for t in 0..TRIAL_FRAMES {
            l.update(&fs(0.9, [0.0, 0.0, if t == 50 { 2.45 } else { 0.5 }], 0.0));
        }
        assert_eq!(l.score(), 1.0);
        let mut fell = V1Success::trial(SkillKind::Layup, 2.5, TRIAL_FRAMES);
        for t in 0..TRIAL_FRAMES {
            let root = if t < 300 { 0.9 } else { 0.3 };
            fell.update(&fs(root, [0.0, 0.0, if t == 50 { 2.45 } else { 0.5 }], 0.0));
        }
        assert_eq!(fell.score(), 0.0, "lying on the floor at the end of the 10 s");
        let mut missed = V1Success::trial(SkillKind::Shot, 2.5, TRIAL_FRAMES);
        for t in 0..TRIAL_FRAMES {
            missed.update(&fs(0.9, [0.0, 0.0, if t == 50 { 2.35 } else { 0.5 }], 0.0));
        }
        assert_eq!(missed.score(), 0.0, "the highest ball is 0.15 m below the target");
    }
}
