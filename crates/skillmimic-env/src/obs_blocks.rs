//! Named blocks of observation columns, and the observation layouts tasks declare in the
//! registry ([`ObsLayout`]): what the ONNX metadata, the gymnasium observation space (bounds)
//! and the documentation read, for any task on any character, without building an environment.

use std::ops::Range;

use crate::obs::{BLOCKS, layout};
use skillmimic_core::characters::{CharacterSpec, Proprioception};

/// A named block of observation columns.
#[derive(Clone, Debug, PartialEq)]
pub struct ObsBlock {
    pub name: String,
    pub range: Range<usize>,
    /// Lower and upper bound of every value of the block, when bounded by construction.
    pub bounds: Option<(f32, f32)>,
}

impl ObsBlock {
    /// An unbounded block.
    pub fn new(name: impl Into<String>, range: Range<usize>) -> Self {
        Self { name: name.into(), range, bounds: None }
    }
    /// A block of values in `[lo, hi]`.
    pub fn bounded(name: impl Into<String>, range: Range<usize>, lo: f32, hi: f32) -> Self {
        Self { name: name.into(), range, bounds: Some((lo, hi)) }
    }
}

/// The SkillMimic observation's blocks ([`BLOCKS`]: the humanoid, the ball, the skill one-hot;
/// rotation columns in [−1, 1], the one-hot in [0, 1]) up to column `end`, and, when `history`
/// > 0, the SkillMimic-V2 history embedding after the skill one-hot.
pub fn skillmimic_blocks(end: usize, history: usize) -> Vec<ObsBlock> {
    let mut v: Vec<ObsBlock> = BLOCKS
        .iter()
        .filter(|(_, r)| r.end <= end)
        .map(|(name, r)| match *name {
            "body_rot" | "ball_rot" => ObsBlock::bounded(*name, r.clone(), -1.0, 1.0),
            "skill" => ObsBlock::bounded(*name, r.clone(), 0.0, 1.0),
            _ => ObsBlock::new(*name, r.clone()),
        })
        .collect();
    if history > 0 {
        v.push(ObsBlock::new("history_embedding", layout::OBS_DIM..layout::OBS_DIM + history));
    }
    v
}

/// The named blocks of the proprioception of `n` bodies ([`crate::proprio`]), from column 0:
/// `root_height`, `body_pos`, `body_rot` (tan-norm columns, in [−1, 1]), `body_linvel`,
/// `body_angvel`, and `fingertip_force` (the SkillMimic humanoid's contact-force bodies).
pub fn proprio_blocks(p: &Proprioception, n: usize) -> Vec<ObsBlock> {
    let mut out = Vec::new();
    let mut k = 0;
    let mut push = |name: &str, w: usize, bounded: bool| {
        let r = k..k + w;
        k += w;
        out.push(if bounded {
            ObsBlock::bounded(name, r, -1.0, 1.0)
        } else {
            ObsBlock::new(name, r)
        });
    };
    if p.root_height {
        push("root_height", 1, false);
    }
    push("body_pos", 3 * (n - 1), false);
    push("body_rot", 6 * n, true);
    push("body_linvel", 3 * n, false);
    push("body_angvel", 3 * n, false);
    if !p.contact_force_bodies.is_empty() {
        push("fingertip_force", 3 * p.contact_force_bodies.len(), false);
    }
    out
}

/// How a task's observation reads, declared with its registry line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObsLayout {
    /// The SkillMimic observation (humanoid, ball, skill one-hot: 902), then the SkillMimic-V2
    /// history embedding when wider.
    Imitation,
    /// The SkillMimic humanoid and ball state (838), then the task's part named `part`.
    BallState { part: &'static str },
    /// The character's proprioception, then the task's part named `part`.
    Proprio { part: &'static str },
}

impl ObsLayout {
    /// The blocks of an observation `obs_dim` wide on `character`.
    pub fn blocks(self, character: &CharacterSpec, obs_dim: usize) -> Vec<ObsBlock> {
        let (mut v, used, part) = match self {
            ObsLayout::Imitation => {
                return skillmimic_blocks(layout::OBS_DIM, obs_dim.saturating_sub(layout::OBS_DIM));
            }
            ObsLayout::BallState { part } => {
                (skillmimic_blocks(layout::STATE_DIM, 0), layout::STATE_DIM, part)
            }
            ObsLayout::Proprio { part } => (
                proprio_blocks(&character.proprio, character.bodies.len()),
                character.proprio_dim(),
                part,
            ),
        };
        if obs_dim > used {
            v.push(ObsBlock::new(part, used..obs_dim));
        }
        v
    }
}
