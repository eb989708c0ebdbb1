//! `reach`: bring the right hand to a 3-D target — ModSkill's downstream task (seed 001
//! supplementary "Reach", after ASE and PULSE), over either kind of frozen skill policy.
//!
//! * Target c: uniform in a box of side `box_size` (2 m) centred `center_height` (1 m) above the
//!   floor over the root's start position (world frame, m), drawn at the episode start and again
//!   after every U{`change_steps_min` … `change_steps_max`} low-level steps (per-episode seed).
//! * Hand: body `hand_body` ("R_Middle1", the base of the middle finger — where the SMPL hand
//!   joint of ModSkill's humanoid sits; "R_Wrist" is the wrist).
//! * Task observation (3): c − root position turned into the heading frame (m).
//! * Reward: exp(−`scale`·‖p_hand − c‖²), `scale` 5 /m² (the paper's).
//! * Choices (discrete skill policies): 0 → 12 (rrun), 1 → 13 (run), 2 → 11 (lrun), as heading.
//! * Metrics: `hand_target_dist` (m). Info: `target_x`, `target_y`, `target_z` (world, m).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::math::heading_inverse;
use skillmimic_sim::EnvState;

use super::config::ReachConfig;
use super::{Redraw, Rule, norm};
use crate::config::EnvConfig;
use crate::error::{EnvError, bad};
use crate::markers::Marker;
use crate::vec_env::Env;

/// The `[env.reach]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<super::config::ReachConfig>();

/// The reach task's rule, with the hand's body index.
pub struct Reach(pub ReachConfig, pub usize);

/// A reach episode's current target.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReachGoal {
    /// Target, world xy (m).
    pub xy: [f64; 2],
    /// Target height (m).
    pub target_z: f64,
    /// The world xy the targets are drawn around (the root's start position, m).
    pub anchor: [f64; 2],
    pub redraw: Redraw,
}

/// Skill label of each choice (as `heading`).
pub const LABELS: &[u32] = &[12, 13, 11];

impl Reach {
    fn draw(&self, g: &mut ReachGoal, step: u32, rng: &mut ChaCha8Rng) {
        let c = &self.0;
        let h = 0.5 * c.box_size;
        let mut u = || if h > 0.0 { rng.random_range(-h..h) } else { 0.0 };
        let (dx, dy, dz) = (u(), u(), u());
        g.xy = [g.anchor[0] + dx, g.anchor[1] + dy];
        g.target_z = c.center_height + dz;
        g.redraw.next_change = step + rng.random_range(c.change_steps_min..=c.change_steps_max);
    }
    fn target(g: &ReachGoal) -> [f64; 3] {
        [g.xy[0], g.xy[1], g.target_z]
    }
}

impl Rule for Reach {
    /// A ModSkill task: the SkillMimic loop's timing (`env.hlc.timing`) does not apply.
    fn released_loop(&self) -> bool {
        false
    }
    /// exp(−k·e²) ≤ 1 (a step's reward, also when averaged over held steps).
    fn max_step_reward(&self) -> Option<f64> {
        Some(1.0)
    }
    const NAME: &'static str = "reach";
    type Goal = ReachGoal;
    fn labels(&self) -> &'static [u32] {
        LABELS
    }
    fn task_obs_dim(&self) -> usize {
        3
    }
    fn term_names(&self) -> Vec<&'static str> {
        vec!["reach"]
    }
    fn metric_names(&self) -> Vec<&'static str> {
        vec!["hand_target_dist"]
    }
    fn info_names(&self) -> Vec<&'static str> {
        vec!["target_x", "target_y", "target_z"]
    }
    fn sample_goal(&self, root: [f64; 3], rng: &mut ChaCha8Rng) -> ReachGoal {
        let mut g = ReachGoal {
            anchor: [root[0], root[1]],
            redraw: Redraw { seed: rng.random(), next_change: 0 },
            ..ReachGoal::default()
        };
        self.draw(&mut g, 0, rng);
        g
    }
    fn task_obs(&self, g: &ReachGoal, st: &EnvState<'_>, out: &mut [f32]) {
        let (c, r) = (Self::target(g), st.pos(0));
        let d = heading_inverse(st.quat(0)).rotate([c[0] - r[0], c[1] - r[1], c[2] - r[2]]);
        out[..3].copy_from_slice(&[d[0] as f32, d[1] as f32, d[2] as f32]);
    }
    fn reward(
        &self,
        g: &mut ReachGoal,
        step: u32,
        st: &EnvState<'_>,
        terms: &mut [f32],
        metrics: &mut [f32],
    ) -> f64 {
        let (c, p) = (Self::target(g), st.pos(self.1));
        let dist = norm([p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
        let r = (-self.0.scale * dist * dist).exp();
        terms[0] = r as f32;
        metrics[0] = dist as f32;
        if let Some(mut rng) = g.redraw.rng(step) {
            self.draw(g, step, &mut rng);
        }
        r
    }
    fn info(&self, g: &ReachGoal, out: &mut [f32]) {
        out[..3].copy_from_slice(&[g.xy[0] as f32, g.xy[1] as f32, g.target_z as f32]);
    }
    fn set_info(&self, g: &mut ReachGoal, values: &[f32]) {
        for (k, v) in values.iter().take(3).enumerate().filter(|(_, v)| v.is_finite()) {
            match k {
                0 => g.xy[0] = *v as f64,
                1 => g.xy[1] = *v as f64,
                _ => g.target_z = *v as f64,
            }
        }
    }
    /// A green sphere at the target.
    fn markers(&self, info: &[f32], out: &mut Vec<Marker>) {
        let [x, y, z, ..] = *info else { return };
        let pos = [x as f64, y as f64, z as f64];
        out.push(Marker::Sphere { pos, radius: 0.06, rgba: [0.1, 0.8, 0.2, 0.8] });
    }
}

/// Registry constructor.
pub fn build(cfg: &EnvConfig) -> Result<Box<dyn Env>, EnvError> {
    cfg.table::<ReachConfig>().validate()?;
    let hand = skillmimic_core::characters::skillmimic::BODIES
        .iter()
        .position(|b| b.name == cfg.table::<ReachConfig>().hand_body)
        .ok_or_else(|| {
            let names: Vec<&str> =
                skillmimic_core::characters::skillmimic::BODIES.iter().map(|b| b.name).collect();
            bad(
                "env.reach.hand_body",
                format!(
                    "'{}' is not a body of the humanoid; expected one of {names:?}",
                    cfg.table::<ReachConfig>().hand_body
                ),
            )
        })?;
    super::build(cfg, Reach(cfg.table::<ReachConfig>().clone(), hand))
}
