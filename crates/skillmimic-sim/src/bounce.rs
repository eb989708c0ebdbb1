//! PhysX's bounce threshold for the ball–floor contact, which MuJoCo lacks.
//!
//! PhysX applies restitution only to impacts whose normal approach speed exceeds the bounce
//! threshold (0.2 m/s in the reference); slower impacts are inelastic. MuJoCo's contacts are
//! spring–dampers whose rebound follows from `solref` alone, so a ball resting on the floor keeps
//! micro-bouncing and a slow impact bounces like a fast one.
//!
//! The rule, applied after every physics sub-step (floor plane z = 0, ball radius r):
//! * a contact starts on the first sub-step that ends with the ball below z = r; its impact
//!   speed is the ball's downward speed −v_z at that moment (no contact force acted yet);
//! * if the impact speed is below the threshold the contact is inelastic: for as long as the
//!   ball stays below z = r, an upward v_z is set to 0 (the position update of each sub-step
//!   still lets the contact push the ball out to its resting depth);
//! * the contact ends when the ball is above z = r again.
//!
//! Only the floor contact follows the rule (the contacts with the humanoid keep their soft
//! restitution). The parity tests' PyPI-mujoco shadows apply the same rule.

/// Per-environment state of the rule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BounceState {
    /// The ball was below z = r after the previous sub-step.
    pub touching: bool,
    /// The current floor contact started slower than the threshold.
    pub inelastic: bool,
}

impl BounceState {
    /// Apply the rule after a sub-step. `z` = ball centre height (m), `vz` = its vertical
    /// velocity (m/s, modified in place), `radius` (m), `threshold` (m/s; ≤ 0 = off).
    #[inline]
    pub fn apply(&mut self, z: f64, vz: &mut f64, radius: f64, threshold: f64) {
        if threshold <= 0.0 {
            return;
        }
        let touching = z < radius;
        if touching && !self.touching {
            self.inelastic = -*vz < threshold;
        }
        if !touching {
            self.inelastic = false;
        }
        if touching && self.inelastic && *vz > 0.0 {
            *vz = 0.0;
        }
        self.touching = touching;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_impacts_do_not_rebound_and_fast_ones_keep_their_speed() {
        let r = 0.12;
        // fast impact: 1 m/s down, then the contact pushes the ball up at 0.8 m/s
        let mut s = BounceState::default();
        let mut v = -1.0;
        s.apply(0.5, &mut v, r, 0.2);
        s.apply(0.119, &mut v, r, 0.2);
        assert!(!s.inelastic);
        let mut up = 0.8;
        s.apply(0.118, &mut up, r, 0.2);
        assert_eq!(up, 0.8);
        // slow impact: 0.1 m/s down; the rebound is removed while touching
        let mut s = BounceState::default();
        let mut v = -0.1;
        s.apply(0.119, &mut v, r, 0.2);
        assert!(s.inelastic);
        let mut up = 0.05;
        s.apply(0.1195, &mut up, r, 0.2);
        assert_eq!(up, 0.0);
        // leaving the floor ends the contact
        let mut v = 0.3;
        s.apply(0.2, &mut v, r, 0.2);
        assert!(!s.touching && !s.inelastic && v == 0.3);
        // threshold 0: the rule is off
        let mut s = BounceState::default();
        let mut v = -0.01;
        s.apply(0.119, &mut v, r, 0.0);
        let mut up = 0.05;
        s.apply(0.119, &mut up, r, 0.0);
        assert_eq!(up, 0.05);
    }
}
