//! A retargeted body motion ([`crate::retarget_bvh::Motion`]) as a clip of the project format: the
//! 53 body positions by forward kinematics, a ball track, the hand–ball contact label, the skill
//! label, and the diagnostics a user checks before training (issue 23).
//!
//! Ball track ([`Ball`]), world frame, Z-up, metres:
//! * `None`: a ball-free skill; the ball rests on the floor 3 m in front of the first frame's root
//!   (its track is never imitated: skills 0 and 10 ignore the ball);
//! * `Points`: one position per *source* frame, in the source's axes and units (a CSV of ball
//!   positions, or a marker joint of the BVH), transformed exactly like the root (up axis, yaw,
//!   scale, Y-up → Z-up, ground shift) and resampled linearly.
//!
//! The ball's rotation is unknown and kept at identity. Contact label: 1 where the ball's centre is
//! within radius + 5 cm of a wrist or fingertip body, else 0.

use std::path::Path;

use serde::Serialize;
use skillmimic_core::characters::skillmimic::{
    self as skeleton, FINGERTIPS, L_WRIST, NUM_BODIES, R_WRIST,
};
use skillmimic_core::math::{Quat, Vec3, add, norm, scale, sub};

use crate::clip::Clip;
use crate::error::ClipError;
use crate::retarget_bvh::{Motion, body_positions, joint_speeds, lowest_sole_of};

/// Ball radius of the scene (m).
pub const BALL_RADIUS: f64 = 0.12;

/// Where the ball track comes from.
#[derive(Clone, Debug)]
pub enum Ball {
    None,
    /// Positions per source frame in the source's axes and units.
    Points(Vec<Vec3>),
}

/// Diagnostics of one retargeted clip (written as JSON next to it).
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub name: String,
    pub frames: usize,
    pub fps: f64,
    /// Source units → metres, including the height (leg-length) ratio.
    pub scale: f64,
    /// Height added by the ground alignment (m).
    pub ground_shift_m: f64,
    /// Deepest sole point below the floor over all frames (m, ≥ 0).
    pub foot_penetration_max_m: f64,
    /// Frames whose lowest sole is more than 1 cm below the floor.
    pub frames_penetrating: usize,
    /// Mean horizontal speed of the lowest foot while its sole is within 2 cm of the floor (m/s).
    pub foot_sliding_mean_m_s: f64,
    /// Fastest joint rotation between two frames (rad/s) and where.
    pub max_joint_speed_rad_s: f64,
    pub max_joint_speed_frame: usize,
    pub max_joint_speed_body: String,
    /// Frames with some joint turning faster than 20 rad/s (a retargeting or capture glitch).
    pub frames_with_speed_spike: usize,
    /// Frames labelled as hand–ball contact.
    pub contact_frames: usize,
    /// With the light IK: the distances (m) left between the ankles / wrists and their targets
    /// over the source frames (targets beyond the straight limb; zeros without IK).
    pub ik: crate::limb_ik::IkResiduals,
    /// The same checks frame by frame (output frames), for plotting or finding a glitch.
    pub per_frame: PerFrame,
}

/// Per-frame diagnostics of a retargeted clip (one value per output frame). The humanoid's joints
/// have no limits (every axis spans ±180°), so joint speed is the check on joints.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PerFrame {
    /// Height of the lowest sole point above the floor (m; negative: penetration).
    pub lowest_sole_m: Vec<f64>,
    /// Horizontal speed of the lowest foot body while its sole is within 2 cm of the floor (m/s;
    /// 0 in the air and at frame 0): foot sliding.
    pub foot_sliding_m_s: Vec<f64>,
    /// Fastest joint rotation from the previous frame (rad/s; frame 0: 0).
    pub max_joint_speed_rad_s: Vec<f64>,
}

/// Resample per-source-frame points to the motion's frames.
fn resample(points: &[Vec3], src_dt: f64, m: &Motion) -> Vec<Vec3> {
    (0..m.frames)
        .map(|k| {
            let x = (k as f64 / m.fps / src_dt).min((points.len() - 1) as f64);
            let (i, t) = (x.floor() as usize, x - x.floor());
            let j = (i + 1).min(points.len() - 1);
            add(scale(points[i], 1.0 - t), scale(points[j], t))
        })
        .collect()
}

/// Build the clip and its report (`src_dt`: the source's frame time; `path` names the source in
/// errors). The clip passes the one clip validation every loader runs.
pub fn to_clip(
    m: &Motion,
    name: &str,
    source: &str,
    skill: u32,
    ball: &Ball,
    src_dt: f64,
    path: &Path,
) -> Result<(Clip, Report), ClipError> {
    let t = m.frames;
    let mut clip = Clip {
        name: name.into(),
        source: source.into(),
        skill,
        fps: m.fps,
        num_frames: t,
        root_pos: Vec::with_capacity(3 * t),
        root_rot: Vec::with_capacity(4 * t),
        dof_rot: Vec::with_capacity(156 * t),
        body_pos: Vec::with_capacity(3 * NUM_BODIES * t),
        ball_pos: Vec::with_capacity(3 * t),
        ball_rot: Vec::with_capacity(4 * t),
        contact: Vec::with_capacity(t),
    };
    let balls: Vec<Vec3> = match ball {
        Ball::None => {
            let fwd = m.root_rot[0].rotate([0.0, 0.0, 1.0]); // the skeleton's facing (+z) in the world
            let h = [fwd[0], fwd[1], 0.0];
            let h = if norm(h) > 1e-6 { scale(h, 3.0 / norm(h)) } else { [3.0, 0.0, 0.0] };
            let p = add([m.root_pos[0][0], m.root_pos[0][1], BALL_RADIUS], h);
            vec![p; t]
        }
        Ball::Points(p) => {
            if p.is_empty() {
                return Err(ClipError::Format {
                    path: path.to_path_buf(),
                    detail: "ball track: no positions".into(),
                });
            }
            resample(&p.iter().map(|&x| m.source_to_world(x)).collect::<Vec<_>>(), src_dt, m)
                .into_iter()
                .map(|mut x| {
                    x[2] += m.ground_shift;
                    x
                })
                .collect()
        }
    };
    let hands: Vec<usize> = [L_WRIST, R_WRIST].into_iter().chain(FINGERTIPS).collect();
    let mut rep = Report {
        name: name.into(),
        frames: t,
        fps: m.fps,
        scale: m.scale,
        ground_shift_m: m.ground_shift,
        foot_penetration_max_m: 0.0,
        frames_penetrating: 0,
        foot_sliding_mean_m_s: 0.0,
        max_joint_speed_rad_s: 0.0,
        max_joint_speed_frame: 0,
        max_joint_speed_body: String::new(),
        frames_with_speed_spike: 0,
        contact_frames: 0,
        ik: m.ik,
        per_frame: PerFrame::default(),
    };
    let (mut slide_sum, mut slide_n) = (0.0, 0usize);
    let mut prev: Option<[Vec3; NUM_BODIES]> = None;
    for (k, ball_k) in balls.iter().enumerate() {
        let p = body_positions(m, k);
        clip.root_pos.extend(m.root_pos[k].map(|x| x as f32));
        clip.root_rot.extend(m.root_rot[k].to_wxyz().map(|x| x as f32));
        clip.dof_rot.extend(m.dof_rot[k].iter().flat_map(|v| v.map(|x| x as f32)));
        clip.body_pos.extend(p.iter().flat_map(|v| v.map(|x| x as f32)));
        clip.ball_pos.extend(ball_k.map(|x| x as f32));
        clip.ball_rot.extend(Quat::IDENTITY.to_wxyz().map(|x| x as f32));
        let touching = !matches!(ball, Ball::None)
            && hands.iter().any(|&h| norm(sub(p[h], *ball_k)) < BALL_RADIUS + 0.05);
        clip.contact.push(touching as u8 as f32);
        rep.contact_frames += touching as usize;
        let (sole, foot) = lowest_sole_of(&p);
        rep.foot_penetration_max_m = rep.foot_penetration_max_m.max(-sole);
        rep.frames_penetrating += (sole < -0.01) as usize;
        rep.per_frame.lowest_sole_m.push(sole);
        let mut slide = 0.0;
        if let Some(q) = prev {
            // the lowest foot body, if its sole is on the floor
            if sole < 0.02 {
                slide = norm([p[foot][0] - q[foot][0], p[foot][1] - q[foot][1], 0.0]) * m.fps;
                slide_sum += slide;
                slide_n += 1;
            }
        }
        rep.per_frame.foot_sliding_m_s.push(slide);
        prev = Some(p);
    }
    rep.foot_sliding_mean_m_s = if slide_n > 0 { slide_sum / slide_n as f64 } else { 0.0 };
    let ((w, k, j), spikes, per_frame) = joint_speeds(m, 20.0);
    rep.per_frame.max_joint_speed_rad_s = per_frame;
    rep.max_joint_speed_rad_s = w;
    rep.max_joint_speed_frame = k;
    rep.max_joint_speed_body = skeleton::BODIES[j + 1].name.into();
    rep.frames_with_speed_spike = spikes;
    crate::validate::validate_clip(&clip, path, crate::validate::Naming::Project)?;
    Ok((clip, rep))
}
