//! Kinematic replay on the real BallPlay-M clips: the reward of a clip scored against itself is
//! what the data allows, Acc with label contacts is >= 95 %, and the simulated contact graphs
//! (MuJoCo's exact hand–ball pairs and the papers' force-threshold nodes) are compared with the
//! clip labels.

use std::sync::Arc;

use skillmimic_core::shared_data::{ballplay_clips, shared_dir_or_skip};
use skillmimic_env::RewardConfig;
use skillmimic_env::replay::kinematic_replay;
use skillmimic_motion::MotionLibrary;
use skillmimic_sim::{HandModel, Scene};

#[test]
fn kinematic_replay_scores_real_clips_against_themselves() {
    let Some(shared) = shared_dir_or_skip("kinematic_replay_scores_real_clips_against_themselves")
    else {
        return;
    };
    let files = ballplay_clips(&shared);
    let lib = MotionLibrary::load(&files).unwrap();
    let scene = Arc::new(Scene::default_for(HandModel::Full).unwrap());
    let all: Vec<usize> = (0..lib.len()).collect();
    let rep = kinematic_replay(scene, &lib, &all, &RewardConfig::default()).unwrap();
    println!("kinematic replay of {} clips, {} frames", lib.len(), rep.frames);
    for t in ["p", "r", "reg", "op", "ig", "total"] {
        println!("  mean r_{t:<5} = {:.4}", rep.term_mean(t));
    }
    let l = &rep.metrics_label_contacts;
    let s = &rep.metrics_sim_contacts;
    println!(
        "  contacts from labels: Acc {:.2} %, E_b-mpjpe {:.1} mm, E_o-mpjpe {:.1} mm",
        l.acc_percent(),
        l.body_mpjpe_mm(),
        l.ball_mpjpe_mm()
    );
    println!(
        "  contacts from MuJoCo exact pairs: Acc {:.2} %, E_cg {:.4}",
        s.acc_percent(),
        s.cg_error()
    );
    let mut gaps = rep.label1_hand_gap.clone();
    gaps.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| gaps[((gaps.len() - 1) as f64 * p) as usize];
    println!(
        "  hand-ball: label 1 in {} frames, MuJoCo contact in {} ({:.1} %); label 0 in {} frames, \
            MuJoCo contact in {} ({:.1} %); agreement {:.1} %",
        rep.label1_frames,
        rep.label1_detected,
        100.0 * rep.label1_detected as f64 / rep.label1_frames as f64,
        rep.label0_frames,
        rep.label0_detected,
        100.0 * rep.label0_detected as f64 / rep.label0_frames as f64,
        100.0 * rep.contact_agreement()
    );
    println!(
        "  label-1 frames: gap ball surface -> nearest hand body origin: median {:.3} m, 90th pct \
            {:.3} m",
        q(0.5),
        q(0.9)
    );
    // joints and ball are replayed exactly: only float rounding remains
    assert!(rep.term_mean("r") > 0.999, "r_r {}", rep.term_mean("r"));
    assert!(rep.term_mean("op") > 0.999, "r_op {}", rep.term_mean("op"));
    assert!(rep.term_mean("reg") > 0.99, "r_reg {}", rep.term_mean("reg"));
    // key bodies carry the ~3 cm FK-vs-stored mismatch of the data: exp(-20 * (0.03 m)^2 ...) ~
    // 0.97
    assert!(
        rep.term_mean("p") > 0.95 && rep.term_mean("ig") > 0.95,
        "r_p {} r_ig {}",
        rep.term_mean("p"),
        rep.term_mean("ig")
    );
    assert!(l.acc_percent() >= 95.0, "Acc with label contacts {:.2} %", l.acc_percent());
    // Exact pairs need the replayed hand to touch the ball. The replayed hand is forward
    // kinematics of the stored joints, which misses the captured hand by 2-5 cm on average for
    // wrists and fingers (reference-facts 1.6c), so in label-1 frames the hand often floats a few
    // centimetres off the ball (gap distribution printed above) and ~40 % of them show no
    // geometric contact, while label-0 frames rarely touch. Measured: 76.8 % agreement, 60.6 % of
    // label-1 frames detected, 4.7 % false contacts. The thresholds leave room for small model
    // changes but fail for a misplaced hand or ball (wrong body order or geometry -> detection
    // near 0 %, or contacts everywhere).
    // The papers' force-threshold graph on the same frames (ball node: |F_x| or |F_y| > 0.1 N from
    // any contact, floor included; body node: any force component ≥ 0.1 N on the 17 body-node
    // bodies, target 0).
    println!(
        "  force-threshold graph: ball node = label in {:.1} % of frames (on in {:.1} % of \
            label-1, {:.1} % of label-0 frames); body node = 0 in {:.1} % of frames",
        100.0 * rep.force_ball_agreement(),
        100.0 * rep.force_ball_label1 as f64 / rep.label1_frames as f64,
        100.0 * rep.force_ball_label0 as f64 / rep.label0_frames as f64,
        100.0 * rep.force_body_agreement()
    );
    let detected = rep.label1_detected as f64 / rep.label1_frames as f64;
    let false_pos = rep.label0_detected as f64 / rep.label0_frames as f64;
    assert!(rep.contact_agreement() >= 0.70, "agreement {:.3}", rep.contact_agreement());
    assert!(
        detected >= 0.5 && false_pos <= 0.10,
        "label-1 detection {detected:.3}, label-0 false contacts {false_pos:.3}"
    );
    // Force-threshold graph, measured on the 64 clips: the ball node equals the label in 70.3 %
    // of frames (61.8 % of label-1 frames, i.e. the replayed hand presses on the ball; 19.3 % of
    // label-0 frames, mostly floor contacts: the node counts every source); the body node is 0 in
    // 98.3 %.
    assert!(
        rep.force_ball_agreement() >= 0.6,
        "force-threshold ball node agreement {:.3}",
        rep.force_ball_agreement()
    );
    assert!(
        rep.force_body_agreement() >= 0.95,
        "force-threshold body node agreement {:.3}",
        rep.force_body_agreement()
    );
    // Acc as the imitation task scores these frames (default: the force-threshold graph, both
    // nodes must agree), the ceiling `eval` prints beside a policy's Acc: no higher than the ball
    // node's agreement, and above the frames where both nodes agree minus the body-error misses
    let task = rep.metrics_task_contacts.acc_percent();
    println!("  Acc ceiling (the task's frame scoring of the replay): {task:.1} %");
    assert_eq!(rep.metrics_task_contacts.frames, rep.frames);
    let both_floor = 100.0 * (rep.force_ball_agreement() + rep.force_body_agreement() - 1.0);
    assert!(task <= 100.0 * rep.force_ball_agreement() + 1e-9, "{task}");
    assert!(task >= both_floor - 2.0, "{task} vs {both_floor}");
}
