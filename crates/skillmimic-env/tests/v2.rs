//! SkillMimic-V2 parts wired into the environment, on the shipped demo clips (skills 50 and 51):
//! STF connections and masked steps, STG alignment and threshold, ATS bookkeeping, the history
//! buffer against a hand-written encoder forward, and every on/off combination stepping without
//! NaN while taking the STF / STG reset paths it enables.

use std::path::PathBuf;
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use skillmimic_core::math::{Quat, heading};
use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::config::{MaskedReward, NoiseEps, V2Config};
use skillmimic_env::hoi::HoiState;
use skillmimic_env::obs::layout;
use skillmimic_env::v2::graph::{StitchGraph, aligned_similarity};
use skillmimic_env::v2::history::{FEATURE_DIM, random_encoder};
use skillmimic_env::v2::similarity::{masked_steps, similarity};
use skillmimic_env::{EnvConfig, ResetPlan, RewardConfig, SkillEnv, StateInit};
use skillmimic_motion::{Clip, MotionLibrary};
use skillmimic_nn::history_reference::torch_reference_embedding;

fn demo_library() -> Arc<MotionLibrary> {
    Arc::new(MotionLibrary::load(&[workspace_root().join("motions")]).unwrap())
}

fn config(n: usize) -> EnvConfig {
    EnvConfig {
        num_envs: n,
        threads: 2,
        motion: vec![workspace_root().join("motions")],
        ..Default::default()
    }
}

fn encoder_file(tag: &str) -> PathBuf {
    let p = std::env::temp_dir()
        .join(format!("skillmimic_test_encoder_{}_{tag}.safetensors", std::process::id()));
    random_encoder(60, 3, 11).save(&p, &Default::default()).unwrap();
    p
}

#[test]
fn stf_connects_to_the_most_similar_frame_and_masks_the_bridge() {
    // no noise: the start state is the clip's own frame, which is its best match
    let mut c = config(6);
    c.v2.stf.enabled = true;
    c.v2.stf.prob = 1.0;
    c.v2.stf.eps = NoiseEps::zero();
    let mut env = SkillEnv::new(c.clone(), demo_library()).unwrap();
    for _ in 0..3 {
        env.reset_all(None);
        for i in 0..6 {
            assert_eq!(env.reset_plan(i), ResetPlan::Connect);
            let ep = env.episode(i);
            assert_eq!(ep.masked_steps, 0, "an exact start needs no bridge");
            // it connects to itself, or to a frame with the same state (the demo dribble repeats
            // every 36 frames, and the first of equally similar frames is taken)
            let (src_clip, src_frame) = env.start_source(i);
            assert_eq!(ep.clip, src_clip);
            let lib = env.library();
            let (x, y) = (
                HoiState::from_reference(lib.get(src_clip), src_frame),
                HoiState::from_reference(lib.get(ep.clip), ep.ref_start),
            );
            let sim = similarity(&x, &y, &c.reward, false);
            assert_eq!(
                sim, 1.0,
                "an exact start connects to an identical state (frame {src_frame} -> {})",
                ep.ref_start
            );
        }
    }
    // with noise: the connection is the argmax of the similarity over frames 2..T-2, and the
    // masked steps follow from it; the reference holds the connected frame while masked
    c.v2.stf.eps = NoiseEps::default();
    c.v2.stf.eps.dof_pos = 0.3;
    c.episode_length = 30;
    let mut env = SkillEnv::new(c.clone(), demo_library()).unwrap();
    let mut masked_seen = 0;
    for round in 0..4 {
        env.reset_all(Some(round));
        let lib = env.library().clone();
        for i in 0..6 {
            let ep = env.episode(i).clone();
            let m = lib.get(ep.clip);
            let st = HoiState::from_sim(&env.sim().state().env(i));
            let sims: Vec<f64> = (2..=m.clip.num_frames - 2)
                .map(|j| {
                    skillmimic_env::v2::similarity::similarity(
                        &st,
                        &HoiState::from_reference(m, j),
                        &c.reward,
                        ep.ball_free,
                    )
                })
                .collect();
            let best = sims.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let j = 2 + sims.iter().position(|&s| s == best).unwrap();
            assert_eq!(ep.ref_start, j);
            assert_eq!(ep.masked_steps, masked_steps(best, 10, 1e-10));
            assert_eq!(ep.inserted, ep.masked_steps);
            masked_seen += ep.masked_steps;
        }
        let zero = vec![0.0f32; 6 * 156];
        for k in 1..=12 {
            env.step(&zero).unwrap();
            for i in 0..6 {
                let ep = env.episode(i);
                if ep.progress != k {
                    continue; // fell and was not reset yet
                }
                let want = ep.ref_start + k.saturating_sub(ep.masked_steps);
                assert_eq!(ep.ref_frame(), want);
                if k <= ep.masked_steps {
                    assert_eq!(env.buffers().reward[i], 0.0, "masked step must not be rewarded");
                }
            }
        }
    }
    assert!(masked_seen > 0, "noise of 0.3 rad per joint component should need bridging steps");
    // compatibility mode: no insertion, the reference advances and masked rewards are the
    // mean over the environments on the same clip
    c.v2.bridge.masked_reward = Some(MaskedReward::ReplaceWithClipMean);
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    env.reset_all(Some(1));
    let zero = vec![0.0f32; 6 * 156];
    env.step(&zero).unwrap();
    let total = skillmimic_env::reward::NUM_TERMS - 1;
    let mut replaced = 0;
    for i in 0..6 {
        let ep = env.episode(i);
        assert_eq!(ep.inserted, 0);
        assert_eq!(ep.ref_frame(), ep.ref_start + 1);
        if ep.masked_steps >= 1 {
            let same: Vec<usize> = (0..6).filter(|&k| env.episode(k).clip == ep.clip).collect();
            let mean = same
                .iter()
                .map(|&k| env.buffers().terms[k * skillmimic_env::reward::NUM_TERMS + total] as f64)
                .sum::<f64>()
                / same.len() as f64;
            assert!((env.buffers().reward[i] as f64 - mean).abs() < 1e-6);
            // the replacement is visible: the environment's own reward differs from the mean
            if (env.buffers().terms[i * skillmimic_env::reward::NUM_TERMS + total] as f64 - mean)
                .abs()
                > 1e-6
            {
                replaced += 1;
            }
        }
    }
    assert!(
        replaced > 0,
        "some masked first step must have its reward replaced by a different clip mean"
    );
}

/// A copy of `c` turned by `yaw` about +z and moved by `shift` on the ground (a different
/// skill label too).
fn moved_clip(c: &Clip, yaw: f64, shift: [f64; 2], skill: u32) -> Clip {
    let q = Quat::about_z(yaw);
    let mut out = c.clone();
    out.skill = skill;
    out.name = format!("{skill:03}_moved");
    let mv = |p: &mut [f32]| {
        let r = q.rotate([p[0] as f64, p[1] as f64, p[2] as f64]);
        p[0] = (r[0] + shift[0]) as f32;
        p[1] = (r[1] + shift[1]) as f32;
        p[2] = r[2] as f32;
    };
    out.root_pos.chunks_exact_mut(3).for_each(mv);
    out.ball_pos.chunks_exact_mut(3).for_each(mv);
    out.body_pos.chunks_exact_mut(3).for_each(mv);
    for r in out.root_rot.chunks_exact_mut(4) {
        let n =
            q.mul(Quat::from_wxyz([r[0] as f64, r[1] as f64, r[2] as f64, r[3] as f64])).to_wxyz();
        r.iter_mut().zip(n).for_each(|(a, b)| *a = b as f32);
    }
    for r in out.ball_rot.chunks_exact_mut(4) {
        let n =
            q.mul(Quat::from_wxyz([r[0] as f64, r[1] as f64, r[2] as f64, r[3] as f64])).to_wxyz();
        r.iter_mut().zip(n).for_each(|(a, b)| *a = b as f32);
    }
    out
}

#[test]
fn stg_connections_respect_threshold_and_alignment() {
    let demo = demo_library();
    let (a, b) = (demo.get(0).clip.clone(), demo.get(1).clip.clone());
    let cfg = RewardConfig::default();
    let lib = MotionLibrary::from_clips(vec![a.clone(), b.clone()]).unwrap();
    let g = StitchGraph::build(&lib, &cfg, 1e-10);
    let (starts, total) = g.stats();
    assert!(starts > 0 && total > 0);
    let (mut min_sim, mut max_sim) = (f64::INFINITY, 0.0f64);
    for clip in 0..2 {
        for t in 2..=lib.get(clip).clip.num_frames - 2 {
            for c in g.connections(clip, t) {
                assert_ne!(c.skill, lib.get(clip).clip.skill, "connections go to other skills");
                assert!(c.similarity >= 1e-10);
                // the stored similarity is that of the aligned target, and it is the best one
                let sa = HoiState::from_reference(lib.get(clip), t);
                let sb = HoiState::from_reference(lib.get(c.clip), c.frame);
                let (s, align) = aligned_similarity(&sa, &sb, &cfg, false);
                assert!((s - c.similarity).abs() <= 1e-12 * s.max(1e-300));
                assert_eq!(align, c.align);
                for f in 2..=lib.get(c.clip).clip.num_frames - 2 {
                    let (o, _) = aligned_similarity(
                        &sa,
                        &HoiState::from_reference(lib.get(c.clip), f),
                        &cfg,
                        false,
                    );
                    assert!(o <= c.similarity);
                }
                // alignment puts the target's root on the start's root x/y and heading
                let aligned = sb.aligned(&c.align);
                assert!(
                    (aligned.root_pos[0] - sa.root_pos[0]).abs() < 1e-9
                        && (aligned.root_pos[1] - sa.root_pos[1]).abs() < 1e-9
                );
                assert!((aligned.root_pos[2] - sb.root_pos[2]).abs() < 1e-12, "heights are kept");
                let dh = heading(Quat::from_rotvec(aligned.root_rotvec))
                    - heading(Quat::from_rotvec(sa.root_rotvec));
                assert!(skillmimic_core::math::wrap_angle(dh).abs() < 1e-9);
                max_sim = max_sim.max(c.similarity);
                min_sim = min_sim.min(c.similarity);
            }
        }
    }
    // moving and turning the other skill's clip changes nothing: alignment happens first
    let lib2 =
        MotionLibrary::from_clips(vec![a.clone(), moved_clip(&b, 1.3, [7.0, -4.0], b.skill)])
            .unwrap();
    let g2 = StitchGraph::build(&lib2, &cfg, 1e-10);
    for t in 2..=a.num_frames - 2 {
        let (c1, c2) = (g.connections(0, t), g2.connections(0, t));
        assert_eq!(c1.len(), c2.len());
        for (x, y) in c1.iter().zip(c2) {
            assert_eq!((x.clip, x.frame), (y.clip, y.frame));
            assert!(
                (x.similarity - y.similarity).abs() <= 1e-4 * x.similarity,
                "{} vs {}",
                x.similarity,
                y.similarity
            );
        }
    }
    // a floor above every similarity removes every connection (distant states are excluded)
    let g3 = StitchGraph::build(&lib, &cfg, max_sim * 1.0001);
    assert_eq!(g3.stats(), (0, 0));
    // a floor between the weakest and the strongest connection keeps some and drops others
    assert!(min_sim < max_sim, "{min_sim} {max_sim}");
    let g4 = StitchGraph::build(&lib, &cfg, 0.5 * (min_sim + max_sim));
    assert!(g4.stats().1 > 0 && g4.stats().1 < total);
}

#[test]
fn stg_switch_imitates_the_other_skill_from_the_sampled_state() {
    let mut c = config(8);
    c.v2.stg.enabled = true;
    c.v2.stg.prob = 1.0;
    c.v2.bridge.tau = 1e-6;
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    let mut switched = 0;
    for round in 0..3 {
        env.reset_all(Some(round));
        for i in 0..8 {
            if env.reset_plan(i) != ResetPlan::Switch {
                continue;
            }
            switched += 1;
            let ep = env.episode(i);
            let m = env.library().get(ep.clip);
            assert_eq!(ep.skill, m.clip.skill);
            // the physical state is another skill's state; the aligned reference starts at the
            // same root x/y, and the observation asks for the target skill
            let st = env.sim().state().env(i);
            let r = HoiState::from_reference(m, ep.ref_start).aligned(&ep.align);
            assert!(
                (r.root_pos[0] - st.pos(0)[0]).abs() < 1e-6
                    && (r.root_pos[1] - st.pos(0)[1]).abs() < 1e-6
            );
            assert_eq!(
                env.buffers().obs[i * env.obs_dim() + layout::SKILL.start + ep.skill as usize],
                1.0
            );
            let (src_clip, src_frame) = env.start_source(i);
            assert_ne!(env.library().get(src_clip).clip.skill, ep.skill);
            let conn = env
                .stitch_graph()
                .unwrap()
                .connections(src_clip, src_frame)
                .iter()
                .find(|c| c.clip == ep.clip && c.frame == ep.ref_start)
                .copied();
            let conn = conn.expect("the episode follows a graph connection of its start state");
            assert_eq!(ep.align, conn.align);
            assert_eq!(ep.masked_steps, masked_steps(conn.similarity, 10, 1e-6));
        }
    }
    assert!(switched > 0, "with p_e = 1 some resets must switch skills");
}

#[test]
fn ats_records_episodes_and_shifts_sampling_to_hard_starts() {
    let mut c = config(8);
    c.v2.ats.enabled = true;
    c.v2.ats.update_interval = 10;
    c.episode_length = 8;
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    let before: Vec<f64> = env.adaptive_sampler().unwrap().frame_probs(0).to_vec();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let mut actions = vec![0.0f32; 8 * 156];
    for _ in 0..40 {
        actions.iter_mut().for_each(|a| *a = 0.2 * rng.random_range(-1.0f32..1.0));
        env.step(&actions).unwrap();
        env.reset_done();
    }
    let ats = env.adaptive_sampler().unwrap();
    let tried: usize = (0..2).map(|c| ats.table(c).iter().filter(|&&r| r > 0.0).count()).sum();
    assert!(tried > 0, "finished episodes must be recorded");
    let after = ats.frame_probs(0);
    assert_ne!(before, after, "the distribution is recomputed every 10 steps");
    // tried starts (positive r̄) get less probability than untried ones (r̄ = 0); 40 steps of
    // 8 environments with 8-step episodes try some but not all start frames of clip 0
    let t0 = ats.table(0);
    let hi = t0.iter().position(|&r| r > 0.0).expect("a start frame of clip 0 was tried");
    let lo = t0.iter().position(|&r| r == 0.0).expect("a start frame of clip 0 was never tried");
    assert!(
        after[hi] < after[lo],
        "tried frame {hi}: p {} vs untried frame {lo}: p {}",
        after[hi],
        after[lo]
    );
}

#[test]
fn history_buffer_feeds_the_observation_with_the_embedding_of_past_frames() {
    let path = encoder_file("obs");
    let mut c = config(3);
    c.v2.history.enabled = true;
    c.v2.history.encoder = path.clone();
    c.state_init = StateInit::Frame(70);
    let mut env = SkillEnv::new(c, demo_library()).unwrap();
    assert_eq!(env.obs_dim(), 905);
    let enc = env.history_encoder().unwrap().clone();
    // after a reset the window holds reference rows 11..70 (FK features) then the current frame
    for i in 0..3 {
        let w = env.history_window(i).unwrap();
        assert_eq!(w.len(), 60 * FEATURE_DIM);
        let obs = &env.buffers().obs[i * 905..(i + 1) * 905];
        // the newest row is the current simulated frame's feature
        assert_eq!(&w[59 * FEATURE_DIM..59 * FEATURE_DIM + 157], &obs[..157]);
        // at frame 70 the previous frame's FK row equals frame 69 of the clip, so the window is
        // continuous: the last reference row and the current row differ by one frame of motion
        let d: f32 = (0..157)
            .map(|k| (w[58 * FEATURE_DIM + k] - w[59 * FEATURE_DIM + k]).abs())
            .fold(0.0, f32::max);
        assert!(d < 0.05, "reference rows run into the simulated rows ({d})");
    }
    let zero = vec![0.0f32; 3 * 156];
    for _ in 0..5 {
        let windows: Vec<Vec<f32>> = (0..3).map(|i| env.history_window(i).unwrap()).collect();
        env.step(&zero).unwrap();
        for i in 0..3 {
            let h = torch_reference_embedding(&enc, &windows[i]);
            let obs = &env.buffers().obs[i * 905..(i + 1) * 905];
            for (k, (&x, &y)) in obs[902..].iter().zip(&h).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-4 * (1.0 + y.abs()),
                    "env {i} embedding {k}: {x} vs hand-written {y}: the embedding summarises the \
                        frames before the step"
                );
            }
            let w = env.history_window(i).unwrap();
            assert_eq!(
                &w[..59 * FEATURE_DIM],
                &windows[i][FEATURE_DIM..],
                "the window slides by one"
            );
        }
        env.reset_done();
    }
    let _ = std::fs::remove_file(path);
}

#[test]
fn every_v2_combination_builds_and_steps_without_nan() {
    let path = encoder_file("combos");
    let lib = demo_library();
    for bits in 0..16u32 {
        let mut c = config(4);
        c.episode_length = 12;
        c.v2 = V2Config::default();
        c.v2.history.enabled = bits & 1 != 0;
        c.v2.history.encoder = path.clone();
        c.v2.stf.enabled = bits & 2 != 0;
        c.v2.stf.prob = 0.5;
        c.v2.stg.enabled = bits & 4 != 0;
        c.v2.stg.prob = 0.5;
        c.v2.ats.enabled = bits & 8 != 0;
        c.v2.ats.update_interval = 5;
        let mut env = SkillEnv::new(c, lib.clone()).unwrap();
        assert_eq!(env.obs_dim(), if bits & 1 != 0 { 905 } else { 902 });
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(bits as u64);
        let mut actions = vec![0.0f32; 4 * 156];
        let mut ends = 0;
        // reset plans taken by the episodes: [plain, connect (STF), switch (STG)]
        let mut plans = [0usize; 3];
        let mut count_plans = |env: &SkillEnv, which: &[bool]| {
            for i in (0..4).filter(|&i| which[i]) {
                plans[env.reset_plan(i) as usize] += 1;
            }
        };
        count_plans(&env, &[true; 4]);
        for _ in 0..30 {
            actions.iter_mut().for_each(|a| *a = 0.3 * rng.random_range(-1.0f32..1.0));
            env.step(&actions).unwrap();
            let b = env.buffers();
            assert!(
                b.obs.iter().all(|x| x.is_finite()),
                "combination {bits:04b}: non-finite observation"
            );
            assert!(
                b.reward.iter().all(|r| r.is_finite() && (0.0..=1.0).contains(r)),
                "combination {bits:04b}: reward {:?}",
                b.reward
            );
            ends += b.terminated.iter().chain(&b.truncated).filter(|&&x| x != 0).count();
            let done: Vec<bool> =
                (0..4).map(|i| b.terminated[i] != 0 || b.truncated[i] != 0).collect();
            env.reset_done();
            count_plans(&env, &done);
        }
        assert!(ends > 0, "combination {bits:04b}: no episode ended");
        // each enabled reset path was taken, and a disabled one never
        assert_eq!(
            plans[ResetPlan::Connect as usize] > 0,
            bits & 2 != 0,
            "combination {bits:04b}: plans {plans:?}"
        );
        assert_eq!(
            plans[ResetPlan::Switch as usize] > 0,
            bits & 4 != 0,
            "combination {bits:04b}: plans {plans:?}"
        );
    }
    let _ = std::fs::remove_file(path);
}
