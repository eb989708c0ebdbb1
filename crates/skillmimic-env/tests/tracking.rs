//! The `tracking` task: a kinematic replay of every demo clip scores the full tracking reward
//! (1, without the power term) with zero position errors; episodes run to their clip's end
//! (truncation, `success` = 1 when the error threshold is never crossed) or terminate when the
//! mean body distance exceeds `termination_distance`.

use std::sync::Arc;

use skillmimic_env::EnvConfig;
use skillmimic_env::tasks::tracking::config::TrackingConfig;
use skillmimic_env::tasks::tracking::motion::Motion;
use skillmimic_env::tasks::tracking::{Tracking, formulas};
use skillmimic_sim::{BatchSim, ResetState, Scene};

fn config(n: usize) -> EnvConfig {
    let mut c =
        EnvConfig { task: "tracking".into(), num_envs: n, threads: 1, ..Default::default() };
    c.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    c.table_mut::<TrackingConfig>().random_start = false;
    c
}

#[test]
fn kinematic_replay_scores_one_with_zero_error_on_every_character() {
    for character in ["skillmimic", "smpl"] {
        let mut c = config(1);
        c.character = character.into();
        let ch = skillmimic_env::registry::character(&c).unwrap();
        let scene =
            Arc::new(Scene::new(skillmimic_env::registry::scene_options(&c).unwrap()).unwrap());
        let motion = Motion::load(&c.motion, ch).unwrap();
        let spec = scene.character().clone();
        let frames: Vec<usize> = (0..motion.len()).map(|k| motion.frames(k)).collect();
        let clips = match &motion {
            Motion::Clips(clips) => clips.clone(),
            Motion::SkillMimic(_) => Vec::new(),
        };
        let task = Tracking::new(&c, motion, scene.clone()).unwrap();
        let motion = Motion::load(&c.motion, ch).unwrap();
        let mut sim = BatchSim::new(scene.clone(), 1, 1).unwrap();
        let mut state = ResetState::rest(&scene);
        let bodies = formulas::tracked_bodies(&spec, true);
        let (mut worst, mut worst_fk): (f64, f64) = (0.0, 0.0);
        for (clip, &n) in frames.iter().enumerate() {
            for t in (0..n).step_by(7) {
                motion.fill_state(&spec, clip, t, &mut state);
                sim.reset(&[true], std::slice::from_ref(&state)).unwrap();
                let st = sim.state().env(0);
                let e = formulas::errors(&st, &task.reference(clip).frame(t), &bodies);
                let r = formulas::reward(&e, 0.0, c.table::<TrackingConfig>());
                worst = worst
                    .max(e.dist)
                    .max(e.dist_rel)
                    .max(e.rot2.sqrt())
                    .max(e.vel2.sqrt())
                    .max(e.angvel2.sqrt());
                assert!(
                    (r[5] - 1.0).abs() < 1e-5,
                    "{character} clip {clip} frame {t}: reward {}",
                    r[5]
                );
                // MuJoCo's forward kinematics of the clip's joint coordinates (three hinges per
                // SMPL joint) puts every body where the clip's own kinematics does
                if let Some(cc) = clips.get(clip) {
                    for b in 0..spec.bodies.len() {
                        let (p, q) = (st.pos(b), cc.body_pos_at(t, b));
                        worst_fk =
                            worst_fk.max((0..3).map(|k| (p[k] - q[k]).abs()).fold(0.0, f64::max));
                    }
                }
            }
        }
        println!(
            "{character}: kinematic replay of {} clips, largest error {worst:.2e} (m, rad, m/s, \
                rad/s; float32 storage of the reference); body positions vs the clips' \
                {worst_fk:.2e} m",
            frames.len()
        );
        assert!(worst < 1e-5);
        assert!(worst_fk < 1e-5);
    }
}

#[test]
fn episodes_end_at_the_clip_end_or_on_the_distance() {
    // thresholds out of reach: the episode runs to the clip's end and succeeds
    let mut c = config(2);
    c.table_mut::<TrackingConfig>().termination_distance = 1e6;
    c.table_mut::<TrackingConfig>().success_distance = 1e6;
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
    c.table_mut::<TrackingConfig>().termination_distance = 0.05;
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

/// A termination body the character does not have is refused with the field and the name.
#[test]
fn unknown_termination_bodies_are_refused() {
    let mut c = config(1);
    c.character = "smpl".into();
    c.table_mut::<TrackingConfig>().termination_bodies = vec!["Pelvis".into(), "Tail".into()];
    let err = skillmimic_env::tasks::tracking::build(&c).err().expect("refused").to_string();
    assert!(err.contains("env.tracking.termination_bodies") && err.contains("'Tail'"), "{err}");
    c.table_mut::<TrackingConfig>().termination_bodies = vec!["Pelvis".into(), "Head".into()];
    assert!(skillmimic_env::tasks::tracking::build(&c).is_ok());
}
