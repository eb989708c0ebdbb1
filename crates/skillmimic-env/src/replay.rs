//! Kinematic replay: put the simulator into every frame of a clip and score it against the same
//! clip. This measures what the data itself allows — the stored key-body positions differ from
//! forward kinematics of the stored joints by ≈3 cm — and how the simulated contact graphs
//! (MuJoCo's exact pairs and the papers' force-threshold nodes) compare with the clip's hand–ball
//! labels. Each frame is set with `mj_forward` (positions and the clip's finite-difference
//! velocities), so the contact forces are those of that instant.

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{BatchSim, ResetState, Scene, SimError};

use crate::config::{ContactGraphMode, RewardConfig};
use crate::episode::{BALL_FREE_SKILLS, reset_state_from_clip};
use crate::hoi::{ContactGraph, HoiState, dist};
use crate::metrics::ImitationMetrics;
use crate::reward::{self, NUM_TERMS, TERM_NAMES};

/// Results of a kinematic replay over one or more clips.
#[derive(Clone, Debug, Default)]
pub struct ReplayReport {
    pub frames: usize,
    /// Sum of each reward term (mean = sum / frames), in `reward::TERM_NAMES` order.
    pub term_sums: [f64; NUM_TERMS],
    /// Imitation metrics with the contact graph taken from the clip labels.
    pub metrics_label_contacts: ImitationMetrics,
    /// Imitation metrics with MuJoCo's exact contact graph.
    pub metrics_sim_contacts: ImitationMetrics,
    /// Imitation metrics as the imitation task scores a frame: the simulated contact graph of
    /// `reward_cfg.contact_graph` against the reference graph of the same mode. Their Acc is
    /// the ceiling of a policy's Acc on these clips ([`acc_ceiling`]).
    pub metrics_task_contacts: ImitationMetrics,
    /// Frames whose label is 1 / 0, and how many of them MuJoCo reports a hand–ball contact.
    pub label1_frames: usize,
    pub label1_detected: usize,
    pub label0_frames: usize,
    pub label0_detected: usize,
    /// Per label-1 frame: distance (m) from the ball surface to the nearest hand body origin.
    pub label1_hand_gap: Vec<f64>,
    /// Force-threshold graph (threshold of `reward_cfg`): label-1 / label-0 frames whose ball
    /// node is 1, and frames whose body node is 1 (its target is always 0).
    pub force_ball_label1: usize,
    pub force_ball_label0: usize,
    pub force_body_on: usize,
}

impl ReplayReport {
    /// Mean of reward term `name`.
    pub fn term_mean(&self, name: &str) -> f64 {
        let k = TERM_NAMES.iter().position(|n| *n == name).expect("term name");
        self.term_sums[k] / self.frames.max(1) as f64
    }
    /// Fraction of frames where MuJoCo's hand–ball contact equals the label.
    pub fn contact_agreement(&self) -> f64 {
        let agree = self.label1_detected + (self.label0_frames - self.label0_detected);
        agree as f64 / (self.label1_frames + self.label0_frames).max(1) as f64
    }
    /// Fraction of frames where the force-threshold ball node equals the label.
    pub fn force_ball_agreement(&self) -> f64 {
        let agree = self.force_ball_label1 + (self.label0_frames - self.force_ball_label0);
        agree as f64 / (self.label1_frames + self.label0_frames).max(1) as f64
    }
    /// Fraction of frames where the force-threshold body node is 0 (its target).
    pub fn force_body_agreement(&self) -> f64 {
        1.0 - self.force_body_on as f64 / self.frames.max(1) as f64
    }
}

/// Replay clips `clips` of `lib` frame by frame (frames 1 … T−1) in `scene` and score each frame
/// against itself with `reward_cfg` (contact-graph term taken from the labels).
pub fn kinematic_replay(
    scene: Arc<Scene>,
    lib: &MotionLibrary,
    clips: &[usize],
    reward_cfg: &RewardConfig,
) -> Result<ReplayReport, SimError> {
    const N: usize = 32;
    let mut sim = BatchSim::new(scene, N, 0)?;
    let mut rep = ReplayReport::default();
    let hands = skillmimic_core::characters::skillmimic::BODIES
        .iter()
        .enumerate()
        .filter(|(b, _)| {
            skillmimic_core::characters::skillmimic::body_part(*b)
                == skillmimic_core::characters::BodyPart::Hand
        })
        .map(|(b, _)| b)
        .collect::<Vec<_>>();
    for &ci in clips {
        let m = lib.get(ci);
        let ball_free = BALL_FREE_SKILLS.contains(&m.clip.skill);
        let frames: Vec<usize> = (1..m.clip.num_frames).collect();
        for chunk in frames.chunks(N) {
            let mut mask = vec![false; N];
            let mut states = vec![ResetState::default(); N];
            for (e, &t) in chunk.iter().enumerate() {
                mask[e] = true;
                states[e] = reset_state_from_clip(m, t);
            }
            sim.reset(&mask, &states)?;
            for (e, &t) in chunk.iter().enumerate() {
                let st = sim.state().env(e);
                let s = HoiState::from_sim(&st);
                let r = HoiState::from_reference(m, t);
                let label = m.clip.contact[t] as f64;
                let cg_ref = ContactGraph::reference(label, ContactGraphMode::Exact);
                let cg_sim = ContactGraph::from_sim(
                    &st,
                    ContactGraphMode::Exact,
                    reward_cfg.force_threshold,
                );
                let cg_force = ContactGraph::from_sim(
                    &st,
                    ContactGraphMode::ForceThreshold,
                    reward_cfg.force_threshold,
                );
                let (ball_node, body_node) = (cg_force.values[0] != 0.0, cg_force.values[1] != 0.0);
                let mode = reward_cfg.contact_graph;
                let cg_task = ContactGraph::from_sim(&st, mode, reward_cfg.force_threshold);
                let cg_task_ref = ContactGraph::reference(label, mode);
                rep.force_body_on += usize::from(body_node);
                let prev: [f64; NUM_DOFS] =
                    std::array::from_fn(|j| m.reference.dof_vel[(t - 1) * NUM_DOFS + j] as f64);
                let terms = reward::compute(
                    &s,
                    &prev,
                    &r,
                    &cg_ref,
                    &cg_ref,
                    reward_cfg,
                    crate::compat::Compat::Paper,
                    ball_free,
                );
                for (acc, v) in rep.term_sums.iter_mut().zip(terms.as_array()) {
                    *acc += v;
                }
                let mut body = dist(s.root_pos, r.root_pos);
                for k in 0..s.key_pos.len() {
                    body += dist(s.key_pos[k], r.key_pos[k]);
                }
                let body = body / (1 + s.key_pos.len()) as f64;
                let ball = dist(s.ball_pos, r.ball_pos);
                rep.metrics_label_contacts.add(&[body as f32, ball as f32, 1.0, 0.0]);
                rep.metrics_task_contacts.add(&[
                    body as f32,
                    ball as f32,
                    f32::from(u8::from(cg_task.matches(&cg_task_ref))),
                    cg_task.sq_error(&cg_task_ref) as f32,
                ]);
                let m_sim = cg_sim.matches(&cg_ref);
                rep.metrics_sim_contacts.add(&[
                    body as f32,
                    ball as f32,
                    f32::from(u8::from(m_sim)),
                    cg_sim.sq_error(&cg_ref) as f32,
                ]);
                let detected = cg_sim.values[0] != 0.0;
                if label != 0.0 {
                    rep.label1_frames += 1;
                    rep.label1_detected += usize::from(detected);
                    rep.force_ball_label1 += usize::from(ball_node);
                    let radius = sim.scene().options().ball.map_or(0.0, |b| b.radius);
                    let gap = hands
                        .iter()
                        .map(|&b| dist(st.pos(b), s.ball_pos))
                        .fold(f64::INFINITY, f64::min)
                        - radius;
                    rep.label1_hand_gap.push(gap);
                } else {
                    rep.label0_frames += 1;
                    rep.label0_detected += usize::from(detected);
                    rep.force_ball_label0 += usize::from(ball_node);
                }
                rep.frames += 1;
            }
        }
    }
    Ok(rep)
}

/// Acc (percent) of a kinematic replay of every clip of `lib` in the scene of `cfg`, each frame
/// scored as the imitation task scores it ([`ReplayReport::metrics_task_contacts`]): the highest
/// Acc a policy can reach on these clips. The clips' hand–ball labels and the simulated contact
/// graph disagree in some frames even on the reference motion itself (docs/fidelity.md: the ball
/// node matches the label in 70.3 % of the 64 BallPlay-M clips' frames, and the ceiling is
/// 69.3 %, with the force-threshold graph).
pub fn acc_ceiling(cfg: &crate::EnvConfig, lib: &MotionLibrary) -> Result<f64, crate::EnvError> {
    let scene = Arc::new(Scene::new(cfg.scene_options()?)?);
    let all: Vec<usize> = (0..lib.len()).collect();
    let rep = kinematic_replay(scene, lib, &all, &cfg.reward)?;
    Ok(rep.metrics_task_contacts.acc_percent())
}
