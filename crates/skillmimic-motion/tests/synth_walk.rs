//! The procedural TokenHSI walks (`synth_walk`), checked against what a walk must be: the joint
//! ranges of the released asset (`tokenhsi::BODIES`), one foot on the floor at every frame with
//! the other clear of it, feet that do not skate while they touch the floor, the requested speed
//! and turn rate, an upright pelvis at walking height, and determinism.

mod common;

use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::{Quat, heading, wrap_angle};
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::synth_walk::{FPS, WALKS, WalkParams, tokenhsi_walks, walk};

const FEET: [usize; 2] = tokenhsi::FEET;

/// Per frame: the lowest foot-box corner of each foot (m).
fn foot_heights(clip: &CharacterClip) -> Vec<[f64; 2]> {
    let spec = tokenhsi::spec();
    (0..clip.num_frames)
        .map(|t| {
            let dof: Vec<f64> = clip.dof_at(t).iter().map(|&x| x as f64).collect();
            let (pos, rot) =
                spec.forward_kinematics(clip.root_pos_at(t), clip.root_quat_at(t), &dof);
            let one = |keep: usize| {
                // the other foot's bodies moved far up so that only `keep` counts
                let mut p = pos.clone();
                for &f in &FEET {
                    if f != keep {
                        p[f][2] += 100.0;
                    }
                }
                spec.lowest_foot_box(&p, &rot)
            };
            [one(FEET[0]), one(FEET[1])]
        })
        .collect()
}

/// Each foot's lowest foot-box corner in the rest pose standing on the floor (m): the two boxes
/// differ slightly (right −1.6 mm, left about +0.7 mm).
fn rest_lowest() -> [f64; 2] {
    let spec = tokenhsi::spec();
    let rest = [(spec.root_pos, Quat::IDENTITY, vec![0.0; 32])];
    foot_heights(&CharacterClip::from_frames(&spec, "rest", "", 30.0, &rest))[0]
}

#[test]
fn every_joint_stays_within_the_released_assets_ranges() {
    for clip in tokenhsi_walks() {
        for t in 0..clip.num_frames {
            common::assert_in_released_ranges(&format!("{} frame {t}", clip.name), clip.dof_at(t));
        }
    }
}

#[test]
fn one_foot_is_on_the_floor_at_every_frame_and_the_other_clears_it() {
    let floor = rest_lowest();
    for clip in tokenhsi_walks() {
        let h = foot_heights(&clip);
        let mut max_gap: f64 = 0.0;
        let mut max_swing: f64 = 0.0;
        for (t, z) in h.iter().enumerate() {
            // height of each foot above where it touches the floor in the rest pose
            let up = [z[0] - floor[0], z[1] - floor[1]];
            let (low, high) = (up[0].min(up[1]), up[0].max(up[1]));
            // the supporting foot touches the floor as in the rest pose (within 1 mm)
            assert!(
                low.abs() < 1e-3,
                "{} frame {t}: lower foot {:.4} m off the floor",
                clip.name,
                low
            );
            // nothing goes through the floor
            assert!(high >= -1e-3, "{} frame {t}", clip.name);
            max_gap = max_gap.max(low.abs());
            max_swing = max_swing.max(high);
        }
        // the swing foot is lifted clear at mid-swing
        assert!(max_swing > 0.05, "{}: swing foot only {max_swing:.3} m up", clip.name);
        println!(
            "{}: support within {:.2} mm, swing up to {:.3} m",
            clip.name,
            1e3 * max_gap,
            max_swing
        );
    }
}

#[test]
fn feet_on_the_floor_do_not_skate() {
    // a foot is in contact over a frame pair when its lowest corner is within 5 mm of the rest
    // pose's at both frames; its frame must then not move (foot-skating, as motion-synthesis
    // papers measure it)
    let floor = rest_lowest();
    for clip in tokenhsi_walks() {
        let h = foot_heights(&clip);
        let (mut pairs, mut sum, mut worst) = (0usize, 0.0, 0.0f64);
        for t in 0..clip.num_frames - 1 {
            for (k, &f) in FEET.iter().enumerate() {
                if (h[t][k] - floor[k]).abs() < 5e-3 && (h[t + 1][k] - floor[k]).abs() < 5e-3 {
                    let (a, b) = (clip.body_pos_at(t, f), clip.body_pos_at(t + 1, f));
                    let d = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                    pairs += 1;
                    sum += d;
                    worst = worst.max(d);
                }
            }
        }
        let mean = sum / pairs as f64;
        println!(
            "{}: {pairs} contact pairs, slide mean {:.3} mm, max {:.2} mm",
            clip.name,
            1e3 * mean,
            1e3 * worst
        );
        // a foot touches the floor over nearly every frame pair (not always both frames of a pair
        // across a switch of the stance foot)
        assert!(
            pairs as f64 >= 0.9 * (clip.num_frames - 1) as f64,
            "{}: {pairs} contact pairs",
            clip.name
        );
        assert!(mean < 1e-3 && worst < 1e-2, "{}: mean {mean}, worst {worst}", clip.name);
    }
}

#[test]
fn the_clips_walk_at_their_speed_and_turn_rate_upright() {
    for ((_, p), clip) in WALKS.iter().zip(tokenhsi_walks()) {
        let n = clip.num_frames;
        assert_eq!(n, (p.seconds * FPS).round() as usize + 1);
        let secs = (n - 1) as f64 / FPS;
        // path length of the root (xy) over the clip, per second
        let mut path = 0.0;
        for t in 1..n {
            let (a, b) = (clip.root_pos_at(t - 1), clip.root_pos_at(t));
            path += ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        }
        let speed = path / secs;
        assert!((speed - p.speed).abs() < 0.04 * p.speed, "{}: {speed:.3} m/s", clip.name);
        let turned = wrap_angle(heading(clip.root_quat_at(n - 1)) - heading(clip.root_quat_at(0)));
        assert!(
            (turned - wrap_angle(p.yaw_rate * secs)).abs() < 1e-6,
            "{}: turned {turned}",
            clip.name
        );
        if p.yaw_rate == 0.0 {
            let end = clip.root_pos_at(n - 1);
            assert!(end[1].abs() < 0.1, "{}: drifted {:.3} m sideways", clip.name, end[1]);
            assert!((end[0] / secs - p.speed).abs() < 0.04 * p.speed, "{}", clip.name);
        }
        for t in 0..n {
            let z = clip.root_pos_at(t)[2];
            assert!((0.85..0.96).contains(&z), "{} frame {t}: pelvis at {z:.3} m", clip.name);
            // upright: the root's tilt away from +z is only the heading
            let q = clip.root_quat_at(t);
            let up = q.rotate([0.0, 0.0, 1.0]);
            assert!(up[2] > 1.0 - 1e-9, "{} frame {t}", clip.name);
        }
    }
}

#[test]
fn walks_are_deterministic_and_bad_parameters_are_refused() {
    assert_eq!(tokenhsi_walks(), tokenhsi_walks());
    let ok = WalkParams { speed: 1.0, yaw_rate: 0.0, seconds: 2.0 };
    for (bad, field) in [
        (WalkParams { speed: 0.0, ..ok }, "speed"),
        (WalkParams { speed: f64::NAN, ..ok }, "speed"),
        (WalkParams { yaw_rate: f64::INFINITY, ..ok }, "yaw_rate"),
        (WalkParams { seconds: 0.0, ..ok }, "seconds"),
        (WalkParams { seconds: f64::NAN, ..ok }, "seconds"),
    ] {
        let e = walk("x", bad).unwrap_err();
        assert!(e.starts_with(field), "{e}");
    }
    assert_eq!(walk("x", ok).unwrap().num_frames, 61);
}
