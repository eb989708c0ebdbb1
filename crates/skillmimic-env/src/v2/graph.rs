//! Stitched Trajectory Graph (SkillMimic-V2, seed 003 §4.4): for every start state of every
//! clip, the most similar state of each *other* skill, found after aligning that skill's clip to
//! the start state on the ground plane.
//!
//! For a start state A_t (clip A, frame t) and a candidate B_f (clip B of another skill, frame f)
//! the candidate is aligned by [`align_onto`]: rotated about +z by the heading difference
//! ψ(A_t) − ψ(B_f) and translated so that its root x/y lands on A_t's root x/y (heights kept).
//! The similarity S (same formula as the State Transition Field) is taken between A_t and the
//! aligned B_f; per other skill the best (clip, frame) over frames 2 … T−2 is kept if S ≥ τ,
//! otherwise that skill has no connection from A_t (distant states are excluded).
//!
//! The graph is built once, in parallel, when the environment is created (cost: (total frames)²
//! similarity evaluations — about a second for the six clips of the paper's experiment).

use rayon::prelude::*;
use skillmimic_core::math::heading;
use skillmimic_motion::MotionLibrary;

use crate::config::RewardConfig;
use crate::episode::BALL_FREE_SKILLS;
use crate::hoi::{HoiState, RefAlign};
use crate::v2::similarity::similarity;
use crate::v2::transition::connectable_frames;

/// One connection of the graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Connection {
    /// Skill label of the target clip.
    pub skill: u32,
    /// Library index of the target clip and its connected frame.
    pub clip: usize,
    pub frame: usize,
    /// Similarity β between the start state and the aligned target frame.
    pub similarity: f64,
    /// Ground-plane transform that maps the target clip onto the start state.
    pub align: RefAlign,
}

/// The transform that maps reference state `b` onto `a` on the ground plane: yaw by the heading
/// difference, `b`'s root x/y onto `a`'s root x/y.
pub fn align_onto(a: &HoiState, b: &HoiState) -> RefAlign {
    let ha = heading(skillmimic_core::math::Quat::from_rotvec(a.root_rotvec));
    let hb = heading(skillmimic_core::math::Quat::from_rotvec(b.root_rotvec));
    RefAlign {
        yaw: skillmimic_core::math::wrap_angle(ha - hb),
        pivot: [b.root_pos[0], b.root_pos[1]],
        target: [a.root_pos[0], a.root_pos[1]],
    }
}

/// Similarity of start state `a` to reference state `b` aligned onto it (ball terms off when
/// `ball_free`: the target skill has no ball). Starts from clips without a ball (their ball is
/// random) are not connected to skills with a ball.
pub fn aligned_similarity(
    a: &HoiState,
    b: &HoiState,
    cfg: &RewardConfig,
    ball_free: bool,
) -> (f64, RefAlign) {
    let align = align_onto(a, b);
    (similarity(a, &b.aligned(&align), cfg, ball_free), align)
}

/// The graph: `connections(clip, start)` lists one connection per other skill that has one.
#[derive(Clone, Debug, Default)]
pub struct StitchGraph {
    /// `[clip][start − 2]` → connections.
    table: Vec<Vec<Vec<Connection>>>,
}

impl StitchGraph {
    /// Build the graph of `lib` with the reward weights `cfg` and similarity floor `tau`.
    pub fn build(lib: &MotionLibrary, cfg: &RewardConfig, tau: f64) -> Self {
        let n = lib.len();
        let states: Vec<Vec<HoiState>> = (0..n)
            .into_par_iter()
            .map(|c| {
                let m = lib.get(c);
                (0..m.clip.num_frames).map(|t| HoiState::from_reference(m, t)).collect()
            })
            .collect();
        let skills: Vec<u32> = (0..n).map(|c| lib.get(c).clip.skill).collect();
        let mut classes = skills.clone();
        classes.sort_unstable();
        classes.dedup();
        let table = (0..n)
            .map(|a| {
                let ma = lib.get(a);
                connectable_frames(ma)
                    .into_par_iter()
                    .map(|t| {
                        let sa = &states[a][t];
                        let mut out = Vec::new();
                        let source_free = BALL_FREE_SKILLS.contains(&skills[a]);
                        for &class in classes.iter().filter(|&&c| c != skills[a]) {
                            let ball_free = BALL_FREE_SKILLS.contains(&class);
                            if source_free && !ball_free {
                                // the start state has a random ball: it cannot continue a ball
                                // skill
                                continue;
                            }
                            let mut best: Option<Connection> = None;
                            for b in (0..n).filter(|&b| skills[b] == class) {
                                for f in connectable_frames(lib.get(b)) {
                                    let (s, align) =
                                        aligned_similarity(sa, &states[b][f], cfg, ball_free);
                                    if s >= tau && best.is_none_or(|c| s > c.similarity) {
                                        best = Some(Connection {
                                            skill: class,
                                            clip: b,
                                            frame: f,
                                            similarity: s,
                                            align,
                                        });
                                    }
                                }
                            }
                            out.extend(best);
                        }
                        out
                    })
                    .collect()
            })
            .collect();
        Self { table }
    }

    /// Connections from start frame `start` (2 … T−2) of `clip`; empty outside that range.
    pub fn connections(&self, clip: usize, start: usize) -> &[Connection] {
        start
            .checked_sub(2)
            .and_then(|k| self.table.get(clip)?.get(k))
            .map_or(&[], |v| v.as_slice())
    }

    /// Number of start states with at least one connection, and the total number of connections.
    pub fn stats(&self) -> (usize, usize) {
        let starts = self.table.iter().flatten().filter(|v| !v.is_empty()).count();
        let total = self.table.iter().flatten().map(Vec::len).sum();
        (starts, total)
    }
}
