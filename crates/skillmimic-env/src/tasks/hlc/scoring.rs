//! `scoring`: dribble to a basket and lay the ball up into it, again and again (seed 000 §5.4.4;
//! reference-facts §8.2).
//!
//! * Choices → skills: 0 → 31 (layup), 1 → 1 (pickup), 2 → 2 (rebound), 3 → 12, 4 → 13, 5 → 11
//!   (dribbles), 6 → 31 (layup again, as in the released table).
//! * Task observation (5): `loc`, `bearing` of the basket, the "reached" flag (0/1).
//! * Goal: basket xy = root_xy + d·(sin φ, cos φ), d ~ U(2, 8) m, φ ~ U(0, 2π); basket point
//!   B = (basket xy, 2.5 m).
//! * "Reached" (the code's latch, until the episode ends): the predicted crossing of the rim
//!   height h = 2 m lies within 0.3 m of the basket xy, the ball is above h and touches nothing
//!   (every |component| of its net contact force ≤ 0.1 N). Prediction with g = 9.8 m/s²:
//!   code — if the apex z + v_z²/2g is below h, h = 0; t = (√(v_z² + 2g(z − h)) − v_z)/g;
//!   ballistic (`prediction = "ballistic"`) — the descending crossing
//!   t = (v_z + √(v_z² + 2g(z − h)))/g, nothing when the apex is below h. Crossing xy =
//!   (x + v_x t, y + v_y t).
//! * Reward: code (1 if ‖v_root‖ ≥ 0.5 else 0.1) × [exp(−0.5‖ball − B‖) + 1{reached} +
//!   0.2·exp(−|z_ball − 2.5|)]; paper (1 if ‖v_ball‖² > 0.5 else 0.1) × [exp(−‖ball − B‖²) +
//!   1{scored} + 0.2·exp(−|z_ball − 2.5|)] with "scored" = the paper's success, latched.
//! * Success: paper — the ball is higher than B and within 0.3 m of it (latched, metric
//!   `success`); code — the "reached" latch (`success_code`).
//! * Metrics: `ball_basket_dist` (m), `success`, `success_code`. Info: `goal_x`, `goal_y`,
//!   `reached`.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{BALL, EnvState};

use super::config::{Formula, Prediction, ScoringConfig};
use super::{Rule, ball_to, loc_bearing, norm};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::markers::{Marker, ring};
use crate::vec_env::Env;

/// The `[env.scoring]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::ScoringConfig>();

/// Gravity of the prediction (m/s²).
pub const G: f64 = 9.8;

/// The scoring task's rule.
pub struct Scoring(pub ScoringConfig);

/// A scoring episode's basket and success latches.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScoringGoal {
    /// Basket position, world xy (m; its height is `basket_height`).
    pub xy: [f64; 2],
    /// The code's "reached" latch (also its task observation flag).
    pub reached: bool,
    /// The paper's success rule, latched.
    pub success: bool,
    /// The released code's success latch.
    pub code_success: bool,
}

/// Rim radius of a basketball hoop (m; markers only).
const RIM: f64 = 0.23;

/// Predicted xy where the ball crosses height `h` (see the module doc), `None` when the ballistic
/// prediction finds no crossing. `p`, `v`: ball position (m) and velocity (m/s), world.
pub fn predict_crossing(p: [f64; 3], v: [f64; 3], h: f64, how: Prediction) -> Option<[f64; 2]> {
    let apex = p[2] + v[2] * v[2] / (2.0 * G);
    let t = match how {
        Prediction::Code => {
            let h = if apex < h { 0.0 } else { h };
            ((v[2] * v[2] + 2.0 * G * (p[2] - h)).max(0.0).sqrt() - v[2]) / G
        }
        Prediction::Ballistic => {
            if apex < h {
                return None;
            }
            (v[2] + (v[2] * v[2] + 2.0 * G * (p[2] - h)).max(0.0).sqrt()) / G
        }
    };
    Some([p[0] + v[0] * t, p[1] + v[1] * t])
}

/// Skill label of each choice (the released code's `control_mapping`).
pub const LABELS: &[u32] = &[31, 1, 2, 12, 13, 11, 31];

impl Rule for Scoring {
    const NAME: &'static str = "scoring";
    type Goal = ScoringGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        5
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["speed_gate", "basket", "bonus", "height", "scoring"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["ball_basket_dist", "success", "success_code"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        vec!["goal_x", "goal_y", "reached"]
    }
    fn sample_goal(&self, root: [f64; 3], rng: &mut ChaCha8Rng) -> ScoringGoal {
        let c = &self.0;
        let d = if c.dist_max > c.dist_min {
            rng.random_range(c.dist_min..c.dist_max)
        } else {
            c.dist_min
        };
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let xy = [root[0] + d * phi.sin(), root[1] + d * phi.cos()];
        ScoringGoal { xy, ..ScoringGoal::default() }
    }
    fn task_obs(&self, g: &ScoringGoal, st: &EnvState<'_>, out: &mut [f32]) {
        loc_bearing(g.xy, st, out);
        out[4] = f32::from(u8::from(g.reached));
    }
    fn reward(
        &self,
        g: &mut ScoringGoal,
        _step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let c = &self.0;
        let (p, v) = (st.pos(BALL), st.linvel(BALL));
        let touching = st.contact_force(BALL).iter().any(|f| f.abs() > c.contact_force);
        if !g.reached
            && p[2] > c.reach_height
            && !touching
            && let Some(xy) = predict_crossing(p, v, c.reach_height, c.prediction)
        {
            g.reached =
                ((xy[0] - g.xy[0]).powi(2) + (xy[1] - g.xy[1]).powi(2)).sqrt() < c.reach_radius;
        }
        g.code_success = g.reached;
        let dist = norm(ball_to(st, [g.xy[0], g.xy[1], c.basket_height]));
        if p[2] > c.basket_height && dist < c.success_radius {
            g.success = true;
        }
        let height = (-(p[2] - c.basket_height).abs()).exp();
        let (gate, basket, bonus) = match c.reward {
            Formula::Code => (
                if norm(st.linvel(0)) >= c.speed_threshold { 1.0 } else { c.slow_factor },
                (-0.5 * dist).exp(),
                f64::from(u8::from(g.reached)),
            ),
            Formula::Paper => (
                if norm(v).powi(2) > c.speed_threshold { 1.0 } else { c.slow_factor },
                (-dist * dist).exp(),
                f64::from(u8::from(g.success)),
            ),
        };
        let r = gate * (basket + bonus + 0.2 * height);
        terms.copy_from_slice(&[gate as f32, basket as f32, bonus as f32, height as f32, r as f32]);
        metrics.copy_from_slice(&[
            dist as f32,
            f32::from(u8::from(g.success)),
            f32::from(u8::from(g.code_success)),
        ]);
        r
    }
    fn info(&self, g: &ScoringGoal, out: &mut [f32]) {
        out.copy_from_slice(&[g.xy[0] as f32, g.xy[1] as f32, f32::from(u8::from(g.reached))]);
    }
    fn set_info(&self, g: &mut ScoringGoal, values: &[f32]) {
        if let [x, y, ..] = *values {
            g.xy = [x as f64, y as f64];
        }
    }
    /// The hoop: a rim-sized ring at the basket point, a backboard behind it (on its +x side:
    /// the direction the ball comes from is not part of the goal) and a pole.
    fn markers(&self, info: &[f32], out: &mut Vec<Marker>) {
        let [x, y, ..] = *info else { return };
        let (x, y, h) = (x as f64, y as f64, self.0.basket_height);
        ring([x, y, h], RIM, 24, 0.012, [1.0, 0.45, 0.0, 1.0], out);
        let board = [0.95, 0.95, 0.95, 0.6];
        out.push(Marker::Box {
            pos: [x + RIM + 0.15, y, h + 0.3],
            half: [0.015, 0.9, 0.55],
            rgba: board,
        });
        let (from, to) = ([x + RIM + 0.2, y, 0.0], [x + RIM + 0.2, y, h + 0.3]);
        out.push(Marker::Segment { from, to, radius: 0.04, rgba: [0.3, 0.3, 0.3, 1.0] });
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<ScoringConfig>().validate()?;
    super::build(cfg, Scoring(cfg.table::<ScoringConfig>().clone()))
}
