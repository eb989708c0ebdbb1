//! `steering`: move in a commanded direction at a commanded speed — ModSkill's downstream task
//! (seed 001 supplementary "Steering", after ASE's and PULSE's), over either kind of frozen skill
//! policy (discrete skill choices, or part embeddings of a `modular_attention` checkpoint).
//!
//! * Command: a world-frame direction d (unit, xy) at an angle U(0, 2π) and a speed
//!   v* ~ U(`speed_min`, `speed_max`) (m/s), drawn at the episode start and again after every
//!   U{`change_steps_min` … `change_steps_max`} low-level steps (ASE's target changes). The
//!   redraws come from a per-episode seed drawn at the reset, so episodes are reproducible.
//! * Task observation (3): d turned into the heading frame (x, y), then v* (m/s).
//! * Reward: exp(−k·‖v*·d − v_xy‖²), v_xy the world linear velocity of the pelvis's centre of
//!   mass (m/s; the velocity the observation reports), k =
//!   `error_scale` (0.25, ASE's scale). The paper writes the speed term as the velocity
//!   difference itself; as a reward it is turned into this bounded form (1 at a perfect match),
//!   so an episode's return over its largest possible value (`TaskSpec::max_step_reward` = 1
//!   × the episode's steps) is the normalised return the paper reports (Tab. 4); an evaluation
//!   reports it as `normalised_return`, where a fall forfeits the rest of the episode.
//! * Choices (discrete skill policies): 0 → 12 (rrun), 1 → 13 (run), 2 → 11 (lrun), as heading.
//! * Metrics: `speed_error` ‖v*·d − v_xy‖ (m/s), `dir_speed` d·v_xy (m/s). Info: `dir_x`,
//!   `dir_y` (world), `speed` (m/s) of the current command.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::math::heading_inverse;
use skillmimic_sim::EnvState;

use super::config::SteeringConfig;
use super::{Redraw, Rule};
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::vec_env::Env;

/// The `[env.steering]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::SteeringConfig>();

/// The steering task's rule.
pub struct Steering(pub SteeringConfig);

/// A steering episode's current command.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SteeringGoal {
    /// Commanded direction, world xy (unit vector).
    pub xy: [f64; 2],
    /// Commanded speed (m/s).
    pub speed: f64,
    pub redraw: Redraw,
}

/// Skill label of each choice (dribbling right, forward, left; as `heading`).
pub const LABELS: &[u32] = &[12, 13, 11];

impl Steering {
    /// Draw a command into `g` and the low-level step of the next one (after `step`).
    fn draw(&self, g: &mut SteeringGoal, step: u32, rng: &mut ChaCha8Rng) {
        let c = &self.0;
        let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        g.xy = [a.cos(), a.sin()];
        g.speed = if c.speed_max > c.speed_min {
            rng.random_range(c.speed_min..c.speed_max)
        } else {
            c.speed_min
        };
        g.redraw.next_change = step + rng.random_range(c.change_steps_min..=c.change_steps_max);
    }

    /// v*·d − v_xy (world, m/s).
    pub fn velocity_error(g: &SteeringGoal, st: &EnvState<'_>) -> [f64; 2] {
        let v = st.linvel(0);
        [g.speed * g.xy[0] - v[0], g.speed * g.xy[1] - v[1]]
    }
}

impl Rule for Steering {
    /// A ModSkill task: the SkillMimic loop's timing (`env.hlc.timing`) does not apply.
    fn released_loop(&self) -> bool {
        false
    }
    /// exp(−k·e²) ≤ 1 (a step's reward, also when averaged over held steps).
    fn max_step_reward(&self) -> Option<f64> {
        Some(1.0)
    }
    const NAME: &'static str = "steering";
    type Goal = SteeringGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        3
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["steering"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["speed_error", "dir_speed"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        vec!["dir_x", "dir_y", "speed"]
    }
    fn sample_goal(&self, _root: [f64; 3], rng: &mut ChaCha8Rng) -> SteeringGoal {
        let mut g = SteeringGoal {
            redraw: Redraw { seed: rng.random(), next_change: 0 },
            ..Default::default()
        };
        self.draw(&mut g, 0, rng);
        g
    }
    fn task_obs(&self, g: &SteeringGoal, st: &EnvState<'_>, out: &mut [f32]) {
        let d = heading_inverse(st.quat(0)).rotate([g.xy[0], g.xy[1], 0.0]);
        out[..3].copy_from_slice(&[d[0] as f32, d[1] as f32, g.speed as f32]);
    }
    fn reward(
        &self,
        g: &mut SteeringGoal,
        step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let e = Self::velocity_error(g, st);
        let e2 = e[0] * e[0] + e[1] * e[1];
        let r = (-self.0.error_scale * e2).exp();
        let v = st.linvel(0);
        terms[0] = r as f32;
        metrics[0] = e2.sqrt() as f32;
        metrics[1] = (g.xy[0] * v[0] + g.xy[1] * v[1]) as f32;
        if let Some(mut rng) = g.redraw.rng(step) {
            self.draw(g, step, &mut rng);
        }
        r
    }
    fn info(&self, g: &SteeringGoal, out: &mut [f32]) {
        out[..3].copy_from_slice(&[g.xy[0] as f32, g.xy[1] as f32, g.speed as f32]);
    }
    /// Direction (normalised; a zero vector keeps the current one) and speed.
    fn set_info(&self, g: &mut SteeringGoal, values: &[f32]) {
        let (x, y) = (
            values.first().copied().unwrap_or(0.0) as f64,
            values.get(1).copied().unwrap_or(0.0) as f64,
        );
        let n = (x * x + y * y).sqrt();
        if n > 0.0 && n.is_finite() {
            g.xy = [x / n, y / n];
        }
        if let Some(&s) = values.get(2)
            && s.is_finite()
        {
            g.speed = s as f64;
        }
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<SteeringConfig>().validate()?;
    super::build(cfg, Steering(cfg.table::<SteeringConfig>().clone()))
}
