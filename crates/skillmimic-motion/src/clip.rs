//! A motion clip in the project's representation, and its decoding from BallPlay-M `.pt` files.
//!
//! The BallPlay-M column layout (one row per frame, 60 fps) is documented in [`crate::layout`].

use std::path::Path;

use skillmimic_core::characters::skillmimic::{NUM_BODIES, NUM_DOFS};
use skillmimic_core::math::Quat;

use crate::error::ClipError;

// The layout items keep their historical paths `clip::PT_WIDTH`, `clip::BALLPLAY_FPS` and
// `clip::pt_column_field`.
pub use crate::layout::{BALLPLAY_FPS, PT_WIDTH, pt_column_field};

/// Width of the one-hot skill condition; labels must be below it.
pub const SKILL_WIDTH: usize = 64;

/// A motion clip. Arrays are float32, frame-major; frames and units as in the project format:
/// positions in metres in the Z-up world frame, quaternions **(w, x, y, z)**, joint rotations as
/// exp maps (rad) of each body relative to its parent in skeleton order.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    /// Clip name (file stem).
    pub name: String,
    /// Where the clip came from (file path or generator description).
    pub source: String,
    /// Skill label (0 … 63).
    pub skill: u32,
    /// Frames per second.
    pub fps: f64,
    /// Number of frames T.
    pub num_frames: usize,
    /// `(T, 3)` root position.
    pub root_pos: Vec<f32>,
    /// `(T, 4)` root orientation (w, x, y, z), sign-continuous over time.
    pub root_rot: Vec<f32>,
    /// `(T, 52, 3)` joint rotations (exp maps).
    pub dof_rot: Vec<f32>,
    /// `(T, 53, 3)` body positions.
    pub body_pos: Vec<f32>,
    /// `(T, 3)` ball centre.
    pub ball_pos: Vec<f32>,
    /// `(T, 4)` ball orientation (w, x, y, z).
    pub ball_rot: Vec<f32>,
    /// `(T,)` hand–ball contact label, 0 or 1.
    pub contact: Vec<f32>,
}

/// Names of the BallPlay-M skill labels (the folder each label's clips come from in the released
/// data; reference-facts §1.7), in label order. Labels not listed have no known name.
pub const SKILL_NAMES: &[(u32, &str)] = &[
    (0, "getup"),
    (1, "pickup"),
    (2, "rebound"),
    (3, "catch"),
    (4, "pass"),
    (5, "shot_style1"),
    (6, "shot_style2"),
    (7, "shot_style3"),
    (9, "shot"),
    (10, "run_no_object"),
    (11, "lrun"),
    (12, "rrun"),
    (13, "run"),
    (23, "turnhook"),
    (31, "layup"),
    (34, "turnlayup"),
    (40, "rturn2lhand"),
    (41, "back"),
    (42, "turn"),
    (43, "legturn"),
    (44, "lleg_style1"),
    (45, "lleg_style2"),
];

/// The name of skill label `label`, if it has one ([`SKILL_NAMES`]).
pub fn skill_name(label: u32) -> Option<&'static str> {
    SKILL_NAMES.iter().find(|(l, _)| *l == label).map(|(_, n)| *n)
}

/// Skill label from a clip file name: the integer of its first three characters
/// (`013_018pickle_run_3.pt` → 13).
pub fn skill_label_from_name(path: &Path) -> Result<u32, ClipError> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix: String = name.chars().take(3).collect();
    if prefix.len() != 3 || !prefix.chars().all(|c| c.is_ascii_digit()) {
        return Err(ClipError::Label { path: path.to_path_buf(), name });
    }
    let label: u32 = prefix
        .parse()
        .map_err(|_| ClipError::Label { path: path.to_path_buf(), name: name.clone() })?;
    if label as usize >= SKILL_WIDTH {
        return Err(ClipError::LabelRange { path: path.to_path_buf(), label, width: SKILL_WIDTH });
    }
    Ok(label)
}

/// Convert a rotation vector to a float32 quaternion (w, x, y, z) via f64.
fn rotvec_to_wxyz(v: [f32; 3]) -> [f32; 4] {
    Quat::from_rotvec([v[0] as f64, v[1] as f64, v[2] as f64]).to_wxyz().map(|x| x as f32)
}

impl Clip {
    /// Decode `t` rows of the 337-column layout (values must be finite). Nothing is validated or
    /// rounded: the contact label is column 336 as stored; see `crate::validate::validate_clip`.
    pub fn from_rows(
        name: String,
        source: String,
        skill: u32,
        fps: f64,
        t: usize,
        rows: &[f32],
    ) -> Clip {
        assert_eq!(rows.len(), t * PT_WIDTH);
        let mut clip = Clip {
            name,
            source,
            skill,
            fps,
            num_frames: t,
            root_pos: Vec::with_capacity(3 * t),
            root_rot: Vec::with_capacity(4 * t),
            dof_rot: Vec::with_capacity(NUM_DOFS * t),
            body_pos: Vec::with_capacity(3 * NUM_BODIES * t),
            ball_pos: Vec::with_capacity(3 * t),
            ball_rot: Vec::with_capacity(4 * t),
            contact: Vec::with_capacity(t),
        };
        let mut prev: Option<[f32; 4]> = None;
        for r in rows.chunks_exact(PT_WIDTH) {
            clip.root_pos.extend_from_slice(&r[0..3]);
            let mut q = rotvec_to_wxyz([r[3], r[4], r[5]]);
            // sign continuity: q and −q are the same rotation; keep neighbours in one hemisphere
            if let Some(p) = prev
                && p.iter().zip(&q).map(|(a, b)| a * b).sum::<f32>() < 0.0
            {
                q = q.map(|x| -x);
            }
            prev = Some(q);
            clip.root_rot.extend_from_slice(&q);
            clip.dof_rot.extend_from_slice(&r[9..165]);
            clip.body_pos.extend_from_slice(&r[165..324]);
            clip.ball_pos.extend_from_slice(&r[324..327]);
            // the loaders negate the stored ball exp map
            clip.ball_rot.extend_from_slice(&rotvec_to_wxyz([-r[327], -r[328], -r[329]]));
            clip.contact.push(r[336]);
        }
        clip
    }

    /// Root position of frame `t` (f64).
    pub fn root_pos_at(&self, t: usize) -> [f64; 3] {
        std::array::from_fn(|k| self.root_pos[3 * t + k] as f64)
    }
    /// Root orientation of frame `t`.
    pub fn root_quat_at(&self, t: usize) -> Quat {
        Quat::from_wxyz(std::array::from_fn(|k| self.root_rot[4 * t + k] as f64))
    }
    /// The 156 joint exp-map components of frame `t`.
    pub fn dof_at(&self, t: usize) -> &[f32] {
        &self.dof_rot[NUM_DOFS * t..NUM_DOFS * (t + 1)]
    }
    /// Stored world position of body `b` at frame `t` (f64).
    pub fn body_pos_at(&self, t: usize, b: usize) -> [f64; 3] {
        std::array::from_fn(|k| self.body_pos[(t * NUM_BODIES + b) * 3 + k] as f64)
    }
    /// Ball centre at frame `t` (f64).
    pub fn ball_pos_at(&self, t: usize) -> [f64; 3] {
        std::array::from_fn(|k| self.ball_pos[3 * t + k] as f64)
    }
    /// Ball orientation at frame `t`.
    pub fn ball_quat_at(&self, t: usize) -> Quat {
        Quat::from_wxyz(std::array::from_fn(|k| self.ball_rot[4 * t + k] as f64))
    }
    /// Duration in seconds.
    pub fn duration(&self) -> f64 {
        self.num_frames as f64 / self.fps
    }
}
