//! Kinematic validation of the generated humanoid against the real BallPlay-M clips: forward
//! kinematics from each clip's root pose and joint exp maps must reproduce the clip's stored body
//! positions, and the stored bone lengths must equal the model's body offsets.

use std::sync::Arc;

use skillmimic_core::characters::skillmimic::{BODIES, NUM_BODIES};
use skillmimic_core::shared_data::{ballplay_clips, shared_dir_or_skip};
use skillmimic_motion::Clip;
use skillmimic_sim::{BatchSim, HandModel, ResetState, Scene};

fn reset_state(clip: &Clip, t: usize) -> ResetState {
    let mut s = ResetState::default();
    s.root_pos = clip.root_pos_at(t);
    s.root_quat = clip.root_quat_at(t);
    for (d, &v) in s.dof_pos.iter_mut().zip(clip.dof_at(t)) {
        *d = v as f64;
    }
    s.ball_mut().pos = clip.ball_pos_at(t);
    s
}

#[test]
fn forward_kinematics_reproduces_stored_body_positions_on_all_clips() {
    let Some(shared) =
        shared_dir_or_skip("forward_kinematics_reproduces_stored_body_positions_on_all_clips")
    else {
        return;
    };
    let clips = ballplay_clips(&shared);
    assert!(clips.len() >= 50, "expected the 56 shared clips, found {}", clips.len());
    let scene = Arc::new(Scene::default_for(HandModel::Full).unwrap());
    const N: usize = 32;
    let mut sim = BatchSim::new(scene.clone(), N, 0).unwrap();

    // the model's own bone lengths (offsets of the compiled bodies)
    let model_body_pos = scene.model().body_pos();
    let bone: Vec<f64> = (0..NUM_BODIES)
        .map(|b| {
            let o = model_body_pos[scene.body_ids[b]];
            (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
        })
        .collect();

    let (mut total_err, mut total_n) = (0.0f64, 0usize);
    let mut worst_bone = 0.0f64;
    let mut worst_body = 0.0f64;
    println!(
        "{:<45} {:>6} {:>10} {:>10} {:>12}",
        "clip", "frames", "mean [cm]", "max [cm]", "bone err [m]"
    );
    for path in &clips {
        let clip = Clip::from_pt(path).unwrap();
        let (mut clip_err, mut clip_n, mut clip_max, mut clip_bone) =
            (0.0f64, 0usize, 0.0f64, 0.0f64);
        for start in (0..clip.num_frames).step_by(N) {
            let frames: Vec<usize> = (start..(start + N).min(clip.num_frames)).collect();
            let mut mask = vec![false; N];
            let mut states = vec![ResetState::default(); N];
            for (e, &t) in frames.iter().enumerate() {
                mask[e] = true;
                states[e] = reset_state(&clip, t);
            }
            sim.reset(&mask, &states).unwrap();
            for (e, &t) in frames.iter().enumerate() {
                let st = sim.state().env(e);
                for b in 0..NUM_BODIES {
                    let (p, r) = (st.pos(b), clip.body_pos_at(t, b));
                    let err =
                        ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2))
                            .sqrt();
                    clip_err += err;
                    clip_n += 1;
                    clip_max = clip_max.max(err);
                    if let Some(parent) = BODIES[b].parent {
                        let q = clip.body_pos_at(t, parent);
                        let len =
                            ((r[0] - q[0]).powi(2) + (r[1] - q[1]).powi(2) + (r[2] - q[2]).powi(2))
                                .sqrt();
                        clip_bone = clip_bone.max((len - bone[b]).abs());
                    }
                }
            }
        }
        let name = path.file_name().unwrap().to_string_lossy();
        println!(
            "{:<45} {:>6} {:>10.2} {:>10.2} {:>12.2e}",
            name,
            clip.num_frames,
            100.0 * clip_err / clip_n as f64,
            100.0 * clip_max,
            clip_bone
        );
        total_err += clip_err;
        total_n += clip_n;
        worst_bone = worst_bone.max(clip_bone);
        worst_body = worst_body.max(clip_max);
    }
    let mean = total_err / total_n as f64;
    println!(
        "ALL {} clips: mean per-body error {:.2} cm (reference model 3.1 cm), worst {:.1} cm, \
            worst bone-length error {:.1e} m",
        clips.len(),
        100.0 * mean,
        100.0 * worst_body,
        worst_bone
    );
    assert!(mean <= 0.035, "mean per-body FK error {:.2} cm exceeds 3.5 cm", 100.0 * mean);
    assert!(
        worst_bone <= 1e-4,
        "stored bone lengths differ from the model offsets by {worst_bone:.2e} m"
    );
}
