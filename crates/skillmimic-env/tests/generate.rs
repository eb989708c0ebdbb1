//! Clip generators of active skill learning (`skillmimic_motion::generate`): the pure-Rust
//! forward kinematics equals MuJoCo's; mirroring is an involution whose body positions are the
//! partner bodies' reflected; time warping by 1 is the identity and by ½ doubles the frames;
//! recombination swaps exactly one part; the validity filter names what is wrong; an external
//! command round-trips a clip.

use std::sync::Arc;

use rand::SeedableRng;
use skillmimic_core::characters::skillmimic::{
    NUM_BODIES, NUM_DOFS, body_parts, dof_range, forward_kinematics, mirror_body,
};
use skillmimic_env::episode::reset_state_from_clip;
use skillmimic_motion::generate::{
    ExternalCommand, Generator, Invalid, ModelFree, check_validity, mirror, recombine, time_warp,
};
use skillmimic_motion::{Clip, MotionLibrary};
use skillmimic_sim::{BatchSim, HandModel, Scene};

fn demo() -> MotionLibrary {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions");
    MotionLibrary::load(&[dir]).unwrap()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn forward_kinematics_equals_mujoco() {
    let lib = demo();
    let mut sim =
        BatchSim::new(Arc::new(Scene::default_for(HandModel::Full).unwrap()), 1, 1).unwrap();
    let mut worst: f64 = 0.0;
    for m in lib.clips() {
        for t in (0..m.clip.num_frames).step_by(11) {
            sim.reset(&[true], &[reset_state_from_clip(m, t)]).unwrap();
            let st = sim.state().env(0);
            let p =
                forward_kinematics(m.clip.root_pos_at(t), m.clip.root_quat_at(t), m.clip.dof_at(t));
            for (b, pb) in p.iter().enumerate() {
                let q = st.pos(b);
                worst = worst.max((0..3).map(|k| (pb[k] - q[k]).abs()).fold(0.0, f64::max));
            }
        }
    }
    println!("forward kinematics vs MuJoCo: max {worst:.2e} m");
    assert!(worst < 1e-6);
}

#[test]
fn mirror_time_warp_and_recombination() {
    let lib = demo();
    let c = &lib.get(0).clip;
    let m = mirror(c);
    // body positions: the partner's, reflected across the x-z plane (exactly for the
    // symmetric skeleton up to the wrists; the mocap skeleton's finger offsets differ between the
    // hands by up to 1.3 cm)
    let mut finger_worst: f64 = 0.0;
    for t in 0..c.num_frames {
        for b in 0..NUM_BODIES {
            let (p, q) = (c.body_pos_at(t, b), m.body_pos_at(t, mirror_body(b)));
            let d = (p[0] - q[0]).abs().max((p[1] + q[1]).abs()).max((p[2] - q[2]).abs());
            if skillmimic_core::characters::skillmimic::is_finger(b) {
                finger_worst = finger_worst.max(d);
            } else {
                assert!(d < 1e-5, "frame {t} body {b}: {d}");
            }
        }
    }
    println!("mirrored fingers: up to {finger_worst:.4} m from the reflected partner positions");
    assert!(finger_worst < 0.03);
    let mm = mirror(&m);
    assert!(
        max_diff(&mm.dof_rot, &c.dof_rot) < 1e-6
            && max_diff(&mm.body_pos, &c.body_pos) < 1e-5
            && max_diff(&mm.root_pos, &c.root_pos) < 1e-6
    );
    let dots: Vec<f32> = (0..c.num_frames)
        .map(|t| (0..4).map(|k| mm.root_rot[4 * t + k] * c.root_rot[4 * t + k]).sum::<f32>().abs())
        .collect();
    assert!(dots.iter().all(|d| (d - 1.0).abs() < 1e-5), "the root rotation comes back");
    assert_eq!(mirror(&Clip { skill: 11, ..c.clone() }).skill, 12);

    let same = time_warp(c, 1.0);
    assert_eq!(same.num_frames, c.num_frames);
    assert!(
        max_diff(&same.dof_rot, &c.dof_rot) < 1e-5 && max_diff(&same.body_pos, &c.body_pos) < 1e-5
    );
    let slow = time_warp(c, 0.5);
    assert_eq!(slow.num_frames, 2 * (c.num_frames - 1) + 1);
    assert!(
        max_diff(
            &slow.dof_rot[10 * NUM_DOFS..11 * NUM_DOFS],
            &c.dof_rot[5 * NUM_DOFS..6 * NUM_DOFS]
        ) < 1e-5
    );

    let donor = &lib.get(1).clip;
    let parts = body_parts("five").unwrap();
    let (name, bodies) = &parts[3];
    let r = recombine(c, donor, name, bodies);
    assert_eq!(r.num_frames, c.num_frames.min(donor.num_frames));
    for t in 0..r.num_frames {
        for b in 1..NUM_BODIES {
            let d = dof_range(b);
            let want = if bodies.contains(&b) { donor } else { c };
            assert_eq!(
                &r.dof_rot[t * NUM_DOFS + d.start..t * NUM_DOFS + d.end],
                &want.dof_rot[t * NUM_DOFS + d.start..t * NUM_DOFS + d.end]
            );
        }
    }
    assert_eq!(&r.root_pos[..], &c.root_pos[..3 * r.num_frames]);
}

#[test]
fn validity_filter_names_the_problem() {
    let lib = demo();
    let c = lib.get(0).clip.clone();
    assert_eq!(check_validity(&c, 0.05, 60.0), Ok(()));
    let mut low = c.clone();
    low.body_pos.iter_mut().skip(2).step_by(3).for_each(|z| *z -= 1.5);
    let e = check_validity(&low, 0.05, 60.0).unwrap_err();
    assert!(matches!(e, Invalid::BelowFloor { frame: 0, .. }), "{e}");
    assert!(e.to_string().contains("below the floor"), "{e}");
    let mut fast = c.clone();
    fast.dof_rot[5 * NUM_DOFS + 3] += 2.0; // L_Knee jumps by 2 rad at frame 5
    let e = check_validity(&fast, 0.05, 60.0).unwrap_err();
    assert!(matches!(e, Invalid::TooFast { joint: "L_Knee", frame: 5, .. }), "{e}");
    let mut nan = c.clone();
    nan.root_pos[3 * 7] = f32::NAN;
    assert!(matches!(
        check_validity(&nan, 0.05, 60.0).unwrap_err(),
        Invalid::NonFinite { field: "root_pos", frame: 7, .. }
    ));
}

#[test]
fn generators_model_free_and_external_command() {
    let lib = demo();
    let clips: Vec<Clip> = lib.clips().iter().map(|m| m.clip.clone()).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let out = ModelFree::default().generate(&clips[0], &clips, &mut rng).unwrap();
    assert!(out.len() >= 2 && out.iter().all(|c| c.name.starts_with(&clips[0].name)));
    for c in &out {
        check_validity(c, 0.05, 60.0).unwrap_or_else(|e| panic!("{}: {e}", c.name));
    }
    let dir = std::env::temp_dir().join(format!("skillmimic-gen-{}", std::process::id()));
    let mut copy = ExternalCommand::new(
        "sh".into(),
        vec!["-c".into(), "cp \"$0\" \"$1/copy.safetensors\"".into()],
        dir.clone(),
    );
    let back = copy.generate(&clips[0], &clips, &mut rng).unwrap();
    assert_eq!(back.len(), 1);
    assert_eq!(
        (back[0].dof_rot.clone(), back[0].root_pos.clone(), back[0].skill),
        (clips[0].dof_rot.clone(), clips[0].root_pos.clone(), clips[0].skill)
    );
    let mut broken =
        ExternalCommand::new("sh".into(), vec!["-c".into(), "exit 3".into()], dir.clone());
    let e = broken.generate(&clips[0], &clips, &mut rng).unwrap_err().to_string();
    assert!(e.contains("external command sh") && e.contains("exit"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
