//! `skillmimic convert` and `skillmimic synth-motions`: motion-clip tools.

use std::path::{Path, PathBuf};

use anyhow::Context;
use skillmimic_env::synth;
use skillmimic_motion::Clip;
use skillmimic_motion::library::find_clip_files;

#[derive(clap::Args)]
pub struct ConvertArgs {
    /// A BallPlay-M `.pt` file, or a folder searched recursively for them.
    pub input: PathBuf,
    /// Output `.safetensors` file, or (for a folder input) the output folder, mirroring the
    /// input's sub-folders.
    pub output: PathBuf,
}

/// Convert one file or a folder tree of `.pt` clips into the project format.
pub fn convert(a: ConvertArgs) -> anyhow::Result<()> {
    if a.input.is_file() {
        let clip = Clip::load_any(&a.input)?;
        clip.save(&a.output).with_context(|| format!("cannot write {}", a.output.display()))?;
        tracing::info!("{} -> {} ({} frames, skill {})", a.input.display(), a.output.display(), clip.num_frames, clip.skill);
        return Ok(());
    }
    let files: Vec<PathBuf> = find_clip_files(&a.input)?.into_iter().filter(|p| p.extension().is_some_and(|e| e == "pt")).collect();
    anyhow::ensure!(!files.is_empty(), "no .pt clips found under {}", a.input.display());
    for f in &files {
        let rel = f.strip_prefix(&a.input).unwrap_or(f);
        let out = a.output.join(rel).with_extension("safetensors");
        let clip = Clip::from_pt(f)?;
        clip.save(&out).with_context(|| format!("cannot write {}", out.display()))?;
    }
    tracing::info!("converted {} clips from {} into {}", files.len(), a.input.display(), a.output.display());
    Ok(())
}

#[derive(clap::Args)]
pub struct SynthArgs {
    /// Output folder for the demo clips.
    #[arg(long, default_value = "motions")]
    pub out_dir: PathBuf,
}

/// File name of a synthesised clip.
pub fn synth_file_name(clip: &Clip) -> String {
    format!("{}.safetensors", clip.name)
}

/// Write the procedurally synthesised demo clips (deterministic).
pub fn synth(a: SynthArgs) -> anyhow::Result<()> {
    for clip in synth::demo_clips()? {
        let path: PathBuf = Path::new(&a.out_dir).join(synth_file_name(&clip));
        clip.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
        tracing::info!("wrote {} ({} frames, skill {})", path.display(), clip.num_frames, clip.skill);
    }
    Ok(())
}
