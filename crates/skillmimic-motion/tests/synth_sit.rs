//! The procedural stand-to-sit clips (`synth_sit`): joint ranges of the released
//! asset, both feet planted and flat, the seated pelvis resting on the seat's top, the legs clear
//! of the seat's front edge.

mod common;

use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::Quat;
use skillmimic_motion::synth_sit::{PELVIS_RADIUS, sit};

#[test]
fn the_sit_clip_is_planted_in_range_and_ends_on_the_seat() {
    let spec = tokenhsi::spec();
    let rest = spec.forward_kinematics(spec.root_pos, Quat::IDENTITY, &[0.0; 32]);
    let rest_low = spec.lowest_foot_box(&rest.0, &rest.1);
    for h in [0.35, 0.45, 0.55] {
        let s = sit("sit", h).unwrap();
        let c = &s.clip;
        let mut left_slide: f64 = 0.0;
        for t in 0..c.num_frames {
            let dof: Vec<f64> = c.dof_at(t).iter().map(|&x| x as f64).collect();
            common::assert_in_released_ranges(&format!("seat {h} frame {t}"), c.dof_at(t));
            let (pos, rot) = spec.forward_kinematics(c.root_pos_at(t), c.root_quat_at(t), &dof);
            // feet flat on the floor as in the rest pose
            assert!((spec.lowest_foot_box(&pos, &rot) - rest_low).abs() < 2e-3, "h {h} frame {t}");
            for f in tokenhsi::FEET {
                let d = ((pos[f][0] - rest.0[f][0]).powi(2) + (pos[f][1] - rest.0[f][1]).powi(2))
                    .sqrt();
                if f == tokenhsi::FEET[0] {
                    assert!(d < 1e-6, "h {h} frame {t}: the right foot moved {d}");
                } else {
                    left_slide = left_slide.max(d);
                }
            }
            // knees and shins stay in front of a 0.5-m-deep seat's front edge
            let front = s.seat_top[0] + 0.25;
            for b in [10, 11, 13, 14] {
                assert!(
                    pos[b][0] > front + 0.04,
                    "h {h} frame {t}: body {b} at x {:.3}, seat front {front:.3}",
                    pos[b][0]
                );
            }
        }
        assert!(left_slide < 5e-3, "h {h}: the left foot slides {left_slide}");
        let end = c.root_pos_at(c.num_frames - 1);
        assert!((end[2] - h - PELVIS_RADIUS).abs() < 1e-4, "h {h}: seated root at {}", end[2]);
        assert!((end[0] - s.seat_top[0]).abs() < 1e-6 && (s.seat_top[2] - h).abs() < 1e-12);
        println!(
            "seat {h}: hip {:.3} rad, left foot slides {:.2} mm, root moves back {:.3} m",
            s.hip_seated,
            1e3 * left_slide,
            -end[0]
        );
    }
    assert!(sit("x", 0.1).unwrap_err().starts_with("seat_height"));
}
