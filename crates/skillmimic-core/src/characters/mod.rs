//! The simulated characters, each described once: its body tree (depth-first), joints and their
//! PD drives, the action → PD target map, geometry, body parts and the rates it is simulated at.
//!
//! A character module holds its skeleton table and builds a [`CharacterSpec`] from it
//! ([`Character::spec`]); the MJCF generator, the simulation batch, the state read-out and the
//! environments' character-level rules (proprioception, fall rule) read only the spec, so adding
//! a character is one module here plus one line in [`Character`]:
//!
//! * [`skillmimic`]: the 53-body SkillMimic humanoid (BallPlay-M skeleton, 52 ball joints, 156
//!   dofs; articulated or welded fingers);
//! * [`tokenhsi`]: the 15-body TokenHSI character (ten 3-DoF joints, two elbow hinges, 32 dofs);
//! * [`smpl`]: the 24-body SMPL humanoid of PHC, ModSkill and ProtoMotions (23 joints of three
//!   hinges each, 69 dofs).
//!
//! Conventions: metres, radians, kg/m³; positions and offsets in the parent body's frame;
//! quaternions w, x, y, z (MuJoCo's order). A 3-DoF ball joint's coordinates are the rotation
//! vector (exponential map) of the body relative to its parent; a hinge's its angle.

pub mod skillmimic;
pub mod smpl;
mod spec;
pub mod tokenhsi;

pub use spec::{
    ActionMap, BodyDef, BodyPart, CharacterSpec, Drive, GeomDef, GeomSpec, HandModel, Hinge,
    JointDef, Proprioception, intrinsic_xyz,
};

/// The registered characters (with their variant options).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Character {
    /// The SkillMimic humanoid ([`skillmimic`]).
    SkillMimic { hands: HandModel },
    /// The TokenHSI character ([`tokenhsi`]).
    TokenHsi,
    /// The SMPL humanoid ([`smpl`]).
    Smpl,
}

impl Default for Character {
    fn default() -> Self {
        Character::SkillMimic { hands: HandModel::Full }
    }
}

impl Character {
    /// Registry names, in listing order (the value of `env.character`).
    pub const NAMES: [&'static str; 3] = ["skillmimic", "tokenhsi", "smpl"];

    /// Every character with every variant, in listing order (the shipped scenes of `mjcf/`).
    pub const VARIANTS: [Character; 4] = [
        Character::SkillMimic { hands: HandModel::Full },
        Character::SkillMimic { hands: HandModel::Box },
        Character::TokenHsi,
        Character::Smpl,
    ];

    /// Registry name.
    pub fn name(self) -> &'static str {
        match self {
            Character::SkillMimic { .. } => "skillmimic",
            Character::TokenHsi => "tokenhsi",
            Character::Smpl => "smpl",
        }
    }
    /// The character called `name` (`hands` applies to the SkillMimic humanoid).
    pub fn by_name(name: &str, hands: HandModel) -> Option<Self> {
        match name {
            "skillmimic" => Some(Character::SkillMimic { hands }),
            "tokenhsi" => Some(Character::TokenHsi),
            "smpl" => Some(Character::Smpl),
            _ => None,
        }
    }
    /// The character's description.
    pub fn spec(self) -> CharacterSpec {
        match self {
            Character::SkillMimic { hands } => skillmimic::spec(hands),
            Character::TokenHsi => tokenhsi::spec(),
            Character::Smpl => smpl::spec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_character_spec_is_consistent() {
        for c in Character::VARIANTS {
            let s = c.spec();
            s.check().unwrap_or_else(|e| panic!("{}: {e}", c.name()));
            assert_eq!(
                Character::by_name(c.name(), HandModel::Box).map(|c| c.name()),
                Some(c.name())
            );
            let driven: usize = s.bodies.iter().map(|b| b.joint.dofs()).sum();
            assert!(driven <= s.num_dofs && driven > 0, "{}", c.name());
        }
        assert_eq!(Character::TokenHsi.spec().num_dofs, 32);
        assert_eq!(Character::default().spec().proprio_dim(), 823);
        assert_eq!(Character::TokenHsi.spec().proprio_dim(), 222);
        assert_eq!(Character::Smpl.spec().proprio_dim(), 358);
        // local rotations round-trip through the dof coordinates of every joint kind
        for c in [Character::default(), Character::TokenHsi, Character::Smpl] {
            let s = c.spec();
            let dof: Vec<f64> = (0..s.num_dofs).map(|k| 0.6 * ((k as f64) * 1.7).sin()).collect();
            let mut back = vec![0.0; s.num_dofs];
            for b in 1..s.bodies.len() {
                s.set_local_rotation(b, s.local_rotation(b, &dof), &mut back);
            }
            for b in 1..s.bodies.len() {
                let (q, r) = (s.local_rotation(b, &dof), s.local_rotation(b, &back));
                let single_hinge = matches!(&s.bodies[b].joint, JointDef::Hinges { hinges, .. } if hinges.len() == 1);
                let angle = q.conj().mul(r).angle();
                assert!(single_hinge || angle < 1e-12, "{} body {b}: {angle}", c.name());
            }
        }
        assert_eq!(Character::Smpl.spec().num_dofs, 69);
        assert_eq!(Character::default().spec().num_dofs, 156);
    }
}
