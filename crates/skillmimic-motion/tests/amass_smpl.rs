//! AMASS-layout sequences straight onto the SMPL humanoid (`skillmimic_motion::amass_smpl`):
//! SMPL's zero pose stood up is the humanoid's rest pose facing −y with the pelvis at
//! trans + J_pelvis; the ground option puts the lowest foot point on the floor; SMPL files (72
//! columns) drive the hands, SMPL-H files do not; bad files are refused by name.

use skillmimic_core::characters::smpl;
use skillmimic_core::math::Quat;
use skillmimic_motion::amass_smpl;
use skillmimic_motion::testing::{write_npz, write_synthetic_amass};

fn dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sm-amass-smpl-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// SMPL's Y-up model stood up in the Z-up world (root_orient = Rx(90°)), `width` columns.
fn stood_up(path: &std::path::Path, frames: usize, width: usize, trans: [f64; 3]) -> Vec<f64> {
    let mut poses = vec![0.0; frames * width];
    for f in 0..frames {
        poses[f * width] = std::f64::consts::FRAC_PI_2;
    }
    let tr: Vec<f64> = (0..frames).flat_map(|_| trans).collect();
    write_npz(
        path,
        &[
            ("poses", &[frames, width], &poses),
            ("trans", &[frames, 3], &tr),
            ("mocap_framerate", &[], &[30.0]),
        ],
    )
    .unwrap();
    poses
}

#[test]
fn the_zero_pose_is_the_rest_pose_facing_minus_y_with_the_pelvis_at_trans_plus_j_pelvis() {
    let d = dir("zero");
    let p = d.join("zero.npz");
    stood_up(&p, 4, 156, [0.3, -0.1, 0.9]);
    let (clip, rep) = amass_smpl::load(&p, false).unwrap();
    assert_eq!((clip.character.as_str(), clip.num_frames, clip.fps), ("smpl", 4, 30.0));
    assert_eq!((rep.source_width, rep.ground_shift), (156, 0.0));
    assert!(clip.dof_pos.iter().all(|x| x.abs() < 1e-6), "{:?}", &clip.dof_pos[..9]);
    let q = clip.root_quat_at(0);
    let fwd = q.rotate([1.0, 0.0, 0.0]);
    let up = q.rotate([0.0, 0.0, 1.0]);
    assert!((fwd[1] + 1.0).abs() < 1e-6 && (up[2] - 1.0).abs() < 1e-6, "{fwd:?} {up:?}");
    // SMPL's neutral J_pelvis (model coordinates) added to trans as is
    let want = [0.3 - 0.0018, -0.1 - 0.2233, 0.9 + 0.0282];
    let got = clip.root_pos_at(2);
    assert!((0..3).all(|k| (got[k] - want[k]).abs() < 1e-6), "{got:?}");
    // with the ground option the lowest foot-box point over the clip is on the floor
    let (g, rep) = amass_smpl::load(&p, true).unwrap();
    assert!(rep.lowest_foot_point.abs() < 1e-9, "{rep:?}");
    // standing upright in the rest pose: the pelvis at the rest height
    assert!((g.root_pos_at(0)[2] - smpl::REST_ROOT_HEIGHT).abs() < 2e-3, "{:?}", g.root_pos_at(0));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn only_smpl_files_drive_the_hands() {
    let d = dir("hands");
    let spec = smpl::spec();
    let hand = spec.bodies.iter().position(|b| b.name == "L_Hand").unwrap();
    let k = spec.bodies[hand].dofs.start;
    for (width, driven) in [(72, true), (156, false), (165, false)] {
        let p = d.join(format!("w{width}.npz"));
        let mut poses = stood_up(&p, 3, width, [0.0, 0.0, 0.9]);
        // column 66..69: SMPL's left hand in a 72-wide file, a finger of SMPL-H / SMPL-X
        for f in 0..3 {
            poses[f * width + 66] = 0.4;
        }
        write_npz(
            &p,
            &[
                ("poses", &[3, width], &poses),
                ("trans", &[3, 3], &[0.0, 0.0, 0.9].repeat(3)),
                ("mocap_framerate", &[], &[30.0]),
            ],
        )
        .unwrap();
        let (clip, _) = amass_smpl::load(&p, false).unwrap();
        let bend = clip.dof_at(1)[k..k + 3].iter().map(|x| x.abs()).fold(0.0f32, f32::max);
        assert_eq!(
            bend > 0.3,
            driven,
            "width {width}: hand hinges {:?}",
            &clip.dof_at(1)[k..k + 3]
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_walk_keeps_its_joint_rotations_and_bad_files_are_refused_by_name() {
    let d = dir("walk");
    let p = d.join("walk.npz");
    let poses = write_synthetic_amass(&p, 31, 30.0, &[0.5]).unwrap();
    let (clip, rep) = amass_smpl::load(&p, true).unwrap();
    assert!(rep.betas_ignored && clip.num_frames == 31);
    // the left knee's local rotation is SMPL's (the humanoid's frames are SMPL's turned by P, so
    // the rotation angle is the same)
    let spec = smpl::spec();
    let knee = spec.bodies.iter().position(|b| b.name == "L_Knee").unwrap();
    for f in [0, 7, 19] {
        let k = spec.bodies[knee].dofs.start;
        let h = clip.dof_at(f);
        let q = Quat::from_axis_angle([1.0, 0.0, 0.0], h[k] as f64)
            .mul(Quat::from_axis_angle([0.0, 1.0, 0.0], h[k + 1] as f64))
            .mul(Quat::about_z(h[k + 2] as f64));
        let want = poses[f * 156 + 12..f * 156 + 15].iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((q.angle() - want).abs() < 1e-5, "frame {f}: {} vs {want}", q.angle());
    }
    // a joint count, a frame rate, a non-finite value
    let bad = d.join("bad.npz");
    let cases: [(&str, Vec<f64>, usize, f64, &str); 3] = [
        ("joints", vec![0.0; 3 * 60], 60, 30.0, "60 columns"),
        ("fps", vec![0.0; 3 * 72], 72, 0.0, "frame rate"),
        ("nan", [vec![f64::NAN], vec![0.0; 3 * 72 - 1]].concat(), 72, 30.0, "non-finite"),
    ];
    for (what, poses, width, fps, needle) in cases {
        write_npz(
            &bad,
            &[
                ("poses", &[3, width], &poses),
                ("trans", &[3, 3], &[0.0; 9]),
                ("mocap_framerate", &[], &[fps]),
            ],
        )
        .unwrap();
        let e = amass_smpl::load(&bad, true).unwrap_err().to_string();
        assert!(e.contains("bad.npz") && e.contains(needle), "{what}: {e}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
