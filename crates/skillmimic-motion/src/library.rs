//! A motion library: many clips with their derived references and the reference sampling rules.
//!
//! * Clip sampling is class-balanced: clip i has weight 1 / (number of clips with its skill
//!   label), and the pickup class (label 1) counts double; clips are drawn with replacement.
//! * Start frames are uniform over 2 … T−2 (inclusive), the reference-state-initialisation range.

use std::path::{Path, PathBuf};

use rand::Rng;

use crate::clip::Clip;
use crate::error::ClipError;
use crate::reference::ClipReference;
use crate::validate::{Naming, validate_clip};

/// Label of the pickup skill, whose class weight is doubled.
pub const PICKUP_LABEL: u32 = 1;
/// Smallest clip length usable for training (start frames 2 … T−2 must exist); the one minimum
/// of every loader, defined in [`crate::validate`].
pub use crate::validate::MIN_FRAMES;

/// One clip of the library with its derived reference.
#[derive(Clone, Debug)]
pub struct MotionClip {
    pub clip: Clip,
    pub reference: ClipReference,
}

/// Clips, derived references and sampling weights.
#[derive(Clone, Debug)]
pub struct MotionLibrary {
    clips: Vec<MotionClip>,
    weights: Vec<f64>,
    cumulative: Vec<f64>,
}

/// All clip files (`.pt`, `.safetensors`) below `path` (a file is returned as is), sorted by
/// path.
pub fn find_clip_files(path: &Path) -> Result<Vec<PathBuf>, ClipError> {
    find_files(path, &["pt", "safetensors"])
}

/// All files with one of the `extensions` (without the dot) below `path` (a file is returned as
/// is, whatever its extension), sorted by path.
pub fn find_files(path: &Path, extensions: &[&str]) -> Result<Vec<PathBuf>, ClipError> {
    if path.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    if !path.is_dir() {
        return Err(ClipError::NotFound { path: path.to_path_buf() });
    }
    let mut out = Vec::new();
    let mut stack = vec![path.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let rd =
            std::fs::read_dir(&dir).map_err(|error| ClipError::Io { path: dir.clone(), error })?;
        for entry in rd {
            let p = entry.map_err(|error| ClipError::Io { path: dir.clone(), error })?.path();
            if p.is_dir() {
                stack.push(p);
            } else if p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.contains(&e))
            {
                out.push(p);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Draw an index from cumulative (not necessarily normalised) weights.
pub fn sample_cumulative<R: Rng + ?Sized>(cumulative: &[f64], rng: &mut R) -> usize {
    let u: f64 = rng.random::<f64>() * cumulative[cumulative.len() - 1];
    cumulative.partition_point(|&c| c <= u).min(cumulative.len() - 1)
}

impl MotionLibrary {
    /// Load every clip found in `paths` (files or folders, searched recursively for `.pt` and
    /// `.safetensors`), in sorted path order.
    pub fn load(paths: &[PathBuf]) -> Result<Self, ClipError> {
        let mut files = Vec::new();
        for p in paths {
            files.extend(find_clip_files(p)?);
        }
        if files.is_empty() {
            let shown: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
            return Err(ClipError::Format {
                path: paths.first().cloned().unwrap_or_default(),
                detail: format!("no .pt or .safetensors clips found in [{}]", shown.join(", ")),
            });
        }
        let clips = files.iter().map(|f| Clip::load_any(f)).collect::<Result<Vec<_>, _>>()?;
        Self::from_clips(clips)
    }

    /// Build a library from loaded clips, each checked by [`validate_clip`] (at least
    /// [`MIN_FRAMES`] frames, plausible values).
    pub fn from_clips(clips: Vec<Clip>) -> Result<Self, ClipError> {
        for c in &clips {
            // clips from files were validated by their loader under the file's name; clips built
            // in memory are named by clip name and `source` (not a file that was loaded)
            validate_clip(
                c,
                Path::new(&format!("clip '{}' (from {})", c.name, c.source)),
                Naming::Project,
            )?;
        }
        if clips.is_empty() {
            return Err(ClipError::Format {
                path: PathBuf::new(),
                detail: "the motion library is empty".into(),
            });
        }
        let count = |label: u32| clips.iter().filter(|c| c.skill == label).count() as f64;
        let raw: Vec<f64> = clips
            .iter()
            .map(|c| (if c.skill == PICKUP_LABEL { 2.0 } else { 1.0 }) / count(c.skill))
            .collect();
        let total: f64 = raw.iter().sum();
        let weights: Vec<f64> = raw.iter().map(|w| w / total).collect();
        let mut acc = 0.0;
        let cumulative = weights
            .iter()
            .map(|w| {
                acc += w;
                acc
            })
            .collect();
        let clips = clips
            .into_iter()
            .map(|clip| {
                let reference = ClipReference::new(&clip);
                MotionClip { clip, reference }
            })
            .collect();
        Ok(Self { clips, weights, cumulative })
    }

    /// Number of clips.
    pub fn len(&self) -> usize {
        self.clips.len()
    }
    /// Always false (an empty library cannot be built).
    pub fn is_empty(&self) -> bool {
        self.clips.is_empty()
    }
    /// Clip `i`.
    pub fn get(&self, i: usize) -> &MotionClip {
        &self.clips[i]
    }
    /// All clips.
    pub fn clips(&self) -> &[MotionClip] {
        &self.clips
    }
    /// Normalised sampling weights.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
    /// Sorted distinct skill labels.
    pub fn skills(&self) -> Vec<u32> {
        let mut s: Vec<u32> = self.clips.iter().map(|c| c.clip.skill).collect();
        s.sort_unstable();
        s.dedup();
        s
    }
    /// Indices of the clips with skill `label`.
    pub fn clips_of_skill(&self, label: u32) -> Vec<usize> {
        (0..self.clips.len()).filter(|&i| self.clips[i].clip.skill == label).collect()
    }

    /// Draw a clip index with the class-balanced weights.
    pub fn sample_clip<R: Rng>(&self, rng: &mut R) -> usize {
        sample_cumulative(&self.cumulative, rng)
    }

    /// Cumulative sums of the class-balanced weights each multiplied by `factor(clip)` (draw
    /// from them with [`sample_cumulative`]).
    pub fn cumulative_weighted(&self, factor: impl Fn(&Clip) -> f64) -> Vec<f64> {
        let mut acc = 0.0;
        self.clips
            .iter()
            .zip(&self.weights)
            .map(|(m, w)| {
                acc += w * factor(&m.clip);
                acc
            })
            .collect()
    }

    /// Draw a start frame uniformly from 2 … T−2 of clip `i`.
    pub fn sample_start<R: Rng>(&self, i: usize, rng: &mut R) -> usize {
        rng.random_range(2..=self.clips[i].clip.num_frames - 2)
    }
}
