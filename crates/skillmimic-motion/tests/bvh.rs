//! The BVH reader: forward kinematics against hand-computed poses and an independent Euler-matrix
//! composition, every channel order, a real mocap file shipped with a crates.io package, and
//! hostile files refused with the line and what was expected.

use std::path::Path;

use skillmimic_motion::bvh::{self, Bvh};

fn parse(text: &str) -> Result<Bvh, String> {
    bvh::parse(Path::new("t.bvh"), text).map_err(|e| e.to_string())
}

const TWO: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 2 3 90 0 0 0 0 0
0 0 0 0 0 0 0 0 0
";

#[test]
fn forward_kinematics_by_hand() {
    let b = parse(TWO).unwrap();
    assert_eq!((b.frames, b.width, b.joints.len()), (2, 9, 2));
    assert!((b.fps() - 30.0).abs() < 1e-3);
    assert_eq!(b.joints[1].end_site, Some([0.0, 5.0, 0.0]));
    let p = b.pose(0);
    // root at (1, 2, 3) turned 90° about z: the child's offset (0, 10, 0) points along −x
    let c = p.positions[1];
    assert!(
        (c[0] + 9.0).abs() < 1e-9 && (c[1] - 2.0).abs() < 1e-9 && (c[2] - 3.0).abs() < 1e-9,
        "{c:?}"
    );
    assert_eq!(b.pose(1).positions[1], [0.0, 10.0, 0.0]);
}

/// R for Euler angles (degrees) applied in `order` as intrinsic rotations, by matrices.
fn euler_matrix(order: &[usize], deg: &[f64]) -> [[f64; 3]; 3] {
    let mut m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for (&axis, &d) in order.iter().zip(deg) {
        let (s, c) = d.to_radians().sin_cos();
        let r = match axis {
            0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
            1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
            _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        };
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                out[i][j] = (0..3).map(|k| m[i][k] * r[k][j]).sum();
            }
        }
        m = out;
    }
    m
}

#[test]
fn every_channel_order_matches_matrix_composition() {
    let names = ["Xrotation", "Yrotation", "Zrotation"];
    let orders = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let deg = [37.0, -61.0, 112.0];
    for order in orders {
        let ch: Vec<&str> = order.iter().map(|&a| names[a]).collect();
        let text = format!(
            "HIERARCHY\nROOT A\n{{\n OFFSET 0 0 0\n CHANNELS 3 {} {} {}\n JOINT B\n {{\n  OFFSET \
                1 2 3\n  End Site\n  {{\n   OFFSET 0 0 0\n  }}\n }}\n}}\nMOTION\nFrames: 1\nFrame \
                Time: 0.01\n{} {} {}\n",
            ch[0], ch[1], ch[2], deg[0], deg[1], deg[2]
        );
        let b = parse(&text).unwrap();
        let got = b.pose(0).positions[1];
        let m = euler_matrix(&order, &deg);
        let want: Vec<f64> =
            (0..3).map(|i| m[i][0] * 1.0 + m[i][1] * 2.0 + m[i][2] * 3.0).collect();
        for i in 0..3 {
            assert!((got[i] - want[i]).abs() < 1e-9, "order {ch:?}: {got:?} vs {want:?}");
        }
    }
}

/// `data/test_mocapbank.bvh` of the crates.io package `bvh_anim` 0.4.0 (MIT): a real MocapBank
/// capture, 455 frames at 30 fps, Y-up, centimetres. Found in the local cargo registry.
fn mocapbank() -> Option<std::path::PathBuf> {
    skillmimic_core::shared_data::registry_file_or_skip(
        "mocapbank BVH",
        "bvh_anim-0.4.0",
        "data/test_mocapbank.bvh",
    )
}

#[test]
fn real_mocap_file_parses_and_keeps_bone_lengths() {
    let Some(path) = mocapbank() else { return };
    let b = bvh::read(&path).unwrap();
    assert_eq!(b.frames, 455);
    assert!((b.fps() - 30.0).abs() < 1e-2);
    assert!(b.values.iter().all(|v| v.is_finite()));
    // forward kinematics keeps every bone at its offset's length in every frame
    let mut worst = 0.0f64;
    for f in 0..b.frames {
        let p = b.pose(f);
        for (j, joint) in b.joints.iter().enumerate() {
            if let Some(pa) = joint.parent {
                let d: f64 = (0..3)
                    .map(|i| (p.positions[j][i] - p.positions[pa][i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let want: f64 = joint.offset.iter().map(|x| x * x).sum::<f64>().sqrt();
                worst = worst.max((d - want).abs());
            }
        }
    }
    println!(
        "{} joints, {} frames; worst bone-length change {worst:.2e}",
        b.joints.len(),
        b.frames
    );
    assert!(worst < 1e-9);
}

#[test]
fn hostile_files_are_refused_with_line_and_expectation() {
    let cases: [(&str, String, &str); 9] = [
        ("empty", String::new(), "expected 'HIERARCHY'"),
        ("truncated", TWO[..TWO.len() - 20].to_string(), "MOTION holds"),
        ("non-finite", TWO.replace("1 2 3 90", "1 2 NaN 90"), "finite number"),
        ("infinite offset", TWO.replace("OFFSET 0 10 0", "OFFSET 0 inf 0"), "finite number"),
        (
            "unknown channel",
            TWO.replace(
                "Zrotation Xrotation Yrotation\n    End",
                "Zrotation Xrotation Wrotation\n    End",
            ),
            "unknown channel 'Wrotation'",
        ),
        ("seven channels", TWO.replace("CHANNELS 3", "CHANNELS 7"), "count of 0 to 6"),
        ("duplicate joint", TWO.replace("JOINT Spine", "JOINT Hips"), "appears twice"),
        (
            "zero frame time",
            TWO.replace("Frame Time: 0.0333333", "Frame Time: 0"),
            "must be positive",
        ),
        ("huge frame count", TWO.replace("Frames: 2", "Frames: 99999999999"), "exceeds"),
    ];
    for (name, text, want) in cases {
        let err = parse(&text).expect_err(name);
        assert!(
            err.contains("t.bvh") && err.contains("BVH line") && err.contains(want),
            "{name}: {err}"
        );
    }
    let unbalanced = TWO.replace("}\nMOTION", "MOTION");
    assert!(parse(&unbalanced).unwrap_err().contains("braces"), "unbalanced");
}
