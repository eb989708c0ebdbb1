//! Light IK in retargeting (issue 23, `--ik`) on a real mocap file (MocapBank, from the crates.io
//! package bvh_anim 0.4.0): with IK the ankles and wrists sit on the source's positions × scale
//! (checked here from the BVH's own forward kinematics, not from the retargeter's), the hips'
//! midpoint sits on the source's, the torso keeps its shape, planted feet slide no more than
//! without IK, and the clip stays free of penetration and speed spikes.

use skillmimic_core::characters::skillmimic as skeleton;
use skillmimic_core::math::{norm, sub};
use skillmimic_motion::bvh;
use skillmimic_motion::retarget_bvh::{self, JointMap, Options};
use skillmimic_motion::retarget_clip::{Ball, to_clip};

#[test]
fn ik_puts_ankles_and_wrists_on_the_scaled_source() {
    let Some(path) = skillmimic_core::shared_data::registry_file_or_skip(
        "mocapbank BVH",
        "bvh_anim-0.4.0",
        "data/test_mocapbank.bvh",
    ) else {
        return;
    };
    let b = bvh::read(&path).unwrap();
    let map = JointMap::load("mocapbank").unwrap();
    // output at the source's rate: output frame k is source frame k (no resampling in the check)
    let fps = 1.0 / b.frame_time;
    let plain =
        retarget_bvh::retarget(&b, &map, &Options { fps, ground: true, ik: false }).unwrap();
    let ik = retarget_bvh::retarget(&b, &map, &Options { fps, ground: true, ik: true }).unwrap();
    assert_eq!((plain.frames, ik.frames), (b.frames, b.frames));
    let ends = [
        ("L_Hip", "L_Ankle"),
        ("R_Hip", "R_Ankle"),
        ("L_Shoulder", "L_Wrist"),
        ("R_Shoulder", "R_Wrist"),
    ];
    let (mut before, mut after, mut after_max, mut out_of_reach) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for k in 0..b.frames {
        let pose = b.pose(k);
        let (p0, p1) =
            (retarget_bvh::body_positions(&plain, k), retarget_bvh::body_positions(&ik, k));
        for (upper, e) in ends {
            let body = skeleton::body_index(e).unwrap();
            let up = skeleton::body_index(upper).unwrap();
            let j = b.joint(map.bodies[e].as_str()).unwrap();
            // the target: the source joint in the world, like the root (scale, axes, ground shift)
            let t0 = plain.source_to_world(pose.positions[j]);
            let t1 = ik.source_to_world(pose.positions[j]);
            let (t0, t1) = (
                [t0[0], t0[1], t0[2] + plain.ground_shift],
                [t1[0], t1[1], t1[2] + ik.ground_shift],
            );
            before += norm(sub(p0[body], t0));
            let d = norm(sub(p1[body], t1));
            after += d;
            after_max = after_max.max(d);
            // a target within the limb's reach is met; one beyond it leaves the straight-limb gap
            let reach = norm(skeleton::BODIES[body].offset)
                + norm(skeleton::BODIES[body - 1].offset)
                - 1e-3;
            let gap = norm(sub(t1, p1[up])) - reach;
            if gap < -1e-3 {
                assert!(d < 1e-6, "{e} at frame {k}: {d} m from a reachable target");
            } else {
                out_of_reach += 1;
                assert!(
                    d <= gap.max(0.0) + 1e-3,
                    "{e} at frame {k}: {d} m from a target {gap} m beyond reach"
                );
            }
        }
    }
    let n = (b.frames * ends.len()) as f64;
    let (before, after) = (before / n, after / n);
    let c0 = to_clip(&plain, "plain", "mocapbank", 1, &Ball::None, b.frame_time, &path).unwrap().1;
    let c1 = to_clip(&ik, "ik", "mocapbank", 1, &Ball::None, b.frame_time, &path).unwrap().1;
    println!(
        "ankles and wrists from the scaled source: {:.1} mm mean without IK, {:.2} mm mean / \
         {:.2} mm max with IK (report: ankles {:.2} / {:.2} mm, wrists {:.2} / {:.2} mm; \
         {out_of_reach} of {n} targets beyond the limb's reach); \
         ground shift {:.1} → {:.1} mm, foot sliding {:.3} → {:.3} m/s, \
         deepest sole {:.1} → {:.1} mm, fastest joint {:.1} → {:.1} rad/s",
        1000.0 * before,
        1000.0 * after,
        1000.0 * after_max,
        1000.0 * c1.ik.feet_mean_m,
        1000.0 * c1.ik.feet_max_m,
        1000.0 * c1.ik.hands_mean_m,
        1000.0 * c1.ik.hands_max_m,
        1000.0 * plain.ground_shift,
        1000.0 * ik.ground_shift,
        c0.foot_sliding_mean_m_s,
        c1.foot_sliding_mean_m_s,
        1000.0 * c0.foot_penetration_max_m,
        1000.0 * c1.foot_penetration_max_m,
        c0.max_joint_speed_rad_s,
        c1.max_joint_speed_rad_s
    );
    assert!(
        before > 0.01,
        "the proportions differ, so rotations alone miss by more than 1 cm ({before} m)"
    );
    assert!(after < before / 5.0, "IK ends {after} m mean from the targets (without: {before} m)");
    assert!(c1.ik.feet_mean_m < 1e-3 && c1.ik.feet_max_m < 0.01, "ankles {:?}", c1.ik);
    assert!(
        (c1.ik.feet_max_m.max(c1.ik.hands_max_m) - after_max).abs() < 1e-6,
        "report {:?} vs {after_max}",
        c1.ik
    );
    assert!(
        c1.foot_sliding_mean_m_s <= c0.foot_sliding_mean_m_s + 1e-3,
        "sliding {} → {}",
        c0.foot_sliding_mean_m_s,
        c1.foot_sliding_mean_m_s
    );
    assert!(c1.foot_penetration_max_m < 0.02 && c1.frames_with_speed_spike == 0, "{c1:?}");
    // IK moves the root (hips' midpoint onto the source's) and bends the limbs; the torso's shape
    // (pelvis, spine, head, shoulders and hips relative to the pelvis) is unchanged
    let (lh, rh) = (skeleton::body_index("L_Hip").unwrap(), skeleton::body_index("R_Hip").unwrap());
    let mut hips_worst = 0.0f64;
    for k in 0..b.frames {
        let (p0, p1) =
            (retarget_bvh::body_positions(&plain, k), retarget_bvh::body_positions(&ik, k));
        for name in ["Chest", "Head", "L_Shoulder", "R_Hip"] {
            let i = skeleton::body_index(name).unwrap();
            assert!(
                norm(sub(sub(p0[i], p0[0]), sub(p1[i], p1[0]))) < 1e-9,
                "{name} moved relative to the pelvis at frame {k}"
            );
        }
        let pose = b.pose(k);
        let src_mid: [f64; 3] = std::array::from_fn(|c| {
            let w = |n: &str| {
                ik.source_to_world(pose.positions[b.joint(map.bodies[n].as_str()).unwrap()])[c]
            };
            0.5 * (w("L_Hip") + w("R_Hip")) + if c == 2 { ik.ground_shift } else { 0.0 }
        });
        let mid: [f64; 3] = std::array::from_fn(|c| 0.5 * (p1[lh][c] + p1[rh][c]));
        hips_worst = hips_worst.max(norm(sub(mid, src_mid)));
    }
    assert!(hips_worst < 1e-9, "hips' midpoint {hips_worst} m from the source's");
}
