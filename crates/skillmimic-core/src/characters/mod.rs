//! The simulated characters, each described once: its body tree (depth-first), joints and their
//! PD drives, the action → PD target map, geometry, body parts and the rates it is simulated at.
//!
//! A character module holds its skeleton table and builds a [`CharacterSpec`] from it
//! ([`Character::spec`]); the MJCF generator, the simulation batch, the state read-out and the
//! environments' character-level rules (proprioception, fall rule) read only the spec, so adding
//! a character is one module here declaring its [`CharacterEntry`] plus one line in
//! [`REGISTERED`]:
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

mod entry;
pub mod skillmimic;
pub mod smpl;
mod spec;
pub mod tokenhsi;

pub use entry::{Character, CharacterEntry};
pub use spec::{
    ActionMap, BodyDef, BodyPart, CharacterSpec, Drive, GeomDef, GeomSpec, HandModel, Hinge,
    IDENTITY_WXYZ, JointDef, Proprioception, intrinsic_xyz, xyz_hinges,
};

/// The registered characters, in listing order.
// ANCHOR: registered
pub const REGISTERED: &[&CharacterEntry] = &[&skillmimic::ENTRY, &tokenhsi::ENTRY, &smpl::ENTRY];
// ANCHOR_END: registered

impl Default for Character {
    /// The SkillMimic humanoid with articulated hands.
    fn default() -> Self {
        skillmimic::humanoid(HandModel::Full)
    }
}

/// Listing and lookup over [`REGISTERED`].
impl Character {
    /// Registry names, in listing order.
    pub const NAMES: [&'static str; REGISTERED.len()] = {
        let mut names = [""; REGISTERED.len()];
        let mut i = 0;
        while i < names.len() {
            names[i] = REGISTERED[i].name;
            i += 1;
        }
        names
    };

    /// Every character with every variant, in listing order (the shipped scenes of `mjcf/`).
    pub fn variants() -> Vec<Character> {
        REGISTERED.iter().flat_map(|e| e.hands.iter().map(move |&h| Character::new(e, h))).collect()
    }
    /// The character called `name` (`hands` applies to characters with hand variants).
    pub fn by_name(name: &str, hands: HandModel) -> Option<Self> {
        REGISTERED.iter().find(|e| e.name == name).map(|e| Character::new(e, hands))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_character_spec_is_consistent() {
        for c in Character::variants() {
            let s = c.spec();
            s.check().unwrap_or_else(|e| panic!("{}: {e}", c.name()));
            assert_eq!(
                Character::by_name(c.name(), HandModel::Box).map(|c| c.name()),
                Some(c.name())
            );
            let driven: usize = s.bodies.iter().map(|b| b.joint.dofs()).sum();
            assert!(driven <= s.num_dofs && driven > 0, "{}", c.name());
        }
        assert_eq!(tokenhsi::CHARACTER.spec().num_dofs, 32);
        assert_eq!(Character::default().spec().proprio_dim(), 823);
        assert_eq!(tokenhsi::CHARACTER.spec().proprio_dim(), 222);
        assert_eq!(smpl::CHARACTER.spec().proprio_dim(), 358);
        // local rotations round-trip through the dof coordinates of every joint kind
        for c in [Character::default(), tokenhsi::CHARACTER, smpl::CHARACTER] {
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
        assert_eq!(smpl::CHARACTER.spec().num_dofs, 69);
        assert_eq!(Character::default().spec().num_dofs, 156);
    }
}
