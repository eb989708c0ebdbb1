//! Clips of the TokenHSI character ([`skillmimic_core::hsi_character`]) and their file format
//! (`.safetensors`, version 1):
//!
//! | tensor | dtype | shape | content |
//! |---|---|---|---|
//! | `root_pos` | F32 | (T, 3) | pelvis position, world, m, Z-up |
//! | `root_rot` | F32 | (T, 4) | pelvis orientation **(w, x, y, z)**, unit norm |
//! | `dof_pos` | F32 | (T, 32) | joint coordinates in action order: rotation vectors (rad) of the 3-DoF joints relative to the parent, hinge angles of the elbows |
//! | `body_pos` | F32 | (T, 15, 3) | world positions of the 15 body frames, m |
//!
//! Metadata: `format = "tokenhsi-clip"`, `format_version = "1"`, `fps` (> 0), `name`, `source`.
//! Bring your own motions (AMASS, SAMP, OMOMO retargets) by filling these arrays for the
//! character's 15 bodies; `skillmimic retarget` writes them from SkillMimic-skeleton clips.

use std::collections::BTreeMap;
use std::path::Path;

use skillmimic_core::hsi_character::{BODIES, JointSpec, NUM_BODIES, NUM_DOFS};
use skillmimic_core::math::{Quat, add};
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, write_atomic};

use crate::error::ClipError;

/// Value of the `format` metadata field.
pub const HSI_FORMAT_NAME: &str = "tokenhsi-clip";

/// A clip of the TokenHSI character (arrays float32, frame-major).
#[derive(Clone, Debug, PartialEq)]
pub struct HsiClip {
    pub name: String,
    pub source: String,
    pub fps: f64,
    pub num_frames: usize,
    /// `(T, 3)`
    pub root_pos: Vec<f32>,
    /// `(T, 4)` (w, x, y, z)
    pub root_rot: Vec<f32>,
    /// `(T, 32)`
    pub dof_pos: Vec<f32>,
    /// `(T, 15, 3)`
    pub body_pos: Vec<f32>,
}

/// World positions and orientations of the 15 bodies for a root pose and 32 joint coordinates.
pub fn hsi_forward_kinematics(
    root_pos: [f64; 3],
    root_quat: Quat,
    dof: &[f64],
) -> ([[f64; 3]; NUM_BODIES], [Quat; NUM_BODIES]) {
    let mut pos = [[0.0; 3]; NUM_BODIES];
    let mut rot = [root_quat; NUM_BODIES];
    pos[0] = root_pos;
    let mut k = 0;
    for b in 1..NUM_BODIES {
        let p = BODIES[b].parent.expect("non-root bodies have a parent");
        let local = match BODIES[b].joint {
            JointSpec::Ball { .. } => Quat::from_rotvec([dof[k], dof[k + 1], dof[k + 2]]),
            JointSpec::HingeY { .. } => Quat::from_rotvec([0.0, dof[k], 0.0]),
            _ => Quat::IDENTITY,
        };
        k += BODIES[b].joint.dofs();
        pos[b] = add(pos[p], rot[p].rotate(BODIES[b].offset));
        rot[b] = rot[p].mul(local);
    }
    (pos, rot)
}

impl HsiClip {
    /// Root position at frame `t`.
    pub fn root_pos_at(&self, t: usize) -> [f64; 3] {
        let r = &self.root_pos[3 * t..3 * t + 3];
        [r[0] as f64, r[1] as f64, r[2] as f64]
    }
    /// Root orientation at frame `t`.
    pub fn root_quat_at(&self, t: usize) -> Quat {
        let r = &self.root_rot[4 * t..4 * t + 4];
        Quat::from_wxyz([r[0] as f64, r[1] as f64, r[2] as f64, r[3] as f64])
    }
    /// Joint coordinates at frame `t`.
    pub fn dof_at(&self, t: usize) -> &[f32] {
        &self.dof_pos[NUM_DOFS * t..NUM_DOFS * (t + 1)]
    }

    /// Save (atomic write).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let t = self.num_frames;
        let mut meta = BTreeMap::new();
        meta.insert("format".into(), HSI_FORMAT_NAME.into());
        meta.insert("format_version".into(), "1".into());
        meta.insert("fps".into(), self.fps.to_string());
        meta.insert("name".into(), self.name.clone());
        meta.insert("source".into(), self.source.clone());
        let tensors = [
            OwnedTensor::f32("root_pos", &[t, 3], &self.root_pos),
            OwnedTensor::f32("root_rot", &[t, 4], &self.root_rot),
            OwnedTensor::f32("dof_pos", &[t, NUM_DOFS], &self.dof_pos),
            OwnedTensor::f32("body_pos", &[t, NUM_BODIES, 3], &self.body_pos),
        ];
        write_atomic(path, &tensors, &meta)
    }

    /// Load and validate a clip file (errors name the file and the field).
    pub fn load(path: &Path) -> Result<Self, ClipError> {
        let bad = |detail: String| ClipError::Format { path: path.to_path_buf(), detail };
        let f = TensorFile::open(path).map_err(|e| bad(e.to_string()))?;
        let meta = f.metadata();
        if meta.get("format").map(String::as_str) != Some(HSI_FORMAT_NAME) {
            return Err(bad(format!(
                "metadata 'format' is {:?}, expected \"{HSI_FORMAT_NAME}\"",
                meta.get("format")
            )));
        }
        let fps: f64 = meta
            .get("fps")
            .and_then(|s| s.parse().ok())
            .filter(|v: &f64| v.is_finite() && *v > 0.0)
            .ok_or_else(|| bad("metadata 'fps' must be a positive number".into()))?;
        let read = |name: &str, tail: &[usize]| -> Result<(usize, Vec<f32>), ClipError> {
            let spec: Vec<Option<usize>> =
                std::iter::once(None).chain(tail.iter().map(|&d| Some(d))).collect();
            let (shape, data) = f.f32(name, &spec).map_err(|e| bad(e.to_string()))?;
            if let Some(k) = data.iter().position(|x| !x.is_finite()) {
                return Err(bad(format!(
                    "tensor '{name}' holds a non-finite value at flat index {k}"
                )));
            }
            Ok((shape[0], data))
        };
        let (t, root_pos) = read("root_pos", &[3])?;
        let (t2, root_rot) = read("root_rot", &[4])?;
        let (t3, dof_pos) = read("dof_pos", &[NUM_DOFS])?;
        let (t4, body_pos) = read("body_pos", &[NUM_BODIES, 3])?;
        if t < 2 || [t2, t3, t4].iter().any(|&x| x != t) {
            return Err(bad(format!(
                "tensors disagree on the frame count or hold fewer than 2 frames ({t}, {t2}, {t3}, {t4})"
            )));
        }
        let name = meta.get("name").cloned().unwrap_or_else(|| {
            path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
        });
        Ok(Self {
            name,
            source: meta.get("source").cloned().unwrap_or_default(),
            fps,
            num_frames: t,
            root_pos,
            root_rot,
            dof_pos,
            body_pos,
        })
    }
}
