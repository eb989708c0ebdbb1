//! The BallPlay-M row layout (one row per frame, 60 fps), shared by the `.pt` reader
//! ([`crate::pt`]) and the clip decoder ([`crate::clip`]). This module depends on no other module
//! of the crate.
//!
//! | columns | content |
//! |---|---|
//! | 0:3 | root (Pelvis) position, world, m (Z-up) |
//! | 3:6 | root rotation, exponential map (rad), includes the Y-up → Z-up tilt |
//! | 6:9 | duplicate of 3:6 (ignored) |
//! | 9:165 | 52 × 3 joint rotations, exp map of each body relative to its parent |
//! | 165:324 | 53 × 3 world positions of all bodies (not exactly FK of the joints, see docs) |
//! | 324:327 | ball centre, world, m |
//! | 327:330 | ball rotation exp map, stored negated (all zero in the shipped data) |
//! | 330:336 | unused |
//! | 336 | hand–ball contact label (0/1) |

/// Width of a BallPlay-M row.
pub const PT_WIDTH: usize = 337;
/// Frame rate of BallPlay-M clips (Hz).
pub const BALLPLAY_FPS: f64 = 60.0;

/// Name of the field a BallPlay-M column belongs to (error messages).
pub fn pt_column_field(c: usize) -> &'static str {
    match c {
        0..=2 => "root position",
        3..=8 => "root rotation",
        9..=164 => "joint rotations",
        165..=323 => "body positions",
        324..=326 => "ball position",
        327..=329 => "ball rotation",
        330..=335 => "unused",
        _ => "contact label",
    }
}
