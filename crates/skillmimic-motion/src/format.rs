//! The project's clip file format (`.safetensors`), version 1, and the clip loaders
//! (`Clip::from_pt`, `Clip::load`, `Clip::load_any`), each running the one validation of
//! [`crate::validate`].
//!
//! | tensor | dtype | shape | content |
//! |---|---|---|---|
//! | `root_pos` | F32 | (T, 3) | root (Pelvis) position, world, m, Z-up |
//! | `root_rot` | F32 | (T, 4) | root orientation, quaternion **(w, x, y, z)** (MuJoCo order), unit norm |
//! | `dof_rot` | F32 | (T, 52, 3) | exp map (axis·angle, rad) of each body relative to its parent, skeleton order |
//! | `body_pos` | F32 | (T, 53, 3) | world positions of the 53 bodies, m (the reward targets of key bodies) |
//! | `ball_pos` | F32 | (T, 3) | ball centre, world, m |
//! | `ball_rot` | F32 | (T, 4) | ball orientation (w, x, y, z) |
//! | `contact` | F32 | (T,) | hand–ball contact label, 0 or 1 |
//!
//! Metadata (strings): `format = "skillmimic-clip"`, `format_version = "1"`, `fps` (frames per
//! second, 1 … 1000), `skill` (label 0…63), `name`, `source`.
//!
//! Loading checks every rule of [`crate::validate`] (at least 4 frames, finite and plausible
//! values, unit quaternions, contact exactly 0 or 1).
//!
//! Body order, skeleton frames and bone offsets are those of `skillmimic_core::characters::skillmimic`; bring
//! your own clips by filling these arrays for the same skeleton.

use std::collections::BTreeMap;
use std::path::Path;

use skillmimic_core::characters::skillmimic::{NUM_BODIES, NUM_JOINTS};
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, TensorFileError, write_atomic};

use crate::clip::{BALLPLAY_FPS, Clip, PT_WIDTH, SKILL_WIDTH, skill_label_from_name};
use crate::error::ClipError;
use crate::pt::read_pt_matrix;
use crate::validate::{Naming, check_pt_rows, validate_clip};

/// Value of the `format` metadata field.
pub const FORMAT_NAME: &str = "skillmimic-clip";
/// Current format version.
pub const FORMAT_VERSION: u32 = 1;

fn tf_err(path: &Path, e: TensorFileError) -> ClipError {
    match e {
        TensorFileError::Io { error, .. } => ClipError::Io { path: path.to_path_buf(), error },
        other => ClipError::Format {
            path: path.to_path_buf(),
            detail: strip_path(path, &other.to_string()),
        },
    }
}

fn strip_path(path: &Path, msg: &str) -> String {
    msg.strip_prefix(&format!("{}: ", path.display())).unwrap_or(msg).to_string()
}

impl Clip {
    /// Save in the project format (atomic write).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let t = self.num_frames;
        let mut meta = BTreeMap::new();
        meta.insert("format".into(), FORMAT_NAME.into());
        meta.insert("format_version".into(), FORMAT_VERSION.to_string());
        meta.insert("fps".into(), self.fps.to_string());
        meta.insert("skill".into(), self.skill.to_string());
        meta.insert("name".into(), self.name.clone());
        meta.insert("source".into(), self.source.clone());
        let tensors = [
            OwnedTensor::f32("root_pos", &[t, 3], &self.root_pos),
            OwnedTensor::f32("root_rot", &[t, 4], &self.root_rot),
            OwnedTensor::f32("dof_rot", &[t, NUM_JOINTS, 3], &self.dof_rot),
            OwnedTensor::f32("body_pos", &[t, NUM_BODIES, 3], &self.body_pos),
            OwnedTensor::f32("ball_pos", &[t, 3], &self.ball_pos),
            OwnedTensor::f32("ball_rot", &[t, 4], &self.ball_rot),
            OwnedTensor::f32("contact", &[t], &self.contact),
        ];
        write_atomic(path, &tensors, &meta)
    }

    /// Load a BallPlay-M `.pt` clip (label from the file name, 60 fps), validated by
    /// [`crate::validate`] (errors name `.pt` columns).
    pub fn from_pt(path: &Path) -> Result<Clip, ClipError> {
        let skill = skill_label_from_name(path)?;
        let m = read_pt_matrix(path)?;
        if m.cols != PT_WIDTH || m.rows == 0 {
            return Err(ClipError::Shape {
                path: path.to_path_buf(),
                shape: vec![m.rows, m.cols],
                expected_width: PT_WIDTH,
            });
        }
        check_pt_rows(&m.data, path)?;
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let clip =
            Clip::from_rows(name, path.display().to_string(), skill, BALLPLAY_FPS, m.rows, &m.data);
        validate_clip(&clip, path, Naming::PtColumns)?;
        Ok(clip)
    }

    /// Load a clip in the project format, validating every field ([`crate::validate`]; errors name
    /// `path`, the file loaded, never the `source` metadata).
    pub fn load(path: &Path) -> Result<Clip, ClipError> {
        let f = TensorFile::open(path).map_err(|e| tf_err(path, e))?;
        let fmt = f.meta("format").map_err(|e| tf_err(path, e))?;
        if fmt != FORMAT_NAME {
            return Err(ClipError::Format {
                path: path.into(),
                detail: format!("metadata format is '{fmt}', expected '{FORMAT_NAME}'"),
            });
        }
        let version: u32 =
            f.meta_parse("format_version", "an integer").map_err(|e| tf_err(path, e))?;
        if version > FORMAT_VERSION {
            return Err(ClipError::Format {
                path: path.into(),
                detail: format!(
                    "format_version {version} is newer than this build supports ({FORMAT_VERSION})"
                ),
            });
        }
        let fps: f64 =
            f.meta_parse("fps", "a number of frames per second").map_err(|e| tf_err(path, e))?;
        let skill: u32 = f.meta_parse("skill", "an integer 0..63").map_err(|e| tf_err(path, e))?;
        if skill as usize >= SKILL_WIDTH {
            return Err(ClipError::LabelRange {
                path: path.into(),
                label: skill,
                width: SKILL_WIDTH,
            });
        }
        let (shape, root_pos) = f.f32("root_pos", &[None, Some(3)]).map_err(|e| tf_err(path, e))?;
        let t = shape[0];
        let get = |name: &str, dims: &[usize]| {
            let mut want = vec![Some(t)];
            want.extend(dims.iter().map(|&d| Some(d)));
            f.f32(name, &want).map(|(_, v)| v).map_err(|e| tf_err(path, e))
        };
        let clip = Clip {
            name: f.metadata().get("name").cloned().unwrap_or_default(),
            source: f.metadata().get("source").cloned().unwrap_or_default(),
            skill,
            fps,
            num_frames: t,
            root_pos,
            root_rot: get("root_rot", &[4])?,
            dof_rot: get("dof_rot", &[NUM_JOINTS, 3])?,
            body_pos: get("body_pos", &[NUM_BODIES, 3])?,
            ball_pos: get("ball_pos", &[3])?,
            ball_rot: get("ball_rot", &[4])?,
            contact: get("contact", &[])?,
        };
        validate_clip(&clip, path, Naming::Project)?;
        Ok(clip)
    }

    /// Load a clip from either format, chosen by extension (`.pt` or `.safetensors`).
    pub fn load_any(path: &Path) -> Result<Clip, ClipError> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("pt") => Clip::from_pt(path),
            Some("safetensors") => Clip::load(path),
            _ => Err(ClipError::Format {
                path: path.into(),
                detail: "unknown clip extension, expected .pt (BallPlay-M) or .safetensors \
                    (skillmimic-clip)"
                    .into(),
            }),
        }
    }
}
