//! SkillMimic-skeleton clips onto the other registered characters: the one table of the
//! retargets this crate has ([`crate::retarget_hsi`], [`crate::retarget_smpl`]), keyed by the
//! character's registry name. A new character that should track BallPlay-M clips adds its
//! retarget here; without one it tracks its own character clips.

use skillmimic_core::characters::{smpl, tokenhsi};

use crate::character_clip::CharacterClip;
use crate::clip::Clip;

/// A SkillMimic-skeleton clip as a clip of the character (the retarget's report dropped).
pub type Retarget = fn(&Clip) -> CharacterClip;

/// Registry name → retarget.
pub const RETARGETS: &[(&str, Retarget)] = &[
    (tokenhsi::ENTRY.name, |c| crate::retarget_hsi::retarget_to_hsi(c).0),
    (smpl::ENTRY.name, |c| crate::retarget_smpl::retarget_to_smpl(c).0),
];

/// The retarget onto the character called `character`, if this crate has one.
pub fn onto(character: &str) -> Option<Retarget> {
    RETARGETS.iter().find(|(name, _)| *name == character).map(|&(_, f)| f)
}
