//! The shipped demo clips regenerate byte for byte, replay exactly on the model and touch the
//! ball when their label says so.

use std::sync::Arc;

use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::RewardConfig;
use skillmimic_env::replay::kinematic_replay;
use skillmimic_env::synth::demo_clips;
use skillmimic_motion::{Clip, MotionLibrary};
use skillmimic_sim::{HandModel, Scene};

#[test]
fn shipped_demo_clips_regenerate_byte_identically() {
    let dir = std::env::temp_dir().join(format!("skillmimic-synth-{}", std::process::id()));
    for clip in demo_clips().unwrap() {
        let name = format!("{}.safetensors", clip.name);
        let fresh = dir.join(&name);
        clip.save(&fresh).unwrap();
        let shipped = workspace_root().join("motions").join(&name);
        let a = std::fs::read(&shipped).unwrap_or_else(|e| {
            panic!("{}: {e} (run `skillmimic synth-motions`)", shipped.display())
        });
        let b = std::fs::read(&fresh).unwrap();
        assert!(
            a == b,
            "{} differs from a fresh `skillmimic synth-motions` run",
            shipped.display()
        );
        assert_eq!(Clip::load(&shipped).unwrap(), clip);
    }
}

#[test]
fn demo_clips_replay_exactly_and_touch_the_ball_in_contact_frames() {
    let lib = MotionLibrary::from_clips(demo_clips().unwrap()).unwrap();
    let scene = Arc::new(Scene::default_for(HandModel::Full).unwrap());
    let rep = kinematic_replay(scene, &lib, &[0, 1], &RewardConfig::default()).unwrap();
    let det = rep.label1_detected as f64 / rep.label1_frames as f64;
    let fp = rep.label0_detected as f64 / rep.label0_frames as f64;
    println!(
        "demo replay: r_p {:.5}, r_r {:.5}, r_ig {:.5}, hand-ball detected in {:.1} % of label-1 \
            frames, {:.1} % of label-0 frames",
        rep.term_mean("p"),
        rep.term_mean("r"),
        rep.term_mean("ig"),
        100.0 * det,
        100.0 * fp
    );
    // stored body positions are forward kinematics of the model itself
    assert!(rep.term_mean("p") > 0.9999 && rep.term_mean("r") > 0.9999);
    assert!(rep.metrics_label_contacts.body_mpjpe_mm() < 0.01);
    assert!(det >= 0.8 && fp <= 0.1, "detected {det:.3}, false {fp:.3}");
}
