//! `circling`: dribble around the start point at a given radius (seed 000 §5.4.3;
//! reference-facts §8.2).
//!
//! * Choices → skills: 0 → 12, 1 → 13, 2 → 11 (as heading).
//! * Task observation (5): `loc`, `bearing` of the centre, the radius r (m).
//! * Goal: centre c = the start root_xy, r ~ U(2, 5) m.
//! * Reward with d = ‖ball_xy − c‖ and the ball speed v = ‖v_ball‖ (3D, m/s): code
//!   exp(−|d − r|) × (1 if v ≥ 0.5 else 0.1); paper exp(−|d² − r|) × (1 if v² > 0.5 else 0.1).
//! * Success: paper — the share of frames with |d − r| < 0.5 m and v > 0.5 m/s (metric
//!   `success`, the running share); code — latch when d < 0.3 m (metric `success_code`).
//! * Metrics: `ring_err` |d − r| (m), `valid_frame` (0/1), `success`, `success_code`.
//!   Info: `goal_x`, `goal_y`, `radius`.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{BALL, EnvState};

use super::config::{CirclingConfig, Formula};
use super::{Rule, loc_bearing, norm};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::markers::{Marker, ring};
use crate::vec_env::Env;

/// The `[env.circling]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::CirclingConfig>();

/// The circling task's rule.
pub struct Circling(pub CirclingConfig);

/// A circling episode's goal and success bookkeeping.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CirclingGoal {
    /// Centre, world xy (m).
    pub xy: [f64; 2],
    /// Radius (m).
    pub radius: f64,
    /// The released code's success latch.
    pub code_success: bool,
    /// Valid frames and frames so far (the paper's success = their ratio).
    pub valid_frames: u32,
    pub frames: u32,
}

/// Skill label of each choice (the released code's `control_mapping`).
pub const LABELS: &[u32] = &[12, 13, 11];

impl Rule for Circling {
    const NAME: &'static str = "circling";
    type Goal = CirclingGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        5
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["ring", "speed_gate", "circling"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["ring_err", "valid_frame", "success", "success_code"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        vec!["goal_x", "goal_y", "radius"]
    }
    fn sample_goal(&self, root: [f64; 3], rng: &mut ChaCha8Rng) -> CirclingGoal {
        let c = &self.0;
        let radius = if c.radius_max > c.radius_min {
            rng.random_range(c.radius_min..c.radius_max)
        } else {
            c.radius_min
        };
        CirclingGoal { xy: [root[0], root[1]], radius, ..CirclingGoal::default() }
    }
    fn task_obs(&self, g: &CirclingGoal, st: &EnvState<'_>, out: &mut [f32]) {
        loc_bearing(g.xy, st, out);
        out[4] = g.radius as f32;
    }
    fn reward(
        &self,
        g: &mut CirclingGoal,
        _step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let c = &self.0;
        let b = st.pos(BALL);
        let d = ((b[0] - g.xy[0]).powi(2) + (b[1] - g.xy[1]).powi(2)).sqrt();
        let v = norm(st.linvel(BALL));
        let (ring, gate) = match c.reward {
            Formula::Code => (
                (-(d - g.radius).abs()).exp(),
                if v >= c.speed_threshold { 1.0 } else { c.slow_factor },
            ),
            Formula::Paper => (
                (-(d * d - g.radius).abs()).exp(),
                if v * v > c.speed_threshold { 1.0 } else { c.slow_factor },
            ),
        };
        let err = (d - g.radius).abs();
        let valid = err < c.success_band && v > c.speed_threshold;
        g.frames += 1;
        g.valid_frames += u32::from(valid);
        if d < c.code_latch_radius {
            g.code_success = true;
        }
        let r = ring * gate;
        terms.copy_from_slice(&[ring as f32, gate as f32, r as f32]);
        metrics.copy_from_slice(&[
            err as f32,
            f32::from(u8::from(valid)),
            g.valid_frames as f32 / g.frames as f32,
            f32::from(u8::from(g.code_success)),
        ]);
        r
    }
    fn info(&self, g: &CirclingGoal, out: &mut [f32]) {
        out.copy_from_slice(&[g.xy[0] as f32, g.xy[1] as f32, g.radius as f32]);
    }
    fn set_info(&self, g: &mut CirclingGoal, values: &[f32]) {
        if let [x, y, ..] = *values {
            g.xy = [x as f64, y as f64];
        }
        if let Some(&r) = values.get(2) {
            g.radius = r as f64;
        }
    }
    /// The centre (a blue sphere) and the circle on the floor.
    fn markers(&self, info: &[f32], out: &mut Vec<Marker>) {
        let [x, y, r, ..] = *info else { return };
        let (x, y, blue) = (x as f64, y as f64, [0.1, 0.3, 0.9, 0.8]);
        out.push(Marker::Sphere { pos: [x, y, 0.05], radius: 0.08, rgba: blue });
        ring([x, y, 0.01], r as f64, 40, 0.015, [0.1, 0.3, 0.9, 0.7], out);
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<CirclingConfig>().validate()?;
    super::build(cfg, Circling(cfg.table::<CirclingConfig>().clone()))
}

#[cfg(test)]
mod tests {
    use super::super::Rule;
    use super::super::config::{ScoringConfig, ThrowingConfig};
    use super::super::scoring::Scoring;
    use super::super::throwing::Throwing;
    use super::*;
    use crate::markers::Marker;

    #[test]
    fn markers_follow_the_goal_entries() {
        let mut m = Vec::new();
        Circling(CirclingConfig::default()).markers(&[1.0, 2.0, 3.0], &mut m);
        assert_eq!(m.len(), 41, "the centre and a ring of 40 segments");
        let Marker::Segment { from, .. } = m[1] else { panic!("ring segment") };
        assert!(((from[0] - 1.0).hypot(from[1] - 2.0) - 3.0).abs() < 1e-9);
        m.clear();
        Scoring(ScoringConfig::default()).markers(&[1.0, 2.0, 0.0], &mut m);
        let h = ScoringConfig::default().basket_height;
        assert!(matches!(m[0], Marker::Segment { from, .. } if (from[2] - h).abs() < 1e-12));
        m.clear();
        Throwing(ThrowingConfig::default()).markers(&[], &mut m);
        assert!(m.is_empty());
    }
}
