//! `env.compat` and the contact-graph default in the running environment (demo clips): each
//! switch changes its quantity and nothing else on the same state.

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::config::NoiseEps;
use skillmimic_env::obs::layout;
use skillmimic_env::reward::{NUM_TERMS, TERM_NAMES};
use skillmimic_env::v2::history::{
    FEATURE_DIM, random_encoder, reference_features, reference_window,
};
use skillmimic_env::{Compat, ContactGraphMode, EnvConfig, ResetPlan, SkillEnv, StateInit};
use skillmimic_motion::MotionLibrary;

fn demo_library() -> Arc<MotionLibrary> {
    Arc::new(MotionLibrary::load(&[workspace_root().join("motions")]).unwrap())
}

fn config(n: usize, compat: Compat) -> EnvConfig {
    EnvConfig {
        num_envs: n,
        threads: 2,
        compat,
        motion: vec![workspace_root().join("motions")],
        ..Default::default()
    }
}

#[test]
fn the_papers_force_threshold_graph_is_the_default() {
    let c = EnvConfig::default();
    assert_eq!(
        (c.reward.contact_graph, c.compat),
        (ContactGraphMode::ForceThreshold, Compat::Paper)
    );
    let env = SkillEnv::new(config(1, Compat::Paper), demo_library()).unwrap();
    use skillmimic_env::Task;
    assert_eq!(env.task().spec().info_names, ["ball_node", "body_node"]);
}

#[test]
fn regulariser_compares_the_first_step_with_zero_velocity_in_the_code_profile() {
    // reg_scale 0: every joint counts in the regulariser (with the default 1e12 only joints whose
    // reference velocity is exactly zero do, and the demo clips' reset velocity is zero there too)
    let n = 4;
    let make = |compat| {
        let mut c = config(n, compat);
        c.reward.reg_scale = 0.0;
        SkillEnv::new(c, demo_library()).unwrap()
    };
    let mut envs: Vec<SkillEnv> = vec![make(Compat::Paper), make(Compat::Code)];
    for e in envs.iter_mut() {
        e.reset_all(Some(3));
    }
    assert_eq!(envs[0].buffers().obs, envs[1].buffers().obs, "same starts");
    let reg = TERM_NAMES.iter().position(|&t| t == "reg").unwrap();
    let total = NUM_TERMS - 1;
    let actions = vec![0.1f32; n * NUM_DOFS];
    let mut differ = 0;
    for step in 1..=3 {
        for e in envs.iter_mut() {
            e.step(&actions).unwrap();
        }
        let (a, b) = (&envs[0].buffers(), &envs[1].buffers());
        assert_eq!(a.obs, b.obs, "the physics is the same");
        for i in 0..n {
            for k in 0..NUM_TERMS {
                let (x, y) = (a.terms[i * NUM_TERMS + k], b.terms[i * NUM_TERMS + k]);
                if step == 1 && (k == reg || k == total) {
                    differ += usize::from(x != y && k == reg);
                    continue;
                }
                assert_eq!(x, y, "step {step} env {i}: term {} differs", TERM_NAMES[k]);
            }
        }
    }
    assert!(differ > 0, "the first step's regulariser never differed");
    // zero in the code profile: the reset state's own velocity is not the "previous" one
    let code = SkillEnv::new(config(n, Compat::Code), demo_library()).unwrap();
    assert!(code.episodes().all(|e| e.prev_dof_vel.iter().all(|&v| v == 0.0)));
    let paper = SkillEnv::new(config(n, Compat::Paper), demo_library()).unwrap();
    for i in 0..n {
        assert_eq!(&paper.episode(i).prev_dof_vel[..], paper.sim().state().env(i).dof_vel);
    }
}

#[test]
fn history_rows_at_a_reset_follow_the_profile() {
    // STF without noise: the start state is the sampled frame s, connected to the earliest frame j
    // with the same state (the demo dribble repeats every 36 frames, so j = s − 36 for late s);
    // the physics and the 902 observation entries are the same in both profiles, only the rows
    // placed in the history buffer differ: frames before s (paper) or before j (code)
    let enc = std::env::temp_dir()
        .join(format!("skillmimic_compat_encoder_{}.safetensors", std::process::id()));
    random_encoder(60, 3, 11).save(&enc, &Default::default()).unwrap();
    let n = 8;
    let make = |compat| {
        let mut c = config(n, compat);
        c.v2.history.enabled = true;
        c.v2.history.encoder = enc.clone();
        c.v2.stf.enabled = true;
        c.v2.stf.prob = 1.0;
        c.v2.stf.eps = NoiseEps::zero();
        SkillEnv::new(c, demo_library()).unwrap()
    };
    let (mut paper, mut code) = (make(Compat::Paper), make(Compat::Code));
    let lib = paper.library().clone();
    let rows = reference_features(Arc::clone(paper.sim().scene()), &lib).unwrap();
    let k = 60;
    let mut differing = 0;
    for round in 0..6 {
        paper.reset_all(Some(round));
        code.reset_all(Some(round));
        for i in 0..n {
            let (po, co) = (&paper.buffers().obs, &code.buffers().obs);
            let w = layout::OBS_DIM + 3;
            // the code profile's zero noise goes through an Euler-angle round trip (1e-16 rad)
            let same = po[i * w..i * w + layout::OBS_DIM]
                .iter()
                .zip(&co[i * w..i * w + layout::OBS_DIM])
                .all(|(a, b)| (a - b).abs() < 1e-6);
            assert!(same, "same physical start");
            assert_eq!(paper.reset_plan(i), ResetPlan::Connect);
            let (clip, s) = paper.start_source(i);
            let j = paper.episode(i).ref_start;
            assert_eq!((code.start_source(i), code.episode(i).ref_start), ((clip, s), j));
            let expect = |frame: usize| {
                let mut win = vec![0.0f32; k * FEATURE_DIM];
                reference_window(&rows[clip], frame, &mut win);
                win
            };
            // after the reset the current frame was pushed: rows 1..k of the filled window come
            // first
            let (wp, wc) = (paper.history_window(i).unwrap(), code.history_window(i).unwrap());
            let body = (k - 1) * FEATURE_DIM;
            assert_eq!(
                wp[..body],
                expect(s)[FEATURE_DIM..],
                "paper: rows before the physical start frame {s}"
            );
            assert_eq!(
                wc[..body],
                expect(j)[FEATURE_DIM..],
                "code: rows before the imitated frame {j}"
            );
            if wp[..body] != wc[..body] {
                differing += 1;
            }
        }
    }
    assert!(differing > 0, "no start connected to a different frame: the test saw no difference");
    let _ = std::fs::remove_file(enc);
}

#[test]
fn get_up_is_exempt_from_early_termination_only_in_v2_runs() {
    // the demo clip relabelled as get-up (label 0, ball-free); a termination height above the
    // character makes every other episode end at step 2
    let base = demo_library();
    let mut clip = base.get(0).clip.clone();
    clip.skill = 0;
    clip.name = "000_demo_getup".into();
    let lib = Arc::new(MotionLibrary::from_clips(vec![clip]).unwrap());
    let run = |v2: bool| {
        let mut c = config(2, Compat::Paper);
        c.termination_height = 10.0;
        c.state_init = StateInit::Frame(5);
        c.v2.ats.enabled = v2; // any V2 part makes it a SkillMimic-V2 run
        let mut env = SkillEnv::new(c, Arc::clone(&lib)).unwrap();
        env.set_autoreset(false);
        let zero = vec![0.0f32; 2 * NUM_DOFS];
        (1..=3)
            .map(|_| {
                env.step(&zero).unwrap();
                env.buffers().terminated.clone()
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(
        run(false),
        vec![vec![0, 0], vec![1, 1], vec![1, 1]],
        "SkillMimic never exempts get-up"
    );
    assert_eq!(run(true), vec![vec![0, 0]; 3], "SkillMimic-V2 exempts get-up");
}

#[test]
fn ats_in_the_environment_starts_from_the_library_weights_in_the_code_profile() {
    // the two demo clips relabelled pickup (1) and 2: class-balanced weights with pickup counted
    // twice are [2/3, 1/3]; the paper profile starts class-uniform [1/2, 1/2]
    let base = demo_library();
    let relabel = |c: usize, skill: u32| {
        let mut clip = base.get(c).clip.clone();
        clip.skill = skill;
        clip.name = format!("{skill:03}_demo");
        clip
    };
    let lib = Arc::new(MotionLibrary::from_clips(vec![relabel(0, 1), relabel(1, 2)]).unwrap());
    for (compat, want) in [(Compat::Code, [2.0 / 3.0, 1.0 / 3.0]), (Compat::Paper, [0.5, 0.5])] {
        let mut c = config(2, compat);
        c.v2.ats.enabled = true;
        let env = SkillEnv::new(c, Arc::clone(&lib)).unwrap();
        let p = env.adaptive_sampler().unwrap().clip_probs();
        assert!(p.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{compat:?}: {p:?}");
    }
}
