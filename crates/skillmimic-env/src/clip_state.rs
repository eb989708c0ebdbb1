//! The simulator state of one frame of a character clip, for any character: the reset state of
//! a tracking episode and the poses of the motion prior's reference frames.

use std::sync::Arc;

use skillmimic_core::characters::{Character, CharacterSpec, JointDef};
use skillmimic_motion::character_clip::CharacterClip;
use skillmimic_sim::{BatchSim, EnvState, ResetState, Scene, SceneOptions};

use crate::error::EnvError;

/// The state of frame `t` of a character clip: its root pose and dof vector, velocities by finite
/// differences to the next frame (the last frame uses the previous interval): root linear
/// velocity in the world frame, root and ball-joint angular velocities from the relative rotation
/// of consecutive frames (in the body frame, MuJoCo's convention), hinge rates.
pub fn clip_state(spec: &CharacterSpec, clip: &CharacterClip, t: usize, s: &mut ResetState) {
    let t0 = t.min(clip.num_frames - 2);
    let dt = 1.0 / clip.fps;
    let (p0, p1) = (clip.root_pos_at(t0), clip.root_pos_at(t0 + 1));
    let (q0, q1) = (clip.root_quat_at(t0), clip.root_quat_at(t0 + 1));
    let w = q0.conj().mul(q1).normalized().to_rotvec();
    s.root_pos = clip.root_pos_at(t);
    s.root_quat = clip.root_quat_at(t).normalized();
    s.root_linvel = [(p1[0] - p0[0]) / dt, (p1[1] - p0[1]) / dt, (p1[2] - p0[2]) / dt];
    s.root_angvel_local = [w[0] / dt, w[1] / dt, w[2] / dt];
    s.dof_vel.fill(0.0);
    let (d, d0, d1) = (clip.dof_at(t), clip.dof_at(t0), clip.dof_at(t0 + 1));
    for (k, &x) in d.iter().enumerate() {
        s.dof_pos[k] = x as f64;
    }
    for body in &spec.bodies {
        let k = body.dofs.start;
        match &body.joint {
            JointDef::Ball { .. } => {
                let r = |x: &[f32]| {
                    skillmimic_core::math::Quat::from_rotvec([
                        x[k] as f64,
                        x[k + 1] as f64,
                        x[k + 2] as f64,
                    ])
                };
                let w = r(d0).conj().mul(r(d1)).normalized().to_rotvec();
                for a in 0..3 {
                    s.dof_vel[k + a] = w[a] / dt;
                }
            }
            JointDef::Hinges { hinges, .. } => {
                for j in k..k + hinges.len() {
                    s.dof_vel[j] = (d1[j] - d0[j]) as f64 / dt;
                }
            }
            JointDef::Free | JointDef::Welded => {}
        }
    }
}

/// Per-frame features (`width` wide, by `features`) of every frame of `clips` of `character`,
/// each frame posed in the character's bare scene from [`clip_state`] (no physics step):
/// `[clip][T × width]`. The motion priors' reference frames.
pub fn posed_features(
    character: Character,
    clips: &[CharacterClip],
    width: usize,
    features: fn(&EnvState<'_>, &mut [f32]),
) -> Result<Vec<Vec<f32>>, EnvError> {
    let scene = Arc::new(Scene::new(SceneOptions::bare(character))?);
    let mut sim = BatchSim::new(scene, 1, 1)?;
    let spec = character.spec();
    let mut state = ResetState::of(&spec, 0);
    let mut out = Vec::with_capacity(clips.len());
    for c in clips {
        let mut rows = vec![0.0f32; c.num_frames * width];
        for t in 0..c.num_frames {
            clip_state(&spec, c, t, &mut state);
            sim.reset(&[true], std::slice::from_ref(&state))?;
            features(&sim.state().env(0), &mut rows[t * width..(t + 1) * width]);
        }
        out.push(rows);
    }
    Ok(out)
}
