//! Reference quantities derived once per clip (SkillMimic's per-clip processing).
//!
//! Velocities are backward differences times the frame rate, with frame 0 set to zero:
//! * root linear velocity (world, m/s);
//! * root angular velocity in the **root frame**: rotvec(conj(q\[t−1\]) · q\[t\]) · fps (rad/s) —
//!   the convention of a MuJoCo free joint's `qvel[3:6]`;
//! * joint velocities: difference of exp-map components (an approximation of the local angular
//!   velocity, as in the original code);
//! * key-body and ball velocities (world, m/s); ball angular velocity from consecutive ball
//!   orientations (zero for BallPlay-M, which stores no ball rotation).
//!
//! The root exp map is recomputed from the (sign-continuous) quaternion with angle in (−π, π].
//! Arrays are float32 like the clip (the differences are taken in f64 first).

use skillmimic_core::characters::skillmimic::{KEY_BODIES, NUM_BODIES, NUM_DOFS};
use skillmimic_core::math::Quat;

use crate::clip::Clip;

/// Number of key bodies.
pub const NUM_KEY: usize = KEY_BODIES.len();

/// Derived per-frame reference arrays of one clip (frame-major).
#[derive(Clone, Debug, PartialEq)]
pub struct ClipReference {
    pub num_frames: usize,
    /// `(T, 3)` root exp map (rad).
    pub root_rotvec: Vec<f32>,
    /// `(T, 3)` root linear velocity, world.
    pub root_linvel: Vec<f32>,
    /// `(T, 3)` root angular velocity, root frame.
    pub root_angvel_local: Vec<f32>,
    /// `(T, 156)` joint velocities.
    pub dof_vel: Vec<f32>,
    /// `(T, 17, 3)` key-body positions (from the stored body positions).
    pub key_pos: Vec<f32>,
    /// `(T, 17, 3)` key-body velocities.
    pub key_vel: Vec<f32>,
    /// `(T, 3)` ball linear velocity.
    pub ball_linvel: Vec<f32>,
    /// `(T, 3)` ball angular velocity, ball frame.
    pub ball_angvel_local: Vec<f32>,
}

fn backward_diff(x: &[f32], width: usize, fps: f64) -> Vec<f32> {
    let mut out = vec![0.0f32; x.len()];
    for t in 1..x.len() / width {
        for k in 0..width {
            out[t * width + k] =
                ((x[t * width + k] as f64 - x[(t - 1) * width + k] as f64) * fps) as f32;
        }
    }
    out
}

fn rot_velocity(q: &[f32], fps: f64) -> Vec<f32> {
    let t_len = q.len() / 4;
    let quat = |t: usize| Quat::from_wxyz(std::array::from_fn(|k| q[4 * t + k] as f64));
    let mut out = vec![0.0f32; 3 * t_len];
    for t in 1..t_len {
        let w = quat(t - 1).conj().mul(quat(t)).to_rotvec();
        for k in 0..3 {
            out[3 * t + k] = (w[k] * fps) as f32;
        }
    }
    out
}

impl ClipReference {
    /// Derive the reference arrays of `clip`.
    pub fn new(clip: &Clip) -> Self {
        let t_len = clip.num_frames;
        let fps = clip.fps;
        let mut root_rotvec = Vec::with_capacity(3 * t_len);
        let mut key_pos = Vec::with_capacity(3 * NUM_KEY * t_len);
        for t in 0..t_len {
            root_rotvec.extend(clip.root_quat_at(t).to_rotvec().map(|x| x as f32));
            for &b in &KEY_BODIES {
                let i = (t * NUM_BODIES + b) * 3;
                key_pos.extend_from_slice(&clip.body_pos[i..i + 3]);
            }
        }
        Self {
            num_frames: t_len,
            root_rotvec,
            root_linvel: backward_diff(&clip.root_pos, 3, fps),
            root_angvel_local: rot_velocity(&clip.root_rot, fps),
            dof_vel: backward_diff(&clip.dof_rot, NUM_DOFS, fps),
            key_vel: backward_diff(&key_pos, 3 * NUM_KEY, fps),
            key_pos,
            ball_linvel: backward_diff(&clip.ball_pos, 3, fps),
            ball_angvel_local: rot_velocity(&clip.ball_rot, fps),
        }
    }
}

/// Read 3 floats at `[3 t ..]` as f64.
#[inline]
pub fn vec3_at(a: &[f32], t: usize) -> [f64; 3] {
    [a[3 * t] as f64, a[3 * t + 1] as f64, a[3 * t + 2] as f64]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::PT_WIDTH;

    #[test]
    fn differences_and_body_frame_angular_velocity_by_hand() {
        // 3 frames: root moves +0.1 m in x per frame, turns 0.02 rad about world z per frame
        let mut rows = vec![0.0f32; 3 * PT_WIDTH];
        for f in 0..3 {
            let r = &mut rows[f * PT_WIDTH..(f + 1) * PT_WIDTH];
            r[0] = 0.1 * f as f32;
            r[5] = 0.02 * f as f32; // exp map about z
            r[9] = 0.5 + 0.01 * f as f32; // first dof
            r[324] = 1.0;
            r[326] = 2.0 - 0.05 * f as f32;
            // Head (body 14) stored position
            r[165 + 3 * 14 + 1] = 0.3 * f as f32;
        }
        let clip = Clip::from_rows("t".into(), "test".into(), 1, 60.0, 3, &rows);
        let r = ClipReference::new(&clip);
        assert_eq!(&r.root_linvel[..3], &[0.0, 0.0, 0.0]);
        assert!((r.root_linvel[3] - 6.0).abs() < 1e-5);
        // rotation about z by 0.02 rad per frame -> 1.2 rad/s about local z (z axis unchanged)
        assert!((r.root_angvel_local[5] - 1.2).abs() < 1e-4, "{:?}", &r.root_angvel_local[3..6]);
        assert!((r.dof_vel[NUM_DOFS] - 0.6).abs() < 1e-4);
        assert!((r.ball_linvel[5] + 3.0).abs() < 1e-4);
        // key body 0 is the head
        assert!((r.key_pos[3 * NUM_KEY + 1] - 0.3).abs() < 1e-6);
        assert!((r.key_vel[3 * NUM_KEY + 1] - 18.0).abs() < 1e-4);
        assert!((r.root_rotvec[8] - 0.04).abs() < 1e-6);
    }
}
