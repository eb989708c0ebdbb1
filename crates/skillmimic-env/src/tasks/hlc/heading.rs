//! `heading`: dribble the ball to a target (seed 000 §5.4.2; reference-facts §8.2).
//!
//! * Choices → skills: 0 → 12 (dribble right), 1 → 13 (dribble forward), 2 → 11 (dribble left).
//! * Task observation (4): `loc`, `bearing` of the target (module doc of [`super`]).
//! * Goal: root_xy + (U(min, max), U(min, max)), min 2 m, max 8 m (the code: always in the +x, +y
//!   quadrant); `goal_sampling = "full_circle"` turns the offset by a uniform angle.
//! * Reward with the target point p = (goal, `target_height` 1 m): code exp(−‖ball − p‖), paper
//!   exp(−‖ball − p‖²).
//! * Success (paper = code): the ball came within `success_radius` (0.5 m) of p.
//! * Metrics: `ball_target_dist` (m), `success` (latched 0/1). Info: `goal_x`, `goal_y` (world, m).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_sim::EnvState;

use super::config::{Formula, GoalSampling, HeadingConfig};
use super::{Rule, ball_to, loc_bearing, norm};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::markers::Marker;
use crate::vec_env::Env;

/// The `[env.heading]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::HeadingConfig>();

/// The heading task's rule.
pub struct Heading(pub HeadingConfig);

/// A heading episode's goal.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeadingGoal {
    /// Target point, world xy (m; its height is `target_height`).
    pub xy: [f64; 2],
    /// The success rule, latched (paper and code agree here).
    pub success: bool,
}

/// The quadrant offset (U(min, max), U(min, max)), turned by U(0, 2π) when `full` (m).
pub fn goal_offset(min: f64, max: f64, full: bool, rng: &mut ChaCha8Rng) -> [f64; 2] {
    let (dx, dy) = if max > min {
        (rng.random_range(min..max), rng.random_range(min..max))
    } else {
        (min, min)
    };
    if !full {
        return [dx, dy];
    }
    let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    [dx * a.cos() - dy * a.sin(), dx * a.sin() + dy * a.cos()]
}

/// Skill label of each choice (the released code's `control_mapping`).
pub const LABELS: &[u32] = &[12, 13, 11];

impl Rule for Heading {
    const NAME: &'static str = "heading";
    type Goal = HeadingGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        4
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["heading"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["ball_target_dist", "success"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        vec!["goal_x", "goal_y"]
    }
    fn sample_goal(&self, root: [f64; 3], rng: &mut ChaCha8Rng) -> HeadingGoal {
        let c = &self.0;
        let o =
            goal_offset(c.goal_min, c.goal_max, c.goal_sampling == GoalSampling::FullCircle, rng);
        HeadingGoal { xy: [root[0] + o[0], root[1] + o[1]], success: false }
    }
    fn task_obs(&self, g: &HeadingGoal, st: &EnvState<'_>, out: &mut [f32]) {
        loc_bearing(g.xy, st, out);
    }
    fn reward(
        &self,
        g: &mut HeadingGoal,
        _step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let dist = norm(ball_to(st, [g.xy[0], g.xy[1], self.0.target_height]));
        let r = match self.0.reward {
            Formula::Code => (-dist).exp(),
            Formula::Paper => (-dist * dist).exp(),
        };
        if dist < self.0.success_radius {
            g.success = true;
        }
        terms[0] = r as f32;
        metrics[0] = dist as f32;
        metrics[1] = f32::from(u8::from(g.success));
        r
    }
    fn info(&self, g: &HeadingGoal, out: &mut [f32]) {
        out[0] = g.xy[0] as f32;
        out[1] = g.xy[1] as f32;
    }
    fn set_info(&self, g: &mut HeadingGoal, values: &[f32]) {
        if let [x, y, ..] = *values {
            g.xy = [x as f64, y as f64];
        }
    }
    /// A red sphere at the target point on a thin pole.
    fn markers(&self, info: &[f32], out: &mut Vec<Marker>) {
        let [x, y, ..] = *info else { return };
        let (x, y, h) = (x as f64, y as f64, self.0.target_height);
        let red = [0.9, 0.1, 0.1, 0.8];
        out.push(Marker::Sphere { pos: [x, y, h], radius: 0.12, rgba: red });
        let pole = [0.9, 0.1, 0.1, 0.6];
        out.push(Marker::Segment { from: [x, y, 0.0], to: [x, y, h], radius: 0.01, rgba: pole });
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<HeadingConfig>().validate()?;
    super::build(cfg, Heading(cfg.table::<HeadingConfig>().clone()))
}
