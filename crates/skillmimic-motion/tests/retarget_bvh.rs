//! Retargeting BVH onto the humanoid, first checks: a clip written as a BVH of the humanoid's own
//! hierarchy (centimetres, ZXY Euler channels from `amass::zxy_degrees`; the reader composes them
//! with its own code) comes back with the same body positions and joint rotations; a real mocap
//! file (MocapBank, from the crates.io package bvh_anim 0.4.0) retargets with its feet on the floor
//! and no joint-speed spikes.

use std::fmt::Write;
use std::path::Path;

use skillmimic_core::characters::skillmimic::{self as skeleton, BODIES, NUM_BODIES};
use skillmimic_core::math::Quat;
use skillmimic_core::shared_data::workspace_root;
use skillmimic_motion::Clip;
use skillmimic_motion::amass::zxy_degrees;
use skillmimic_motion::bvh;
use skillmimic_motion::retarget_bvh::{self, JointMap, Options};

/// The clip as a BVH of the humanoid's hierarchy, Y-up, centimetres.
fn clip_to_bvh(c: &Clip) -> String {
    let mut s = String::from("HIERARCHY\n");
    fn open(s: &mut String, b: usize, depth: usize) {
        let pad = "  ".repeat(depth);
        let o = BODIES[b].offset;
        let kind = if b == 0 { "ROOT" } else { "JOINT" };
        let ch = if b == 0 {
            "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
        } else {
            "CHANNELS 3 Zrotation Xrotation Yrotation"
        };
        writeln!(
            s,
            "{pad}{kind} {}\n{pad}{{\n{pad}  OFFSET {:.9} {:.9} {:.9}\n{pad}  {ch}",
            BODIES[b].name,
            o[0] * 100.0,
            o[1] * 100.0,
            o[2] * 100.0
        )
        .unwrap();
        let kids: Vec<usize> = (0..NUM_BODIES).filter(|&k| BODIES[k].parent == Some(b)).collect();
        if kids.is_empty() {
            writeln!(s, "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 1 0 0\n{pad}  }}").unwrap();
        }
        for k in kids {
            open(s, k, depth + 1);
        }
        writeln!(s, "{pad}}}").unwrap();
    }
    open(&mut s, 0, 0);
    let tilt_inv = Quat::from_axis_angle([1.0, 0.0, 0.0], -std::f64::consts::FRAC_PI_2);
    writeln!(s, "MOTION\nFrames: {}\nFrame Time: {:.12}", c.num_frames, 1.0 / c.fps).unwrap();
    // channel values in hierarchy (depth-first) order = skeleton order
    for t in 0..c.num_frames {
        let rp: Vec<f64> = (0..3).map(|k| c.root_pos[t * 3 + k] as f64).collect();
        let p = tilt_inv.rotate([rp[0], rp[1], rp[2]]);
        let rq = Quat::from_wxyz(std::array::from_fn(|k| c.root_rot[t * 4 + k] as f64));
        let e = zxy_degrees(tilt_inv.mul(rq));
        let mut row = format!(
            "{:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
            p[0] * 100.0,
            p[1] * 100.0,
            p[2] * 100.0,
            e[0],
            e[1],
            e[2]
        );
        for b in 1..NUM_BODIES {
            let d = skeleton::dof_range(b);
            let v = &c.dof_rot[t * 156 + d.start..t * 156 + d.end];
            let e = zxy_degrees(Quat::from_rotvec([v[0] as f64, v[1] as f64, v[2] as f64]));
            write!(row, " {:.9} {:.9} {:.9}", e[0], e[1], e[2]).unwrap();
        }
        s.push_str(&row);
        s.push('\n');
    }
    s
}

#[test]
fn humanoid_clip_round_trips_through_bvh() {
    let path = workspace_root().join("motions/050_synth_stand_dribble_right.safetensors");
    let clip = Clip::load(&path).unwrap();
    let text = clip_to_bvh(&clip);
    let b = bvh::parse(Path::new("roundtrip.bvh"), &text).unwrap();
    let map = JointMap::load("humanoid").unwrap();
    assert_eq!(map.bodies.len(), NUM_BODIES, "the shipped identity map names every body");
    let m = retarget_bvh::retarget(&b, &map, &Options { fps: clip.fps, ground: false, ik: false })
        .unwrap();
    assert_eq!(m.frames, clip.num_frames);
    assert!((m.scale - 0.01).abs() < 1e-9, "scale {}", m.scale);
    let (mut dp, mut dr) = (0.0f64, 0.0f64);
    for t in 0..clip.num_frames {
        let rq = Quat::from_wxyz(std::array::from_fn(|k| clip.root_rot[t * 4 + k] as f64));
        let rp = std::array::from_fn(|k| clip.root_pos[t * 3 + k] as f64);
        let want = skeleton::forward_kinematics(rp, rq, &clip.dof_rot[t * 156..(t + 1) * 156]);
        let got = retarget_bvh::body_positions(&m, t);
        for b in 0..NUM_BODIES {
            dp = dp.max((0..3).map(|k| (want[b][k] - got[b][k]).powi(2)).sum::<f64>().sqrt());
        }
        dr = dr.max(rq.conj().mul(m.root_rot[t]).angle());
        for j in 0..52 {
            let v = &clip.dof_rot[t * 156 + 3 * j..t * 156 + 3 * j + 3];
            let q = Quat::from_rotvec([v[0] as f64, v[1] as f64, v[2] as f64]);
            dr = dr.max(q.conj().mul(Quat::from_rotvec(m.dof_rot[t][j])).angle());
        }
    }
    println!(
        "round trip over {} frames: body positions within {:.2e} m, rotations within {:.2e} rad",
        clip.num_frames, dp, dr
    );
    assert!(dp < 0.01 && dr < 0.02, "{dp} m, {dr} rad");
}

fn mocapbank() -> Option<std::path::PathBuf> {
    skillmimic_core::shared_data::registry_file_or_skip(
        "mocapbank BVH",
        "bvh_anim-0.4.0",
        "data/test_mocapbank.bvh",
    )
}

#[test]
fn real_mocap_retargets_with_feet_on_the_floor() {
    let Some(path) = mocapbank() else { return };
    let b = bvh::read(&path).unwrap();
    let map = JointMap::load("mocapbank").unwrap();
    let m = retarget_bvh::retarget(&b, &map, &Options::default()).unwrap();
    let soles: Vec<f64> = (0..m.frames).map(|k| retarget_bvh::lowest_sole(&m, k)).collect();
    let deepest = soles.iter().cloned().fold(f64::INFINITY, f64::min);
    let (w, k, j) = retarget_bvh::max_joint_speed(&m);
    println!(
        "{} frames at 60 fps, scale {:.4}, ground shift {:.3} m; deepest sole {:.3} m; fastest \
            joint {:.1} rad/s (joint {j}, frame {k})",
        m.frames, m.scale, m.ground_shift, deepest, w
    );
    // 455 frames at 1/0.033333 fps = 15.133 s → 908 frames at 60 fps
    assert_eq!(m.frames, 908);
    // every mapped bone points where the source's bone points (world, Z-up): the rest alignment
    // and the rotation transfer are exact for the bones between mapped joints
    let tilt = Quat::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
    let chains = [
        ("L_Hip", "L_Knee"),
        ("L_Knee", "L_Ankle"),
        ("R_Hip", "R_Knee"),
        ("R_Knee", "R_Ankle"),
        ("L_Shoulder", "L_Elbow"),
        ("L_Elbow", "L_Wrist"),
        ("R_Shoulder", "R_Elbow"),
        ("R_Elbow", "R_Wrist"),
        ("Chest", "Neck"),
        ("Neck", "Head"),
    ];
    let mut worst = 0.0f64;
    for k in (0..m.frames).step_by(2) {
        let p = retarget_bvh::body_positions(&m, k);
        let sp = b.pose(k / 2).positions; // 30 → 60 fps: even output frames are source frames
        for (from, to) in chains {
            let (bf, bt) = (skeleton::body_index(from).unwrap(), skeleton::body_index(to).unwrap());
            let src = |n: &str| b.joint(map.bodies[n].as_str()).unwrap();
            let (sf, st) = (src(from), src(to));
            let sv = tilt.rotate(std::array::from_fn(|i| sp[st][i] - sp[sf][i]));
            let tv: [f64; 3] = std::array::from_fn(|i| p[bt][i] - p[bf][i]);
            let cos = (0..3).map(|i| sv[i] * tv[i]).sum::<f64>()
                / (skillmimic_core::math::norm(sv) * skillmimic_core::math::norm(tv));
            worst = worst.max(cos.clamp(-1.0, 1.0).acos());
        }
    }
    println!("mapped bone directions within {worst:.2e} rad of the source's");
    assert!(worst < 1e-3, "{worst}");
    // standing at the start (the capture bends down later): pelvis at standing height
    let pelvis_z: f64 =
        (0..30).map(|k| retarget_bvh::body_positions(&m, k)[0][2]).sum::<f64>() / 30.0;
    assert!((0.8..1.1).contains(&pelvis_z), "mean pelvis height over the first 0.5 s {pelvis_z}");
    assert!(
        m.scale > 0.005 && m.scale < 0.02,
        "centimetres to metres with a height ratio: {}",
        m.scale
    );
    assert!(deepest > -0.02, "feet {deepest} m below the floor");
    assert!(w < 30.0, "joint speed spike {w} rad/s");
}

#[test]
fn hostile_timing_and_values_are_refused() {
    let text = |frame_time: &str, offset: &str| {
        format!(
            "HIERARCHY\nROOT Hips\n{{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition \
                Zrotation Xrotation Yrotation\n JOINT Spine\n {{\n  OFFSET 0 {offset} 0\n  End \
                Site\n  {{\n   OFFSET 0 1 0\n  }}\n }}\n}}\nMOTION\nFrames: 2\nFrame Time: \
                {frame_time}\n0 90 0 0 0 0\n0 90 0 0 0 0\n"
        )
    };
    let map = JointMap {
        up: "y".into(),
        yaw_deg: 0.0,
        scale: Some(0.01),
        bodies: [("Pelvis".to_string(), "Hips".to_string())].into(),
    };
    let run = |t: String| {
        retarget_bvh::retarget(
            &bvh::parse(Path::new("h.bvh"), &t).unwrap(),
            &map,
            &Options::default(),
        )
        .map(drop)
        .map_err(|e| e.to_string())
    };
    // two frames a billion seconds apart would be 6e10 output frames
    let e = run(text("1e9", "10")).unwrap_err();
    assert!(e.contains("h.bvh") && e.contains("output frames"), "{e}");
    assert!(run(text("0.0333", "10")).is_ok());
    // an unknown up axis is named
    let bad_up = JointMap { up: "x".into(), ..map.clone() };
    let e = retarget_bvh::retarget(
        &bvh::parse(Path::new("h.bvh"), &text("0.0333", "10")).unwrap(),
        &bad_up,
        &Options::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("\"y\" or \"z\""), "{e}");
}
