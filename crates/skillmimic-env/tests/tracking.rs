//! The `tracking` task: a kinematic replay of every demo clip scores the full tracking reward
//! (1, without the power term) with zero position errors; episodes run to their clip's end
//! (truncation, `success` = 1 when the error threshold is never crossed) or terminate when the
//! mean body distance exceeds `termination_distance`.

use std::sync::Arc;

use skillmimic_env::EnvConfig;
use skillmimic_env::episode::reset_state_from_clip;
use skillmimic_env::tasks::imitation::load_motion_library;
use skillmimic_env::tasks::tracking::{Tracking, formulas};
use skillmimic_sim::{BatchSim, Scene};

fn config(n: usize) -> EnvConfig {
    let mut c =
        EnvConfig { task: "tracking".into(), num_envs: n, threads: 1, ..Default::default() };
    c.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    c.tracking.random_start = false;
    c
}

#[test]
fn kinematic_replay_scores_one_with_zero_error() {
    let c = config(1);
    let lib = Arc::new(load_motion_library(&c.motion).unwrap());
    let scene = Arc::new(Scene::new(c.scene_options().unwrap()).unwrap());
    let task = Tracking::new(&c, lib.clone(), scene.clone()).unwrap();
    let mut sim = BatchSim::new(scene, 1, 1).unwrap();
    let bodies = formulas::tracked_bodies(true);
    let mut worst: f64 = 0.0;
    for clip in 0..lib.len() {
        for t in (0..lib.get(clip).clip.num_frames).step_by(7) {
            sim.reset(&[true], &[reset_state_from_clip(lib.get(clip), t)]).unwrap();
            let st = sim.state().env(0);
            let e = formulas::errors(
                &formulas::BodyFrame::from_state(&st),
                &task.reference(clip).frame(t),
                &bodies,
            );
            let r = formulas::reward(&e, 0.0, &c.tracking);
            worst = worst
                .max(e.dist)
                .max(e.dist_rel)
                .max(e.rot2.sqrt())
                .max(e.vel2.sqrt())
                .max(e.angvel2.sqrt());
            assert!((r[5] - 1.0).abs() < 1e-5, "clip {clip} frame {t}: reward {}", r[5]);
        }
    }
    println!(
        "kinematic replay: largest error {worst:.2e} (m, rad, m/s, rad/s; float32 storage of the reference)"
    );
    assert!(worst < 1e-5);
}

#[test]
fn episodes_end_at_the_clip_end_or_on_the_distance() {
    // thresholds out of reach: the episode runs to the clip's end and succeeds
    let mut c = config(2);
    c.tracking.termination_distance = 1e6;
    c.tracking.success_distance = 1e6;
    let mut env = skillmimic_env::registry::make(&c).unwrap();
    assert_eq!(env.obs_dim(), 823 + 24 * 23);
    env.reset_all(Some(0));
    let frames = env.buffers().info[1] as usize; // starts at frame 0
    assert_eq!(frames, 0);
    let mut steps = 0;
    loop {
        env.step(&vec![0.0; 2 * 156]).unwrap();
        steps += 1;
        let b = env.buffers();
        assert!(b.reward[0].is_finite() && b.metrics[..5].iter().all(|m| m.is_finite()));
        if b.truncated[0] == 1 {
            assert_eq!(b.metrics[4], 1.0, "success at the clip end");
            break;
        }
        assert_eq!(b.terminated[0], 0);
        assert_eq!(b.metrics[4], 0.0);
        assert!(steps < 10_000);
    }
    let clip = env.buffers().info[0] as usize;
    println!("zero actions ran {steps} steps to the end of clip {clip}");
    // a 5 cm threshold: zero actions drift from the reference and terminate early
    let mut c = config(1);
    c.tracking.termination_distance = 0.05;
    let mut env = skillmimic_env::registry::make(&c).unwrap();
    env.reset_all(Some(0));
    let mut ended = false;
    for _ in 0..steps {
        env.step(&[0.0; 156]).unwrap();
        let b = env.buffers();
        if b.terminated[0] == 1 {
            assert!(b.metrics[0] > 50.0 && b.metrics[4] == 0.0);
            ended = true;
            break;
        }
    }
    assert!(ended, "zero actions should not track a clip within 5 cm");
}
