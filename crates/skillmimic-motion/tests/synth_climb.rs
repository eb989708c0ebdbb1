//! The procedural TokenHSI step-ups (`synth_climb`), checked against what climbing onto a
//! platform must be: the released asset's joint ranges; at every frame some foot stands on the
//! floor or on the platform's top (within 1 mm of its rest-pose contact) and the feet do not slide
//! while they stand; no part of the legs inside the platform; the clip starts standing on the
//! floor and ends standing on the top in the rest pose; determinism and refused parameters.

mod common;

use skillmimic_core::characters::{GeomSpec, tokenhsi};
use skillmimic_core::math::Quat;
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_motion::synth_climb::{HEIGHT_GRID, HEIGHT_RANGE, climb, tokenhsi_climbs};

const FEET: [usize; 2] = tokenhsi::FEET;

/// World positions of 21 points along every leg capsule and the 8 corners of every foot box, per
/// body, at frame `t`, with the geom's radius (0 for box corners).
fn leg_points(clip: &CharacterClip, t: usize) -> Vec<(usize, [f64; 3], f64)> {
    let spec = tokenhsi::spec();
    let (pos, rot) =
        spec.forward_kinematics(clip.root_pos_at(t), clip.root_quat_at(t), &common::dof(clip, t));
    let mut out = Vec::new();
    for b in 9..15 {
        let at = |p: [f64; 3]| {
            let w = rot[b].rotate(p);
            [pos[b][0] + w[0], pos[b][1] + w[1], pos[b][2] + w[2]]
        };
        for g in &spec.bodies[b].geoms {
            match g.spec {
                GeomSpec::Capsule { radius, from, to, .. } => {
                    for i in 0..=20 {
                        let s = i as f64 / 20.0;
                        out.push((
                            b,
                            at([0, 1, 2].map(|a| from[a] + s * (to[a] - from[a]))),
                            radius,
                        ));
                    }
                }
                GeomSpec::Box { .. } => {
                    for p in g.spec.box_corners().into_iter().flatten() {
                        out.push((b, at(p), 0.0));
                    }
                }
                GeomSpec::Sphere { .. } => {}
            }
        }
    }
    out
}

/// Lowest foot-box corner of foot `f` at frame `t` (m) and its x.
fn sole(clip: &CharacterClip, t: usize, f: usize) -> (f64, f64) {
    leg_points(clip, t)
        .into_iter()
        .filter(|(b, _, r)| *b == f && *r == 0.0)
        .map(|(_, p, _)| (p[2], p[0]))
        .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a })
}

#[test]
fn every_joint_stays_within_the_released_assets_ranges() {
    for c in tokenhsi_climbs() {
        common::assert_clip_in_released_ranges(&c.clip);
    }
}

#[test]
fn a_foot_stands_on_the_floor_or_the_top_at_every_frame_without_sliding() {
    let rest = {
        let spec = tokenhsi::spec();
        let c = CharacterClip::from_frames(
            &spec,
            "rest",
            "",
            30.0,
            &[(spec.root_pos, Quat::IDENTITY, vec![0.0; 32])],
        );
        [sole(&c, 0, FEET[0]).0, sole(&c, 0, FEET[1]).0]
    };
    for c in tokenhsi_climbs() {
        let h = c.edge[2];
        let mut prev: [Option<[f64; 3]>; 2] = [None, None];
        for t in 0..c.clip.num_frames {
            let mut standing = 0;
            for (k, &f) in FEET.iter().enumerate() {
                let (z, x) = sole(&c.clip, t, f);
                let on_floor = (z - rest[k]).abs() < 1e-3 && x < c.edge[0] + 0.2;
                let on_top = (z - h - rest[k]).abs() < 1e-3;
                let frame = c.clip.body_pos_at(t, f);
                if on_floor || on_top {
                    standing += 1;
                    if let Some(p) = prev[k] {
                        let slide = ((frame[0] - p[0]).powi(2) + (frame[1] - p[1]).powi(2)).sqrt();
                        assert!(
                            slide < 1e-3,
                            "{} frame {t}: foot {k} slides {slide} m",
                            c.clip.name
                        );
                    }
                    prev[k] = Some(frame);
                } else {
                    prev[k] = None;
                }
            }
            assert!(standing > 0, "{} frame {t}: no foot stands", c.clip.name);
        }
    }
}

#[test]
fn no_part_of_the_legs_enters_the_platform_or_the_floor() {
    for c in tokenhsi_climbs() {
        let (x_face, h) = (c.edge[0], c.edge[2]);
        for t in 0..c.clip.num_frames {
            for (b, p, r) in leg_points(&c.clip, t) {
                // how deep the sphere of radius r about p reaches into the platform's region
                // {x ≥ face, z ≤ top} (the platform is wider than the stance) and into the floor
                let inside = p[0] >= x_face && p[2] <= h;
                let pen = if inside {
                    (p[0] - x_face).min(h - p[2]) + r
                } else {
                    r - (x_face - p[0]).max(0.0).hypot((p[2] - h).max(0.0))
                };
                let what = format!("{} frame {t}: body {b} at {p:?} (r {r})", c.clip.name);
                assert!(pen < 2e-3, "{what}: {pen:.4} m into the {h} m platform");
                assert!(p[2] - r > -2e-3, "{what}: into the floor");
            }
        }
    }
}

#[test]
fn the_clip_starts_on_the_floor_and_ends_standing_on_the_top() {
    let spec = tokenhsi::spec();
    for c in tokenhsi_climbs() {
        let first = c.clip.root_pos_at(0);
        let last = c.clip.root_pos_at(c.clip.num_frames - 1);
        assert!(
            (first[2] - spec.root_pos[2]).abs() < 1e-6,
            "{}: starts in the rest pose",
            c.clip.name
        );
        assert!(
            (last[2] - spec.root_pos[2] - c.edge[2]).abs() < 1e-5,
            "{}: ends {} m up",
            c.clip.name,
            last[2]
        );
        assert!(last[0] > c.edge[0], "{}: ends beyond the face", c.clip.name);
        for k in 0..32 {
            let end = c.clip.dof_at(c.clip.num_frames - 1)[k];
            let want = if k == 9 || k == 13 { -0.35 } else { 0.0 };
            assert!((end as f64 - want).abs() < 1e-4, "{}: dof {k} ends at {end}", c.clip.name);
        }
    }
}

#[test]
fn climbs_are_deterministic_and_bad_parameters_are_refused() {
    assert_eq!(tokenhsi_climbs(), tokenhsi_climbs());
    assert_eq!(tokenhsi_climbs().len(), HEIGHT_GRID.len());
    for h in [HEIGHT_RANGE[0] - 0.01, HEIGHT_RANGE[1] + 0.01, f64::NAN] {
        let e = climb("x", h).unwrap_err();
        assert!(e.contains("height"), "{h}: {e}");
    }
}
