//! A registered character: what its module declares ([`CharacterEntry`]) and a selected
//! character with its variant ([`Character`]). The list of registered characters is
//! `REGISTERED` of the characters module; this file knows none of them.

use super::spec::{CharacterSpec, HandModel};

/// Body parts of a split: each part's name and bodies (ModSkill's part-wise control).
pub type BodyParts = Vec<(&'static str, Vec<usize>)>;

/// What a character module declares about itself; its entry in
/// [`REGISTERED`](super::REGISTERED) is the one line that makes it selectable (`env.character`,
/// the `mjcf/` scenes, every task that lists it).
#[derive(Debug)]
pub struct CharacterEntry {
    /// Registry name (the value of `env.character`).
    pub name: &'static str,
    /// One line for listings.
    pub summary: &'static str,
    /// The hand models it comes in (`env.hands`): several for the SkillMimic humanoid, the single
    /// [`HandModel::Full`] for a character without variants.
    pub hands: &'static [HandModel],
    /// Whether it is the BallPlay-M character: its default scene holds the ball and it plays
    /// BallPlay-M clips as they are. Other characters get those clips retargeted or play their
    /// own character clips.
    pub ballplay: bool,
    /// The character's description for one of its hand models.
    pub spec: fn(HandModel) -> CharacterSpec,
    /// ModSkill's body parts by split name (`ppo.modular.parts`: `"five"`, …): each part's name
    /// and bodies, every driven body in exactly one part; `None` for a split the character does
    /// not have (`|_| None`: no modular policy on this character).
    pub body_parts: fn(&str) -> Option<BodyParts>,
}

/// A registered character with its variant (hand model); characters without variants carry
/// their single hand model, so two values are equal exactly when they build the same spec.
#[derive(Clone, Copy)]
pub struct Character {
    entry: &'static CharacterEntry,
    hands: HandModel,
}

impl PartialEq for Character {
    fn eq(&self, other: &Self) -> bool {
        self.entry.name == other.entry.name && self.hands == other.hands
    }
}

impl Eq for Character {}

impl std::fmt::Debug for Character {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.hands() {
            Some(h) => write!(f, "Character({}, {})", self.entry.name, h.name()),
            None => write!(f, "Character({})", self.entry.name),
        }
    }
}

impl Character {
    /// `entry` with `hands`; a hand model the character does not come in is replaced by its
    /// first one.
    pub const fn new(entry: &'static CharacterEntry, hands: HandModel) -> Self {
        let mut i = 0;
        while i < entry.hands.len() {
            if entry.hands[i] as u8 == hands as u8 {
                return Character { entry, hands };
            }
            i += 1;
        }
        Character { entry, hands: entry.hands[0] }
    }
    /// Registry name.
    pub fn name(self) -> &'static str {
        self.entry.name
    }
    /// What the character's module declares.
    pub fn entry(self) -> &'static CharacterEntry {
        self.entry
    }
    /// The hand model, for a character that comes in several (`None` otherwise).
    pub fn hands(self) -> Option<HandModel> {
        (self.entry.hands.len() > 1).then_some(self.hands)
    }
    /// Whether it is the BallPlay-M character ([`CharacterEntry::ballplay`]).
    pub fn plays_ballplay(self) -> bool {
        self.entry.ballplay
    }
    /// The character's description.
    pub fn spec(self) -> CharacterSpec {
        (self.entry.spec)(self.hands)
    }
    /// ModSkill's body parts of split `split` ([`CharacterEntry::body_parts`]).
    pub fn body_parts(self, split: &str) -> Option<BodyParts> {
        (self.entry.body_parts)(split)
    }
}
