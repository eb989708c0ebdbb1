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

/// SkillMimic (seed 000 §6.2) success tracker of one 10 s test episode.
///
/// * Pickup: the ball is above 1 m at the end.
/// * Dribble (run skills): score = fraction of frames with root z > 0.5 ∧ ‖ball − root‖ < 1.5.
/// * Layup & shot: |max ball height − target height| < 0.1 m (target = the clip's highest ball
///   z) and the root is above 0.5 m at the end.
#[derive(Clone, Debug, PartialEq)]
pub struct V1Success {
    kind: SkillKind,
    target_height: f64,
    frames: usize,
    valid: usize,
    max_ball_z: f64,
    last: Option<FrameState>,
}

impl V1Success {
    pub fn new(kind: SkillKind, target_height: f64) -> Self {
        Self { kind, target_height, frames: 0, valid: 0, max_ball_z: f64::NEG_INFINITY, last: None }
    }

    pub fn update(&mut self, s: &FrameState) {
        self.frames += 1;
        if s.root_pos[2] > 0.5 && dist(s.ball_pos, s.root_pos) < 1.5 {
            self.valid += 1;
        }
        self.max_ball_z = self.max_ball_z.max(s.ball_pos[2]);
        self.last = Some(*s);
    }

    /// Score in [0, 1]: the dribble fraction, or 0/1 for the other skills.
    pub fn score(&self) -> f64 {
        let Some(last) = self.last else { return 0.0 };
        match self.kind {
            SkillKind::Run => self.valid as f64 / self.frames as f64,
            SkillKind::Pickup => f64::from(u8::from(last.ball_pos[2] > 1.0)),
            SkillKind::Layup | SkillKind::Shot => f64::from(u8::from(
                (self.max_ball_z - self.target_height).abs() < 0.1 && last.root_pos[2] > 0.5,
            )),
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
}
