//! Retargeting from joint positions alone (issue 23, item 3): every BallPlay-M clip, re-derived
//! from the 53 world body positions it stores (columns 165:324) through `retarget_positions` with
//! the identity map, against the clip's own joint rotations and positions; and the light IK on a
//! real mocap file.

use skillmimic_core::characters::skillmimic::{self as skeleton, BODIES, NUM_BODIES};
use skillmimic_core::math::{Quat, Vec3, norm, sub};
use skillmimic_motion::Clip;
use skillmimic_motion::retarget_bvh::{self, JointMap, Options};
use skillmimic_motion::retarget_positions::{JointPositions, retarget_positions};

/// The stored body positions of a clip as a positions source (Z-up world, metres).
fn positions_of(c: &Clip) -> JointPositions {
    JointPositions {
        path: c.source.clone().into(),
        names: BODIES.iter().map(|b| b.name.to_string()).collect(),
        fps: c.fps,
        frames: c.num_frames,
        positions: c.body_pos.chunks(3).map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]).collect(),
    }
}

fn dist(a: Vec3, b: Vec3) -> f64 {
    norm(sub(a, b))
}

/// Global orientations of the 53 bodies from a root rotation and 52 local rotation vectors.
fn globals(root: Quat, dof: impl Fn(usize) -> Vec3) -> [Quat; NUM_BODIES] {
    let mut g = [root; NUM_BODIES];
    for b in 1..NUM_BODIES {
        g[b] = g[BODIES[b].parent.unwrap()].mul(Quat::from_rotvec(dof(b - 1)));
    }
    g
}

fn is_leaf(b: usize) -> bool {
    !(0..NUM_BODIES).any(|c| BODIES[c].parent == Some(b))
}

fn is_multi(b: usize) -> bool {
    (0..NUM_BODIES).filter(|&c| BODIES[c].parent == Some(b)).count() >= 2
}

/// The method on self-consistent positions (the forward kinematics of a clip's own rotations):
/// the root and every body with two or more children come back exactly; a single-child body
/// differs by its twist about the bone only (its bone direction is exact: positions to 1e-9 m).
#[test]
fn rotations_come_back_from_consistent_positions() {
    let path = skillmimic_core::shared_data::workspace_root()
        .join("motions/050_synth_stand_dribble_right.safetensors");
    let clip = Clip::load(&path).unwrap();
    let mut src = positions_of(&clip);
    for t in 0..clip.num_frames {
        let rq = Quat::from_wxyz(std::array::from_fn(|k| clip.root_rot[t * 4 + k] as f64));
        let rp = std::array::from_fn(|k| clip.root_pos[t * 3 + k] as f64);
        let fk = skeleton::forward_kinematics(rp, rq, &clip.dof_rot[t * 156..(t + 1) * 156]);
        src.positions[t * NUM_BODIES..(t + 1) * NUM_BODIES].copy_from_slice(&fk);
    }
    let mut map = JointMap::load("humanoid").unwrap();
    map.up = "z".into();
    let m = retarget_positions(&src, &map, &Options { fps: clip.fps, ground: false, ik: false })
        .unwrap();
    let (mut exact, mut twist, mut pos) = (0.0f64, 0.0f64, 0.0f64);
    for t in 0..clip.num_frames {
        let dof = |j: usize| std::array::from_fn(|k| clip.dof_rot[t * 156 + 3 * j + k] as f64);
        let ga =
            globals(Quat::from_wxyz(std::array::from_fn(|k| clip.root_rot[t * 4 + k] as f64)), dof);
        let gb = globals(m.root_rot[t], |j| m.dof_rot[t][j]);
        let got = retarget_bvh::body_positions(&m, t);
        for b in 0..NUM_BODIES {
            pos = pos.max(dist(got[b], src.at(t, b)));
            let a = ga[b].conj().mul(gb[b]).angle();
            if b == 0 || is_multi(b) {
                exact = exact.max(a);
            } else if !is_leaf(b) {
                twist = twist.max(a);
            }
        }
    }
    println!(
        "consistent positions: root and branching bodies within {exact:.2e} rad, single-child \
            bodies within {twist:.3} rad (twist), positions within {pos:.2e} m"
    );
    assert!(exact < 1e-5, "{exact} rad");
    assert!(pos < 1e-5, "{pos} m");
}

#[test]
fn ballplay_m_clips_rederived_from_their_body_positions() {
    let Some(shared) = skillmimic_core::shared_data::shared_dir_or_skip(
        "ballplay_m_clips_rederived_from_their_body_positions",
    ) else {
        return;
    };
    let files = skillmimic_core::shared_data::ballplay_clips(&shared);
    assert!(files.len() >= 50, "{} clips", files.len());
    let mut map = JointMap::load("humanoid").unwrap();
    map.up = "z".into(); // the clips' world is Z-up
    // position errors: re-derived vs stored positions, and the stored rotations' own FK vs stored
    let (mut pos_max, mut pos_sum, mut quirk_sum, mut n_pos) = (0.0f64, 0.0, 0.0, 0usize);
    // rotation errors (global body orientations, rad): single-branch bodies vs the rest
    let (mut rot_multi, mut rot_single, mut rot_max_multi) =
        ((0.0f64, 0usize), (0.0f64, 0usize), 0.0f64);
    let (mut root_err, mut frames) = (0.0f64, 0usize);
    for f in &files {
        let clip = Clip::load_any(f).unwrap();
        let m = retarget_positions(
            &positions_of(&clip),
            &map,
            &Options { fps: clip.fps, ground: false, ik: false },
        )
        .unwrap();
        assert_eq!(m.frames, clip.num_frames, "{}", clip.name);
        assert!(
            (m.scale - 1.0).abs() < 2e-3,
            "{}: scale {} (same skeleton: 1)",
            clip.name,
            m.scale
        );
        for t in 0..clip.num_frames {
            let got = retarget_bvh::body_positions(&m, t);
            let rq = Quat::from_wxyz(std::array::from_fn(|k| clip.root_rot[t * 4 + k] as f64));
            let rp = std::array::from_fn(|k| clip.root_pos[t * 3 + k] as f64);
            let dof = &clip.dof_rot[t * 156..(t + 1) * 156];
            let fk = skeleton::forward_kinematics(rp, rq, dof);
            let ga =
                globals(rq, |j| [dof[3 * j] as f64, dof[3 * j + 1] as f64, dof[3 * j + 2] as f64]);
            let gb = globals(m.root_rot[t], |j| m.dof_rot[t][j]);
            root_err += ga[0].conj().mul(gb[0]).angle();
            for b in 0..NUM_BODIES {
                let stored =
                    std::array::from_fn(|k| clip.body_pos[(t * NUM_BODIES + b) * 3 + k] as f64);
                let e = dist(got[b], stored);
                pos_max = pos_max.max(e);
                pos_sum += e;
                quirk_sum += dist(fk[b], stored);
                n_pos += 1;
                if !is_leaf(b) {
                    let a = ga[b].conj().mul(gb[b]).angle();
                    if is_multi(b) {
                        rot_multi = (rot_multi.0 + a, rot_multi.1 + 1);
                        rot_max_multi = rot_max_multi.max(a);
                    } else {
                        rot_single = (rot_single.0 + a, rot_single.1 + 1);
                    }
                }
            }
            frames += 1;
        }
    }
    let pos_mean = pos_sum / n_pos as f64;
    let quirk_mean = quirk_sum / n_pos as f64;
    let (multi_mean, single_mean) =
        (rot_multi.0 / rot_multi.1 as f64, rot_single.0 / rot_single.1 as f64);
    println!(
        "{} clips, {frames} frames: body positions re-derived from the stored positions within \
         {:.4} mm mean, {:.4} mm max \
         (the stored rotations' own FK: {:.1} mm mean from the stored positions); global \
         orientation vs the stored rotations: \
         root {:.4} rad mean, bodies with >= 2 children {:.4} rad mean / {:.3} max, \
         single-child bodies {:.3} rad mean (twist \
         about the bone is not in positions)",
        files.len(),
        1000.0 * pos_mean,
        1000.0 * pos_max,
        1000.0 * quirk_mean,
        root_err / frames as f64,
        multi_mean,
        rot_max_multi,
        single_mean
    );
    assert!(
        pos_max < 0.01,
        "re-derived body positions {pos_max} m from the stored ones (1 cm allowed)"
    );
    assert!(pos_mean < 0.002, "mean {pos_mean} m");
}

#[test]
fn csv_reader_names_the_line_and_the_expectation() {
    let dir = std::env::temp_dir().join(format!("positions-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("m.csv");
    std::fs::write(&p, "a_x,a_y,a_z,b.x,b.y,b.z\n0,1,2,3,4,5\n\n6,7,8,9,10,11\n").unwrap();
    let j = JointPositions::read_csv(&p, 30.0).unwrap();
    assert_eq!((j.names.clone(), j.frames), (vec!["a".to_string(), "b".to_string()], 2));
    assert_eq!(j.at(1, 1), [9.0, 10.0, 11.0]);
    for (text, want) in [
        ("a_x,a_y\n1,2\n", "line 1: 2 columns"),
        ("a_x,a_y,b_z\n1,2,3\n", "line 1, columns 1–3"),
        ("a_x,a_y,a_z\n1,2,nan\n", "line 2: expected 3 finite numbers"),
        ("a_x,a_y,a_z\n1,2\n", "line 2: expected 3 finite numbers, found 2"),
        ("a_x,a_y,a_z\n1,2,x\n", "line 2: expected 3 numbers"),
        ("", "empty"),
    ] {
        std::fs::write(&p, text).unwrap();
        let e = JointPositions::read_csv(&p, 30.0).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("m.csv"), "{text:?}: {e}");
    }
    std::fs::write(&p, "a_x,a_y,a_z\n1,2,3\n").unwrap();
    assert!(JointPositions::read_csv(&p, 0.0).unwrap_err().to_string().contains("frame rate"));
    // one frame only, and a map naming a joint the file lacks
    let j = JointPositions::read_csv(&p, 30.0).unwrap();
    let e = retarget_positions(&j, &JointMap::load("humanoid").unwrap(), &Options::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("which the positions file does not have (it has a)") && e.contains("m.csv"),
        "{e}"
    );
    // hostile values: legs of 1e308 overflow the bone vectors; refused as non-finite, never written
    let legs = ["Pelvis", "L_Hip", "L_Knee", "L_Ankle", "R_Hip", "R_Knee", "R_Ankle"];
    let header: Vec<String> =
        legs.iter().flat_map(|n| ["x", "y", "z"].map(|a| format!("{n}_{a}"))).collect();
    let row: Vec<&str> = (0..21).map(|i| if i % 2 == 0 { "1.7e308" } else { "-1.7e308" }).collect();
    std::fs::write(&p, format!("{}\n{}\n{}\n", header.join(","), row.join(","), row.join(",")))
        .unwrap();
    let map = JointMap {
        up: "y".into(),
        yaw_deg: 0.0,
        scale: None,
        bodies: legs.iter().map(|n| (n.to_string(), n.to_string())).collect(),
    };
    let e = retarget_positions(
        &JointPositions::read_csv(&p, 30.0).unwrap(),
        &map,
        &Options { ik: true, ..Options::default() },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("non-finite") && e.contains("m.csv"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
