//! Checks shared by the tests of the procedural TokenHSI clips.

use skillmimic_core::characters::tokenhsi::{BODIES, JointSpec};
use skillmimic_motion::character_clip::CharacterClip;

/// Panic unless every entry of the 32-d dof vector `dof` (rad) lies within its hinge's range in
/// the released asset (`tokenhsi::BODIES`, degrees, ± 1e-6); `what` names the clip and frame.
pub fn assert_in_released_ranges(what: &str, dof: &[f32]) {
    let mut k = 0;
    for b in BODIES.iter() {
        let ranges: Vec<[f64; 2]> = match b.joint {
            JointSpec::Triple { range_deg, .. } => range_deg.to_vec(),
            JointSpec::HingeY { range_deg, .. } => vec![range_deg],
            _ => vec![],
        };
        for r in ranges {
            let deg = (dof[k] as f64).to_degrees();
            assert!(
                deg >= r[0] - 1e-6 && deg <= r[1] + 1e-6,
                "{what}: {} axis {k} at {deg:.2}° outside {r:?}",
                b.joint_name
            );
            k += 1;
        }
    }
    assert_eq!(k, 32, "{what}: dofs");
}

/// The dof vector (rad) of `clip`'s frame `t` in f64.
#[allow(dead_code)] // not every test binary that includes this module uses it
pub fn dof(clip: &CharacterClip, t: usize) -> Vec<f64> {
    clip.dof_at(t).iter().map(|&x| x as f64).collect()
}

/// [`assert_in_released_ranges`] at every frame of `clip`.
#[allow(dead_code)] // not every test binary that includes this module uses it
pub fn assert_clip_in_released_ranges(clip: &CharacterClip) {
    for t in 0..clip.num_frames {
        assert_in_released_ranges(&format!("{} frame {t}", clip.name), clip.dof_at(t));
    }
}
