//! Clips of any character ([`skillmimic_core::characters`]; the SkillMimic humanoid's own clips
//! with the ball are [`crate::Clip`]) and their file format (`.safetensors`, version 1):
//!
//! * `root_pos` — dtype: F32; shape: (T, 3); content: root position, world, m, Z-up
//! * `root_rot` — dtype: F32; shape: (T, 4); content: root orientation **(w, x, y, z)**, unit norm
//! * `dof_pos` — dtype: F32; shape: (T, dofs); content: the character's dof vector: rotation
//!   vectors (rad) of ball joints relative to the parent, hinge angles (three hinges x, y, z:
//!   intrinsic x-y-z angles)
//! * `body_pos` — dtype: F32; shape: (T, bodies, 3); content: world positions of the body frames, m
//!
//! Metadata: `format = "character-clip"`, `format_version = "2"`, `character` (the registry name:
//! `tokenhsi`, `smpl`, …), `fps` (> 0), `name`, `source`. Files written before the characters
//! shared one stack (`format = "tokenhsi-clip"`, no `character`) load as TokenHSI clips. Bring your
//! own motions (AMASS, SAMP, OMOMO retargets) by filling these arrays for the character's bodies;
//! `skillmimic retarget --to <character>` writes them from SkillMimic-skeleton clips.

use std::collections::BTreeMap;
use std::path::Path;

use skillmimic_core::characters::{Character, CharacterSpec, HandModel};
use skillmimic_core::math::Quat;
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, write_atomic};

use crate::error::ClipError;

/// Value of the `format` metadata field.
pub const FORMAT_NAME: &str = "character-clip";
/// The format of TokenHSI clips written before `character-clip` (read as `character = tokenhsi`).
pub const LEGACY_TOKENHSI_FORMAT: &str = "tokenhsi-clip";
/// Version written. Version 1 TokenHSI clips (and `tokenhsi-clip` files) stored each 3-DoF
/// joint as a rotation vector (the character's ball joints of that time); they load converted
/// into the three hinge angles (intrinsic x-y-z) of the character's joints since version 2.
pub const FORMAT_VERSION: u32 = 2;

/// A clip of one character (arrays float32, frame-major).
#[derive(Clone, Debug, PartialEq)]
pub struct CharacterClip {
    /// The character's registry name.
    pub character: String,
    pub name: String,
    pub source: String,
    pub fps: f64,
    pub num_frames: usize,
    /// Dofs and bodies of the character.
    pub num_dofs: usize,
    pub num_bodies: usize,
    /// `(T, 3)`
    pub root_pos: Vec<f32>,
    /// `(T, 4)` (w, x, y, z)
    pub root_rot: Vec<f32>,
    /// `(T, dofs)`
    pub dof_pos: Vec<f32>,
    /// `(T, bodies, 3)`
    pub body_pos: Vec<f32>,
}

impl CharacterClip {
    /// A clip of `spec` from per-frame root poses and dof vectors; `body_pos` from the
    /// character's forward kinematics.
    pub fn from_frames(
        spec: &CharacterSpec,
        name: &str,
        source: &str,
        fps: f64,
        frames: &[([f64; 3], Quat, Vec<f64>)],
    ) -> Self {
        let (nd, nb) = (spec.num_dofs, spec.bodies.len());
        let mut c = Self {
            character: spec.name.to_string(),
            name: name.to_string(),
            source: source.to_string(),
            fps,
            num_frames: frames.len(),
            num_dofs: nd,
            num_bodies: nb,
            root_pos: Vec::with_capacity(3 * frames.len()),
            root_rot: Vec::with_capacity(4 * frames.len()),
            dof_pos: Vec::with_capacity(nd * frames.len()),
            body_pos: Vec::with_capacity(3 * nb * frames.len()),
        };
        for (p, q, dof) in frames {
            c.root_pos.extend(p.iter().map(|&x| x as f32));
            c.root_rot.extend(q.to_wxyz().iter().map(|&x| x as f32));
            c.dof_pos.extend(dof.iter().map(|&x| x as f32));
            let (pos, _) = spec.forward_kinematics(*p, *q, dof);
            c.body_pos.extend(pos.iter().flatten().map(|&x| x as f32));
        }
        c
    }

    /// The clip played at `fps` frames per second: frame k is the pose at time k / fps s (the
    /// last frame at or before the clip's end), interpolated between the two nearest frames —
    /// root position and joint coordinates linearly, root orientation by slerp; body positions
    /// from the character's forward kinematics. At an integer rate ratio (60 → 30 fps) every
    /// frame is an original one. The clip itself when the rates agree to 1e-9.
    pub fn resampled(&self, spec: &CharacterSpec, fps: f64) -> Self {
        if (fps - self.fps).abs() <= 1e-9 * fps || self.num_frames < 2 {
            return self.clone();
        }
        let duration = (self.num_frames - 1) as f64 / self.fps;
        let n = ((duration * fps) + 1e-9).floor() as usize + 1;
        let frames: Vec<([f64; 3], Quat, Vec<f64>)> = (0..n)
            .map(|k| {
                let at = (k as f64 * self.fps / fps).min((self.num_frames - 1) as f64);
                let i = (at.floor() as usize).min(self.num_frames - 2);
                let (a, j) = (at - i as f64, i + 1);
                let (p0, p1) = (self.root_pos_at(i), self.root_pos_at(j));
                let p = std::array::from_fn(|c| p0[c] + a * (p1[c] - p0[c]));
                let q = self.root_quat_at(i).slerp(self.root_quat_at(j), a);
                let dof = self
                    .dof_at(i)
                    .iter()
                    .zip(self.dof_at(j))
                    .map(|(&x, &y)| x as f64 + a * (y as f64 - x as f64))
                    .collect();
                (p, q, dof)
            })
            .collect();
        Self::from_frames(spec, &self.name, &self.source, fps, &frames)
    }

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
    /// The dof vector at frame `t`.
    pub fn dof_at(&self, t: usize) -> &[f32] {
        &self.dof_pos[self.num_dofs * t..self.num_dofs * (t + 1)]
    }
    /// World position of body `b` at frame `t`.
    pub fn body_pos_at(&self, t: usize, b: usize) -> [f64; 3] {
        let r = &self.body_pos[3 * (t * self.num_bodies + b)..3 * (t * self.num_bodies + b) + 3];
        [r[0] as f64, r[1] as f64, r[2] as f64]
    }

    /// Save (atomic write).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let t = self.num_frames;
        let mut meta = BTreeMap::new();
        meta.insert("format".into(), FORMAT_NAME.into());
        meta.insert("format_version".into(), FORMAT_VERSION.to_string());
        meta.insert("character".into(), self.character.clone());
        meta.insert("fps".into(), self.fps.to_string());
        meta.insert("name".into(), self.name.clone());
        meta.insert("source".into(), self.source.clone());
        let tensors = [
            OwnedTensor::f32("root_pos", &[t, 3], &self.root_pos),
            OwnedTensor::f32("root_rot", &[t, 4], &self.root_rot),
            OwnedTensor::f32("dof_pos", &[t, self.num_dofs], &self.dof_pos),
            OwnedTensor::f32("body_pos", &[t, self.num_bodies, 3], &self.body_pos),
        ];
        write_atomic(path, &tensors, &meta)
    }

    /// Load and validate a clip file (errors name the file and the field): a registered
    /// character, its dof and body counts, at least two frames, finite values, unit root
    /// quaternions.
    pub fn load(path: &Path) -> Result<Self, ClipError> {
        let bad = |detail: String| ClipError::Format { path: path.to_path_buf(), detail };
        let f = TensorFile::open(path).map_err(|e| bad(e.to_string()))?;
        let meta = f.metadata();
        let version: u32 = match meta.get("format_version") {
            None => 1,
            Some(v) => v.parse().ok().filter(|&v| v >= 1).ok_or_else(|| {
                bad(format!("metadata 'format_version' is \"{v}\", expected 1 or 2"))
            })?,
        };
        if version > FORMAT_VERSION {
            return Err(bad(format!(
                "metadata 'format_version' is {version}, newer than this build supports \
                    ({FORMAT_VERSION})"
            )));
        }
        let character = match meta.get("format").map(String::as_str) {
            Some(FORMAT_NAME) => meta
                .get("character")
                .cloned()
                .ok_or_else(|| bad("metadata 'character' is missing".into()))?,
            Some(LEGACY_TOKENHSI_FORMAT) => "tokenhsi".to_string(),
            other => {
                return Err(bad(format!(
                    "metadata 'format' is {other:?}, expected \"{FORMAT_NAME}\""
                )));
            }
        };
        let spec = Character::by_name(&character, HandModel::Full)
            .ok_or_else(|| {
                bad(format!(
                    "metadata 'character' is \"{character}\", expected one of {}",
                    Character::NAMES.join(", ")
                ))
            })?
            .spec();
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
        let (nd, nb) = (spec.num_dofs, spec.bodies.len());
        let (t, root_pos) = read("root_pos", &[3])?;
        let (t2, root_rot) = read("root_rot", &[4])?;
        let (t3, mut dof_pos) = read("dof_pos", &[nd])?;
        if character == "tokenhsi" && version < 2 {
            rotation_vectors_to_hinges(&spec, &mut dof_pos);
        }
        let (t4, body_pos) = read("body_pos", &[nb, 3])?;
        if t < 2 || [t2, t3, t4].iter().any(|&x| x != t) {
            return Err(bad(format!(
                "tensors disagree on the frame count or hold fewer than 2 frames ({t}, {t2}, \
                    {t3}, {t4})"
            )));
        }
        if let Some(k) = root_rot.chunks_exact(4).position(|q| {
            let n = q.iter().map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt();
            (n - 1.0).abs() > 1e-3
        }) {
            return Err(bad(format!("tensor 'root_rot' frame {k} is not a unit quaternion")));
        }
        let name = meta.get("name").cloned().unwrap_or_else(|| {
            path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
        });
        Ok(Self {
            character,
            name,
            source: meta.get("source").cloned().unwrap_or_default(),
            fps,
            num_frames: t,
            num_dofs: nd,
            num_bodies: nb,
            root_pos,
            root_rot,
            dof_pos,
            body_pos,
        })
    }
}

/// Rewrite, frame by frame, every 3-hinge joint's three entries of `dof` from a rotation vector
/// into the hinges' intrinsic x-y-z angles (version 1 TokenHSI clips).
fn rotation_vectors_to_hinges(spec: &CharacterSpec, dof: &mut [f32]) {
    let nd = spec.num_dofs;
    for frame in dof.chunks_exact_mut(nd) {
        for body in &spec.bodies {
            if let skillmimic_core::characters::JointDef::Hinges { hinges, .. } = &body.joint
                && hinges.len() == 3
            {
                let k = body.dofs.start;
                let v = [frame[k] as f64, frame[k + 1] as f64, frame[k + 2] as f64];
                let a = skillmimic_core::characters::intrinsic_xyz(Quat::from_rotvec(v));
                for i in 0..3 {
                    frame[k + i] = a[i] as f32;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skillmimic_core::characters::tokenhsi;

    /// A TokenHSI clip of format version 1 (rotation vectors) loads as the hinge angles that give
    /// the same joint rotations; a version-2 file round-trips unchanged.
    #[test]
    fn version_1_tokenhsi_clips_load_as_hinge_angles() {
        let spec = tokenhsi::spec();
        let dir = std::env::temp_dir().join(format!("clip_v1_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut dof = vec![0.0f64; spec.num_dofs];
        dof[14..17].copy_from_slice(&[0.3, -0.8, 0.2]); // right hip as a rotation vector
        dof[17..20].copy_from_slice(&[0.02, 1.1, -0.05]); // right knee
        let frames = vec![([0.0, 0.0, 0.94], Quat::IDENTITY, dof.clone()); 2];
        let clip = CharacterClip::from_frames(&spec, "v1", "test", 30.0, &frames);
        let path = dir.join("v1.safetensors");
        clip.save(&path).unwrap();
        assert_eq!(
            CharacterClip::load(&path).unwrap().dof_pos,
            clip.dof_pos,
            "version 2 round trip"
        );
        // the same arrays written as version 1
        let t = clip.num_frames;
        let mut meta = BTreeMap::new();
        for (k, v) in [("format", FORMAT_NAME), ("format_version", "1"), ("character", "tokenhsi")]
        {
            meta.insert(k.to_string(), v.to_string());
        }
        meta.insert("fps".into(), "30".into());
        let tensors = [
            OwnedTensor::f32("root_pos", &[t, 3], &clip.root_pos),
            OwnedTensor::f32("root_rot", &[t, 4], &clip.root_rot),
            OwnedTensor::f32("dof_pos", &[t, clip.num_dofs], &clip.dof_pos),
            OwnedTensor::f32("body_pos", &[t, clip.num_bodies, 3], &clip.body_pos),
        ];
        write_atomic(&path, &tensors, &meta).unwrap();
        let loaded = CharacterClip::load(&path).unwrap();
        for b in [9usize, 10] {
            let k = spec.bodies[b].dofs.start;
            let want = Quat::from_rotvec([dof[k], dof[k + 1], dof[k + 2]]);
            let got: Vec<f64> = loaded.dof_at(1).iter().map(|&x| x as f64).collect();
            let q = spec.local_rotation(b, &got);
            let d = q.conj().mul(want).normalized().to_rotvec();
            assert!(d.iter().all(|x| x.abs() < 1e-5), "body {b}: {d:?}");
            assert!((got[k] - dof[k]).abs() > 1e-4, "converted, not copied");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Resampling keeps the clip's duration and speed: 60 → 30 fps takes every second frame
    /// exactly; 60 → 45 fps interpolates (a frame at 1/45 s lies 1/3 of the way from frame 1
    /// to frame 2 of the source: root and joints linear, the root's yaw by slerp).
    #[test]
    fn resampling_keeps_duration_and_speed() {
        let spec = tokenhsi::spec();
        let frames: Vec<_> = (0..61)
            .map(|k| {
                let t = k as f64 / 60.0;
                let mut dof = vec![0.0f64; spec.num_dofs];
                dof[0] = 0.5 * t;
                ([t, 0.0, 0.94], Quat::about_z(0.6 * t), dof)
            })
            .collect();
        let clip = CharacterClip::from_frames(&spec, "c", "test", 60.0, &frames);
        let half = clip.resampled(&spec, 30.0);
        assert_eq!((half.num_frames, half.fps), (31, 30.0));
        for k in 0..31 {
            assert_eq!(half.root_pos_at(k), clip.root_pos_at(2 * k));
            assert_eq!(half.dof_at(k), clip.dof_at(2 * k));
            let d = half.root_quat_at(k).conj().mul(clip.root_quat_at(2 * k)).angle();
            assert!(d < 1e-6, "frame {k}: {d}");
        }
        let odd = clip.resampled(&spec, 45.0);
        assert_eq!(odd.num_frames, 46, "1 s at 45 fps");
        for k in [1usize, 7, 44, 45] {
            let t = k as f64 / 45.0;
            assert!((odd.root_pos_at(k)[0] - t).abs() < 1e-6, "frame {k}");
            assert!((odd.dof_at(k)[0] as f64 - 0.5 * t).abs() < 1e-6, "frame {k}");
            let d = odd.root_quat_at(k).conj().mul(Quat::about_z(0.6 * t)).angle();
            assert!(d < 1e-6, "frame {k}: {d}");
        }
        assert_eq!(clip.resampled(&spec, 60.0), clip, "same rate: unchanged");
    }
}
