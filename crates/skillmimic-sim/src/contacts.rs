//! Contact classification from MuJoCo's exact contact pairs.
//!
//! Character bodies are grouped by their [`BodyPart`] (the character's table: the SkillMimic
//! humanoid's *hand* = wrist + fingers, *foot* = ankle + toe, *trunk* = every other body).
//! Contacts with box objects are not classified. The pair kinds below are what the contact graph and the
//! evaluation need; each is 1 when at least one active contact of that kind exists.

use skillmimic_core::characters::BodyPart;

use crate::scene::GeomOwner;

/// Kinds of contact pairs recorded per environment and step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(usize)]
pub enum ContactPair {
    /// A hand (wrist or finger) touches the ball.
    HandBall = 0,
    /// A non-hand humanoid body (trunk or foot) touches the ball.
    BodyBall = 1,
    /// A hand touches a non-hand humanoid body (self-contact).
    HandBody = 2,
    /// The ball touches the floor.
    BallFloor = 3,
    /// A trunk body (not hand, not foot) touches the floor.
    BodyFloor = 4,
    /// A foot touches the floor.
    FootFloor = 5,
    /// A hand touches the floor.
    HandFloor = 6,
}

/// Number of [`ContactPair`] kinds.
pub const NUM_CONTACT_PAIRS: usize = 7;

impl ContactPair {
    /// All kinds in index order.
    pub const ALL: [ContactPair; NUM_CONTACT_PAIRS] = [
        ContactPair::HandBall,
        ContactPair::BodyBall,
        ContactPair::HandBody,
        ContactPair::BallFloor,
        ContactPair::BodyFloor,
        ContactPair::FootFloor,
        ContactPair::HandFloor,
    ];

    /// snake_case name (logs, Python dict keys).
    pub fn name(self) -> &'static str {
        match self {
            ContactPair::HandBall => "hand_ball",
            ContactPair::BodyBall => "body_ball",
            ContactPair::HandBody => "hand_body",
            ContactPair::BallFloor => "ball_floor",
            ContactPair::BodyFloor => "body_floor",
            ContactPair::FootFloor => "foot_floor",
            ContactPair::HandFloor => "hand_floor",
        }
    }

    /// The kind of a contact between two geoms, if it is one we record; `parts` = the
    /// character bodies' anatomical parts.
    pub fn classify(a: GeomOwner, b: GeomOwner, parts: &[BodyPart]) -> Option<ContactPair> {
        use GeomOwner::*;
        let body_part = |x: usize| parts[x];
        let (a, b) = if rank(a) <= rank(b) { (a, b) } else { (b, a) };
        match (a, b) {
            (Floor, Ball) => Some(ContactPair::BallFloor),
            (Floor, Body(x)) => Some(match body_part(x) {
                BodyPart::Hand => ContactPair::HandFloor,
                BodyPart::Foot => ContactPair::FootFloor,
                BodyPart::Trunk => ContactPair::BodyFloor,
            }),
            (Ball, Body(x)) => Some(if body_part(x) == BodyPart::Hand {
                ContactPair::HandBall
            } else {
                ContactPair::BodyBall
            }),
            (Body(x), Body(y)) => {
                let hx = body_part(x) == BodyPart::Hand;
                let hy = body_part(y) == BodyPart::Hand;
                (hx != hy).then_some(ContactPair::HandBody)
            }
            _ => None,
        }
    }
}

fn rank(o: GeomOwner) -> u8 {
    match o {
        GeomOwner::Floor => 0,
        GeomOwner::Ball => 1,
        GeomOwner::Object(_) => 2,
        GeomOwner::Body(_) => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use GeomOwner::*;

    #[test]
    fn pairs_are_classified_symmetrically() {
        let parts: Vec<_> = skillmimic_core::characters::skillmimic::spec(Default::default())
            .bodies
            .iter()
            .map(|b| b.part)
            .collect();
        let classify = |a, b| ContactPair::classify(a, b, &parts);
        // 21 = L_Index3 (hand), 3 = L_Ankle (foot), 0 = Pelvis (trunk), 18 = L_Wrist, 37 = R_Wrist
        assert_eq!(classify(Ball, Body(21)), Some(ContactPair::HandBall));
        assert_eq!(classify(Body(21), Ball), Some(ContactPair::HandBall));
        assert_eq!(classify(Body(3), Ball), Some(ContactPair::BodyBall));
        assert_eq!(classify(Body(0), Body(18)), Some(ContactPair::HandBody));
        assert_eq!(classify(Body(18), Body(37)), None);
        assert_eq!(classify(Body(0), Body(3)), None);
        assert_eq!(classify(Ball, Floor), Some(ContactPair::BallFloor));
        assert_eq!(classify(Floor, Body(0)), Some(ContactPair::BodyFloor));
        assert_eq!(classify(Floor, Body(4)), Some(ContactPair::FootFloor));
        assert_eq!(classify(Body(52), Floor), Some(ContactPair::HandFloor));
        assert_eq!(classify(Object(0), Body(52)), None);
        assert!(ContactPair::ALL.iter().enumerate().all(|(i, p)| *p as usize == i));
    }
}
