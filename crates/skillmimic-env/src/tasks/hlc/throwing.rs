//! `throwing`: throw the ball up to 2.5 m, catch the rebound, throw again (seed 000 §5.4.1;
//! reference-facts §8.2).
//!
//! * Choices → skills: 0 → 34 (turnaround layup), 1 → 1 (pickup), 2 → 13 (dribble forward).
//! * No task observation (the code forces it off): the observation is the 838 state entries.
//! * Reward: exp(−|z_ball − 2.5|) (paper = code).
//! * Success (paper; the code has none): after the first throw the ball stays above 0.3 m for
//!   10 s (600 low-level steps). The first throw = the first step on which the ball is above
//!   `throw_height` (1.5 m) and touches nothing — our definition, the paper gives none. An episode
//!   that ends before the 10 s are over is not a success.
//! * Metrics: `ball_height` (m), `thrown` (0/1), `success` (latched 0/1). No info entries.

use rand_chacha::ChaCha8Rng;
use skillmimic_sim::{BALL, EnvState};

use super::config::ThrowingConfig;
use super::{LL_HZ, Rule};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::vec_env::Env;

/// The `[env.throwing]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::ThrowingConfig>();

/// The throwing task's rule.
pub struct Throwing(pub ThrowingConfig);

/// A throwing episode's success bookkeeping.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThrowGoal {
    /// Low-level step of the first throw.
    pub throw_step: Option<u32>,
    /// Whether the ball went below the floor height since.
    pub dropped: bool,
    /// The success rule, latched.
    pub success: bool,
}

/// Skill label of each choice (the released code's `control_mapping`).
pub const LABELS: &[u32] = &[34, 1, 13];

impl Rule for Throwing {
    const NAME: &'static str = "throwing";
    type Goal = ThrowGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        0
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["throwing"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["ball_height", "thrown", "success"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        Vec::new()
    }
    fn sample_goal(&self, _root: [f64; 3], _rng: &mut ChaCha8Rng) -> ThrowGoal {
        ThrowGoal::default()
    }
    fn task_obs(&self, _g: &ThrowGoal, _st: &EnvState<'_>, _out: &mut [f32]) {}
    fn reward(
        &self,
        g: &mut ThrowGoal,
        step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let c = &self.0;
        let z = st.pos(BALL)[2];
        let r = (-(z - c.target_height).abs()).exp();
        let free = st.contact_force(BALL).iter().all(|f| *f == 0.0);
        match g.throw_step {
            None if z > c.throw_height && free => g.throw_step = Some(step),
            Some(_) if z < c.floor_height => g.dropped = true,
            _ => {}
        }
        if let Some(t0) = g.throw_step
            && !g.dropped
            && (step - t0) as f64 >= c.success_seconds * LL_HZ
        {
            g.success = true;
        }
        terms[0] = r as f32;
        metrics.copy_from_slice(&[
            z as f32,
            f32::from(u8::from(g.throw_step.is_some())),
            f32::from(u8::from(g.success)),
        ]);
        r
    }
    fn info(&self, _g: &ThrowGoal, _out: &mut [f32]) {}
    fn set_info(&self, _g: &mut ThrowGoal, _values: &[f32]) {}
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<ThrowingConfig>().validate()?;
    super::build(cfg, Throwing(cfg.table::<ThrowingConfig>().clone()))
}
