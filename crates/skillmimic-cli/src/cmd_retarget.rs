//! `skillmimic retarget`: SkillMimic-skeleton clips (BallPlay-M `.pt` or the project format) →
//! clips of the TokenHSI character (`tokenhsi-clip` format, `skillmimic_motion::hsi_clip`), by
//! shared joints (`skillmimic_motion::retarget_hsi`), with a JSON report per clip: foot height
//! error over the source's stance frames and joint-limit violations.
//!
//! Users who bring AMASS / SAMP / OMOMO motions for the sit, climb and carry styles (not
//! redistributable here) write the `tokenhsi-clip` arrays directly from their SMPL retargets: the
//! character's lower body has SMPL's neutral offsets, so SMPL joint rotations of the shared joints
//! transfer as they are (see docs/tokenhsi.md).

use std::path::PathBuf;

use anyhow::{Context, bail};
use skillmimic_motion::Clip;
use skillmimic_motion::library::find_clip_files;
use skillmimic_motion::retarget_hsi::retarget_to_hsi;

#[derive(clap::Args)]
pub struct Args {
    /// Target character (only `tokenhsi`).
    #[arg(long, default_value = "tokenhsi")]
    pub to: String,
    /// Source clip files or folders (repeatable).
    #[arg(long, required = true)]
    pub motion: Vec<PathBuf>,
    /// Output folder (one `<name>.safetensors` per clip and `retarget_report.json`).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.to != "tokenhsi" {
        bail!("--to '{}': the only target character is 'tokenhsi'", a.to);
    }
    let mut files = Vec::new();
    for m in &a.motion {
        files.extend(find_clip_files(m)?);
    }
    if files.is_empty() {
        bail!("no .pt or .safetensors clips under {:?}", a.motion);
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut reports = Vec::new();
    for f in &files {
        let clip = Clip::load_any(f)?;
        let (out, rep) = retarget_to_hsi(&clip);
        let path = a.out.join(format!("{}.safetensors", clip.name));
        out.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
        println!(
            "{}: {} frames, foot height error {:.1} mm mean / {:.1} mm max over {} stance frames, {} 3-DoF axes beyond their limits and {} elbow angles clamped ({:.1} % of frames, max excess {:.1} deg)",
            clip.name,
            rep.frames,
            1000.0 * rep.foot_height_error_mean,
            1000.0 * rep.foot_height_error_max,
            rep.stance_frames,
            rep.limit_violations,
            rep.elbow_clamped,
            100.0 * rep.frames_with_violation,
            rep.max_violation.to_degrees()
        );
        reports.push(rep);
    }
    let path = a.out.join("retarget_report.json");
    skillmimic_core::tensorfile::write_bytes_atomic(&path, serde_json::to_string_pretty(&reports)?.as_bytes()).with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote {} clips and {}", reports.len(), path.display());
    Ok(())
}
