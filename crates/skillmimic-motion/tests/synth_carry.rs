//! The procedural TokenHSI carrying walks (`synth_carry`), checked against what carrying a box
//! must be: the joint ranges of the released asset, legs and root exactly those of the walk of
//! the same parameters (so the walk's floor-contact, sliding and speed tests hold for them), the
//! hands on the box's side faces with their mean at the box's centre at every frame (the carry
//! reward's handheld term at its maximum), no other part of the body inside the box, and bad
//! parameters refused by name.

mod common;

use skillmimic_core::characters::GeomSpec;
use skillmimic_core::characters::tokenhsi;
use skillmimic_motion::synth_carry::{
    BOX_RANGE, CARRIES, CarryClip, GRIP_DEPTH, carry, tokenhsi_carries,
};
use skillmimic_motion::synth_walk::{WalkParams, walk};

const HAND_RADIUS: f64 = 0.04;

/// A world point in the clip's root frame at frame `t`.
fn in_root(c: &CarryClip, t: usize, p: [f64; 3]) -> [f64; 3] {
    let (r, q) = (c.clip.root_pos_at(t), c.clip.root_quat_at(t));
    q.conj().rotate([p[0] - r[0], p[1] - r[1], p[2] - r[2]])
}

#[test]
fn every_joint_stays_within_the_released_assets_ranges() {
    for c in tokenhsi_carries() {
        common::assert_clip_in_released_ranges(&c.clip);
    }
}

#[test]
fn legs_trunk_and_root_are_the_walks_frame_for_frame() {
    let arms = [6, 7, 8, 9, 10, 11, 12, 13];
    for (name, p, side) in CARRIES {
        let c = carry(name, p, side).unwrap();
        let w = walk("w", p).unwrap();
        assert_eq!(c.clip.num_frames, w.num_frames, "{name}");
        for t in 0..w.num_frames {
            assert_eq!(c.clip.root_pos_at(t), w.root_pos_at(t), "{name} frame {t}: root");
            assert_eq!(c.clip.root_quat_at(t), w.root_quat_at(t), "{name} frame {t}: heading");
            for k in (0..32).filter(|k| !arms.contains(k)) {
                assert_eq!(c.clip.dof_at(t)[k], w.dof_at(t)[k], "{name} frame {t}: dof {k}");
            }
            // the arms differ from the walk's swing: they hold the box
            assert!(arms.iter().any(|&k| c.clip.dof_at(t)[k] != w.dof_at(t)[k]), "{name} {t}");
        }
    }
}

#[test]
fn the_hands_hold_the_box_at_its_side_faces_at_every_frame() {
    let spec = tokenhsi::spec();
    for c in tokenhsi_carries() {
        let half = 0.5 * c.side;
        let b = c.box_in_root;
        for t in 0..c.clip.num_frames {
            let (pos, _) = spec.forward_kinematics(
                c.clip.root_pos_at(t),
                c.clip.root_quat_at(t),
                &common::dof(&c.clip, t),
            );
            let h = tokenhsi::HANDS.map(|k| in_root(&c, t, pos[k]));
            let mean =
                [0.5 * (h[0][0] + h[1][0]), 0.5 * (h[0][1] + h[1][1]), 0.5 * (h[0][2] + h[1][2])];
            for a in 0..3 {
                assert!(
                    (mean[a] - b[a]).abs() < 1e-4,
                    "{} frame {t}: hands' mean {mean:?} box {b:?}",
                    c.clip.name
                );
            }
            for (k, side) in [(0, -1.0), (1, 1.0)] {
                // on the face: centre depth and height, sunk GRIP_DEPTH into the side face
                let lateral = side * (h[k][1] - b[1]);
                let want = half + HAND_RADIUS - GRIP_DEPTH;
                assert!(
                    (lateral - want).abs() < 1e-4,
                    "{} {t}: hand {k} at {lateral} of {want}",
                    c.clip.name
                );
                assert!((h[k][0] - b[0]).abs() < 1e-4 && (h[k][2] - b[2]).abs() < 1e-4);
            }
        }
    }
}

/// Distance (m) from point `p` to the axis-aligned box of centre `c` and half side `h`.
fn to_box(p: [f64; 3], c: [f64; 3], h: f64) -> f64 {
    let d: Vec<f64> = (0..3).map(|a| ((p[a] - c[a]).abs() - h).max(0.0)).collect();
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

#[test]
fn no_body_but_the_hands_reaches_into_the_box() {
    let spec = tokenhsi::spec();
    for c in tokenhsi_carries() {
        let half = 0.5 * c.side;
        for t in (0..c.clip.num_frames).step_by(2) {
            let (pos, rot) = spec.forward_kinematics(
                c.clip.root_pos_at(t),
                c.clip.root_quat_at(t),
                &common::dof(&c.clip, t),
            );
            let mut closest = f64::INFINITY;
            for (k, body) in spec.bodies.iter().enumerate() {
                if tokenhsi::HANDS.contains(&k) || body.name.contains("lower_arm") {
                    continue; // the hands hold it; the forearms run along its sides
                }
                for g in &body.geoms {
                    let at = |p: [f64; 3]| {
                        let w = rot[k].rotate(p);
                        in_root(&c, t, [pos[k][0] + w[0], pos[k][1] + w[1], pos[k][2] + w[2]])
                    };
                    let (pts, r): (Vec<[f64; 3]>, f64) = match g.spec {
                        GeomSpec::Sphere { radius, center, .. } => (vec![at(center)], radius),
                        GeomSpec::Capsule { radius, from, to, .. } => (
                            (0..=20)
                                .map(|i| {
                                    let s = i as f64 / 20.0;
                                    at([0, 1, 2].map(|a| from[a] + s * (to[a] - from[a])))
                                })
                                .collect(),
                            radius,
                        ),
                        GeomSpec::Box { center, .. } => (vec![at(center)], 0.0),
                    };
                    for p in pts {
                        let gap = to_box(p, c.box_in_root, half) - r;
                        closest = closest.min(gap);
                        assert!(
                            gap > 0.0,
                            "{} frame {t}: {} inside the box by {:.4} m",
                            c.clip.name,
                            g.name,
                            -gap
                        );
                    }
                }
            }
            assert!(closest.is_finite());
        }
    }
}

#[test]
fn carries_are_deterministic_and_bad_parameters_are_refused() {
    assert_eq!(tokenhsi_carries(), tokenhsi_carries());
    let p = WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 1.0 };
    for side in [BOX_RANGE[0] - 0.01, BOX_RANGE[1] + 0.01, f64::NAN, 0.0] {
        let e = carry("x", p, side).unwrap_err();
        assert!(e.contains("box side"), "{side}: {e}");
    }
    let e = carry("x", WalkParams { speed: 5.0, ..p }, 0.4).unwrap_err();
    assert!(e.contains("speed"), "{e}");
    for side in [BOX_RANGE[0], BOX_RANGE[1]] {
        assert!(carry("x", p, side).is_ok(), "{side} m is within the range");
    }
}
