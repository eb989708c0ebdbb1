//! SMPL-H sequences in the AMASS `.npz` layout: a synthetic walking sequence (written in the
//! `numpy.savez` layout) retargets with the identity rest alignment — every joint rotation and the
//! root orientation come through unchanged — with its feet on the floor (≤ 2 cm) and no joint-speed
//! spikes; broken archives are refused by name.

use skillmimic_core::characters::skillmimic as skeleton;
use skillmimic_core::math::Quat;
use skillmimic_motion::amass::{self, Rest, SMPLH_JOINTS};
use skillmimic_motion::retarget_bvh::{self, JointMap, Options};
use skillmimic_motion::testing::write_synthetic_amass;

#[test]
fn synthetic_smplh_walk_transfers_exactly_and_stands_on_the_floor() {
    let dir = std::env::temp_dir().join(format!("sm-amass-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("walk.npz");
    let (frames, fps) = (121, 60.0);
    let poses = write_synthetic_amass(&path, frames, fps, &[]).unwrap();
    let src = amass::read_with_rest(&path, Rest::Humanoid).unwrap();
    assert_eq!((src.frames, src.joints.len()), (frames, 52));
    let map = JointMap::load("smplh").unwrap();
    assert_eq!(map.bodies.len(), 52);
    let m = retarget_bvh::retarget(&src, &map, &Options::default()).unwrap();
    assert_eq!(m.frames, frames);
    assert!(
        (m.scale - 1.0).abs() < 1e-9,
        "metres and the humanoid's own rest skeleton: scale {}",
        m.scale
    );
    let mut worst = 0.0f64;
    for f in 0..frames {
        let row = &poses[f * 156..(f + 1) * 156];
        let q = |j: usize| Quat::from_rotvec([row[3 * j], row[3 * j + 1], row[3 * j + 2]]);
        worst = worst.max(q(0).conj().mul(m.root_rot[f]).angle());
        for (j, (_, _, body)) in SMPLH_JOINTS.iter().enumerate().skip(1) {
            let b = skeleton::body_index(body).unwrap();
            worst = worst.max(q(j).conj().mul(Quat::from_rotvec(m.dof_rot[f][b - 1])).angle());
        }
        let spine2 = skeleton::body_index("Spine2").unwrap();
        assert!(
            Quat::from_rotvec(m.dof_rot[f][spine2 - 1]).angle() < 1e-9,
            "Spine2 keeps the rest pose"
        );
    }
    println!("rotations through the AMASS path within {worst:.2e} rad");
    assert!(worst < 1e-6);
    let deepest =
        (0..frames).map(|k| retarget_bvh::lowest_sole(&m, k)).fold(f64::INFINITY, f64::min);
    let (w, _, _) = retarget_bvh::max_joint_speed(&m);
    println!(
        "deepest sole {deepest:.4} m, fastest joint {w:.2} rad/s, ground shift {:.3} m",
        m.ground_shift
    );
    assert!(deepest > -0.02 && w < 20.0);
    // the root travels as `trans` does: 1 m/s while turning at 0.3 rad/s, a 1.97 m chord in 2 s
    let p0 = retarget_bvh::body_positions(&m, 0)[0];
    let p1 = retarget_bvh::body_positions(&m, frames - 1)[0];
    let d = ((p1[0] - p0[0]).powi(2) + (p1[1] - p0[1]).powi(2)).sqrt();
    assert!((1.9..2.01).contains(&d), "walked {d} m in 2 s");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn broken_archives_are_refused_by_name() {
    let dir = std::env::temp_dir().join(format!("sm-amass-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("x.npz");
    std::fs::write(&p, b"not a zip").unwrap();
    let e = amass::read(&p).unwrap_err().to_string();
    assert!(e.contains("x.npz") && e.contains("zip"), "{e}");
    // a valid archive, then with one array corrupted or missing
    write_synthetic_amass(&p, 4, 30.0, &[]).unwrap();
    assert!(amass::read(&p).is_ok());
    let rewrite = |drop: &str, replace: Option<(&str, Vec<u8>)>| {
        let mut zin = zip::ZipArchive::new(std::fs::File::open(&p).unwrap()).unwrap();
        let q = dir.join("y.npz");
        let mut zout = zip::ZipWriter::new(std::fs::File::create(&q).unwrap());
        for i in 0..zin.len() {
            let mut f = zin.by_index(i).unwrap();
            let name = f.name().unwrap().to_string();
            if name == drop {
                continue;
            }
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut f, &mut bytes).unwrap();
            if let Some((_, b)) = replace.as_ref().filter(|(n, _)| *n == name) {
                bytes = b.clone();
            }
            zout.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
            std::io::Write::write_all(&mut zout, &bytes).unwrap();
        }
        zout.finish().unwrap();
        amass::read(&q).unwrap_err().to_string()
    };
    assert!(rewrite("poses.npy", None).contains("no 'poses'"));
    assert!(rewrite("mocap_framerate.npy", None).contains("mocap_framerate"));
    let int_npy = {
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        let h = "{'descr': '<i8', 'fortran_order': False, 'shape': (4, 3), }\n";
        b.extend_from_slice(&(h.len() as u16).to_le_bytes());
        b.extend_from_slice(h.as_bytes());
        b.extend_from_slice(&[0u8; 96]);
        b
    };
    let e = rewrite("", Some(("trans.npy", int_npy)));
    assert!(e.contains("'trans'") && e.contains("<i8"), "{e}");
    let short = b"\x93NUMPY\x01\x00\x40\x00{'descr': '<f8', 'fortran_order': False, 'shape': (4, \
        3), }          \n"
        .to_vec();
    let e = rewrite("", Some(("trans.npy", short)));
    assert!(e.contains("data bytes"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A body model file (here a synthetic one: 52 vertices at the joints, an identity regressor and
/// one shape direction that scales the body by 10 % per unit β, with a pelvis 0.22 m below the
/// model origin as in SMPL) gives the rest skeleton for the sequence's β: rotations still transfer
/// exactly, the height ratio becomes 1 / 1.1, and the pelvis sits at `trans + J_pelvis(β)`.
#[test]
fn body_model_file_sets_the_skeleton_and_the_pelvis() {
    use skillmimic_motion::testing::write_npz;
    let dir = std::env::temp_dir().join(format!("sm-amass-model-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (seq, model) = (dir.join("walk.npz"), dir.join("model.npz"));
    let poses = write_synthetic_amass(&seq, 61, 60.0, &[1.0]).unwrap();
    // the synthetic model: vertex j = the humanoid's rest joint j, moved by the SMPL-like pelvis
    // offset
    let src = amass::read_with_rest(&seq, Rest::Humanoid).unwrap();
    let mut rest = vec![[0.0f64; 3]; 52];
    for j in 0..52 {
        rest[j] = match src.joints[j].parent {
            Some(p) => std::array::from_fn(|c| rest[p][c] + src.joints[j].offset[c]),
            None => [0.0; 3],
        };
    }
    let j0 = [0.003, -0.22, 0.03];
    let v: Vec<f64> =
        rest.iter().flat_map(|r| [r[0] + j0[0], r[1] + j0[1], r[2] + j0[2]]).collect();
    let reg: Vec<f64> = (0..52 * 52).map(|k| if k / 52 == k % 52 { 1.0 } else { 0.0 }).collect();
    let dirs: Vec<f64> = v.iter().map(|x| 0.1 * x).collect(); // (52, 3, 1): +10 % size per unit β
    write_npz(
        &model,
        &[
            ("v_template", &[52, 3], &v),
            ("J_regressor", &[52, 52], &reg),
            ("shapedirs", &[52, 3, 1], &dirs),
        ],
    )
    .unwrap();
    let joints = amass::model_joints(&model, &[1.0]).unwrap();
    assert!((joints[0][1] - 1.1 * j0[1]).abs() < 1e-12);
    let b = amass::read_with_rest(&seq, Rest::BodyModel(&model)).unwrap();
    let m = retarget_bvh::retarget(
        &b,
        &JointMap::load("smplh").unwrap(),
        &Options { fps: 60.0, ground: false, ik: false },
    )
    .unwrap();
    assert!((m.scale - 1.0 / 1.1).abs() < 1e-9, "height ratio {}", m.scale);
    let mut worst = 0.0f64;
    for f in 0..61 {
        let row = &poses[f * 156..(f + 1) * 156];
        for (j, (_, _, body)) in SMPLH_JOINTS.iter().enumerate().skip(1) {
            let q = Quat::from_rotvec([row[3 * j], row[3 * j + 1], row[3 * j + 2]]);
            worst = worst.max(
                q.conj()
                    .mul(Quat::from_rotvec(m.dof_rot[f][skeleton::body_index(body).unwrap() - 1]))
                    .angle(),
            );
        }
    }
    assert!(worst < 1e-6, "{worst}");
    // frame 0: trans = (0, 0, 0.95); the pelvis at s · (trans + J_pelvis(β)), J_pelvis added in the
    // world
    let want = [1.1 * j0[0] / 1.1, 1.1 * j0[1] / 1.1, (0.95 + 1.1 * j0[2]) / 1.1];
    for c in 0..3 {
        assert!((m.root_pos[0][c] - want[c]).abs() < 1e-9, "root {:?} vs {want:?}", m.root_pos[0]);
    }
    // a model without J_regressor is refused by name
    write_npz(&model, &[("v_template", &[52, 3], &v)]).unwrap();
    let e = amass::read_with_rest(&seq, Rest::BodyModel(&model)).unwrap_err().to_string();
    assert!(e.contains("model.npz") && e.contains("J_regressor"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default rest skeleton is SMPL's neutral mean shape: in the zero pose every mapped limb bone
/// of the retargeted humanoid points along SMPL's rest bone (turned into the Z-up world), the size
/// follows SMPL's leg length, and the pelvis sits at `trans + J_pelvis` × scale.
#[test]
fn smpl_neutral_rest_skeleton_is_the_default() {
    use skillmimic_core::math::{norm, sub};
    use skillmimic_motion::testing::write_npz;
    let joints = amass::smpl_neutral_joints();
    assert_eq!(joints.len(), 52);
    // SMPL's neutral body: pelvis 22.3 cm below the model origin, near-symmetric hips, legs of
    // 0.777 m (hip → knee → ankle), arms of 0.51 m (shoulder → elbow → wrist)
    assert!((joints[0][1] + 0.2233).abs() < 1e-12);
    assert!(
        (joints[1][0] + joints[2][0] - 2.0 * joints[0][0]).abs() < 0.005,
        "hips {:?} {:?}",
        joints[1],
        joints[2]
    );
    let leg = norm(sub(joints[4], joints[1])) + norm(sub(joints[7], joints[4]));
    let arm = norm(sub(joints[18], joints[16])) + norm(sub(joints[20], joints[18]));
    assert!((leg - 0.7776).abs() < 1e-3 && (arm - 0.5109).abs() < 2e-3, "leg {leg}, arm {arm}");
    // the zero pose, stood up in AMASS's Z-up world
    let dir = std::env::temp_dir().join(format!("sm-amass-neutral-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let seq = dir.join("zero.npz");
    let t = 4;
    let poses: Vec<f64> = (0..t * 156)
        .map(|k| if k % 156 == 0 { std::f64::consts::FRAC_PI_2 } else { 0.0 })
        .collect();
    let trans: Vec<f64> = (0..t).flat_map(|_| [0.1, 0.2, 0.95]).collect();
    write_npz(
        &seq,
        &[
            ("poses", &[t, 156], &poses),
            ("trans", &[t, 3], &trans),
            ("mocap_framerate", &[], &[30.0]),
        ],
    )
    .unwrap();
    let b = amass::read(&seq).unwrap();
    let m = retarget_bvh::retarget(
        &b,
        &JointMap::load("smplh").unwrap(),
        &Options { fps: 30.0, ground: false, ik: false },
    )
    .unwrap();
    let humanoid_leg = norm(skeleton::BODIES[skeleton::body_index("L_Knee").unwrap()].offset)
        + norm(skeleton::BODIES[skeleton::body_index("L_Ankle").unwrap()].offset);
    let smpl_legs = leg + norm(sub(joints[5], joints[2])) + norm(sub(joints[8], joints[5]));
    assert!((m.scale - 2.0 * humanoid_leg / smpl_legs).abs() < 1e-3, "scale {}", m.scale);
    let tilt = Quat::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
    let p = retarget_bvh::body_positions(&m, 0);
    let mut worst = 0.0f64;
    for (from, to, jf, jt) in [
        ("L_Hip", "L_Knee", 1, 4),
        ("L_Knee", "L_Ankle", 4, 7),
        ("R_Hip", "R_Knee", 2, 5),
        ("R_Knee", "R_Ankle", 5, 8),
        ("L_Shoulder", "L_Elbow", 16, 18),
        ("L_Elbow", "L_Wrist", 18, 20),
        ("R_Shoulder", "R_Elbow", 17, 19),
        ("R_Elbow", "R_Wrist", 19, 21),
        ("Neck", "Head", 12, 15),
    ] {
        let (bf, bt) = (skeleton::body_index(from).unwrap(), skeleton::body_index(to).unwrap());
        let want = tilt.rotate(sub(joints[jt], joints[jf]));
        let got = sub(p[bt], p[bf]);
        let cos = (0..3).map(|i| want[i] * got[i]).sum::<f64>() / (norm(want) * norm(got));
        worst = worst.max(cos.clamp(-1.0, 1.0).acos());
    }
    println!(
        "zero pose on SMPL's neutral skeleton: limb bones within {worst:.2e} rad of SMPL's rest \
            directions; scale {:.4}",
        m.scale
    );
    assert!(worst < 1e-6, "{worst} rad");
    // pelvis: (trans + J_pelvis) in the world, × scale
    let j0 = amass::SMPL_NEUTRAL_OFFSETS[0];
    let want = [(0.1 + j0[0]) * m.scale, (0.2 + j0[1]) * m.scale, (0.95 + j0[2]) * m.scale];
    assert!(
        (0..3).all(|c| (m.root_pos[0][c] - want[c]).abs() < 1e-9),
        "pelvis {:?} vs {want:?}",
        m.root_pos[0]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The three `poses` widths: an SMPL-X row (165: jaw and eyes between the body and the hands, here
/// with non-zero values that must be ignored) retargets exactly like the SMPL-H row it was made
/// from; an SMPL row (72: two hand joints, no fingers) gives the same body and rest fingers.
#[test]
fn smplx_and_smpl_layouts_match_smplh() {
    use skillmimic_motion::testing::write_npz;
    let dir = std::env::temp_dir().join(format!("sm-amass-widths-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (t, fps) = (31, 30.0);
    let h = dir.join("h.npz");
    let poses = write_synthetic_amass(&h, t, fps, &[]).unwrap();
    let trans: Vec<f64> = (0..t).flat_map(|f| [0.01 * f as f64, 0.0, 0.95]).collect();
    write_npz(
        &h,
        &[
            ("poses", &[t, 156], &poses),
            ("trans", &[t, 3], &trans),
            ("mocap_framerate", &[], &[fps]),
        ],
    )
    .unwrap();
    let x: Vec<f64> = (0..t)
        .flat_map(|f| {
            let row = &poses[f * 156..(f + 1) * 156];
            row[..66]
                .iter()
                .copied()
                .chain([0.3, -0.2, 0.1, 0.5, 0.5, 0.5, -0.4, 0.2, 0.9])
                .chain(row[66..].iter().copied())
                .collect::<Vec<_>>()
        })
        .collect();
    let s: Vec<f64> = (0..t)
        .flat_map(|f| {
            poses[f * 156..f * 156 + 66]
                .iter()
                .copied()
                .chain([0.7, 0.0, 0.0, 0.0, -0.7, 0.0])
                .collect::<Vec<_>>()
        })
        .collect();
    let (xp, sp) = (dir.join("x.npz"), dir.join("s.npz"));
    write_npz(
        &xp,
        &[("poses", &[t, 165], &x), ("trans", &[t, 3], &trans), ("mocap_framerate", &[], &[fps])],
    )
    .unwrap();
    write_npz(
        &sp,
        &[("poses", &[t, 72], &s), ("trans", &[t, 3], &trans), ("mocap_framerate", &[], &[fps])],
    )
    .unwrap();
    let map = JointMap::load("smplh").unwrap();
    let go = |p: &std::path::Path| {
        retarget_bvh::retarget(&amass::read(p).unwrap(), &map, &Options::default()).unwrap()
    };
    let (mh, mx, ms) = (go(&h), go(&xp), go(&sp));
    let is_finger = |b: usize| {
        ["Index", "Middle", "Pinky", "Ring", "Thumb"]
            .iter()
            .any(|f| skeleton::BODIES[b].name.contains(f))
    };
    let mut worst_body = 0.0f64;
    for k in 0..mh.frames {
        assert_eq!(mh.root_rot[k], mx.root_rot[k]);
        assert_eq!(mh.dof_rot[k], mx.dof_rot[k], "SMPL-X frame {k}");
        assert_eq!(mh.root_pos[k], mx.root_pos[k]);
        for b in 1..skeleton::NUM_BODIES {
            let (qh, qs) =
                (Quat::from_rotvec(mh.dof_rot[k][b - 1]), Quat::from_rotvec(ms.dof_rot[k][b - 1]));
            if is_finger(b) {
                assert!(
                    qs.angle() < 1e-9,
                    "SMPL finger {} keeps the rest pose",
                    skeleton::BODIES[b].name
                );
            } else {
                worst_body = worst_body.max(qh.conj().mul(qs).angle());
            }
        }
    }
    assert!(worst_body < 1e-9, "SMPL body rotations {worst_body} rad from SMPL-H's");
    let _ = std::fs::remove_dir_all(&dir);
}
