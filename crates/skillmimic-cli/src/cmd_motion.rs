//! `skillmimic convert` and `skillmimic synth-motions`: motion-clip tools.

use std::collections::HashMap;
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
///
/// Every clip is loaded and validated (the checks of training, `skillmimic_motion::validate`)
/// before anything is written, and an output that is one of the inputs (same file after
/// resolving `.`, `..` and symlinks, or a hard link to it) is refused: on any error nothing is
/// written.
pub fn convert(a: ConvertArgs) -> anyhow::Result<()> {
    if a.input.is_file() {
        InputFiles::new(std::slice::from_ref(&a.input)).refuse_as_output(&a.output)?;
        let clip = Clip::load_any(&a.input)?;
        clip.save(&a.output).with_context(|| format!("cannot write {}", a.output.display()))?;
        tracing::info!(
            "{} -> {} ({} frames, skill {})",
            a.input.display(),
            a.output.display(),
            clip.num_frames,
            clip.skill
        );
        return Ok(());
    }
    let files: Vec<PathBuf> = find_clip_files(&a.input)?
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "pt"))
        .collect();
    anyhow::ensure!(!files.is_empty(), "no .pt clips found under {}", a.input.display());
    let outs: Vec<PathBuf> = files
        .iter()
        .map(|f| a.output.join(f.strip_prefix(&a.input).unwrap_or(f)).with_extension("safetensors"))
        .collect();
    let inputs = InputFiles::new(&files);
    for out in &outs {
        inputs.refuse_as_output(out)?;
    }
    let clips = files.iter().map(|f| Clip::from_pt(f)).collect::<Result<Vec<_>, _>>()?;
    for (clip, out) in clips.iter().zip(&outs) {
        clip.save(out).with_context(|| format!("cannot write {}", out.display()))?;
    }
    tracing::info!(
        "converted {} clips from {} into {}",
        files.len(),
        a.input.display(),
        a.output.display()
    );
    Ok(())
}

/// The identities of the input files: canonical paths and, on Unix, (device, inode) pairs.
struct InputFiles {
    paths: HashMap<PathBuf, PathBuf>,
    ids: HashMap<(u64, u64), PathBuf>,
}

impl InputFiles {
    fn new(inputs: &[PathBuf]) -> Self {
        let mut s = Self { paths: HashMap::new(), ids: HashMap::new() };
        for input in inputs {
            if let Ok(c) = std::fs::canonicalize(input) {
                if let Some(id) = file_id(&c) {
                    s.ids.insert(id, input.clone());
                }
                s.paths.insert(c, input.clone());
            }
        }
        s
    }

    /// Error when `output` is one of the inputs: same resolved path ([`resolve`]), or (Unix)
    /// same device and inode, so `./x.pt` vs `x.pt`, `new/../x.pt`, symlinks and hard links count.
    fn refuse_as_output(&self, output: &Path) -> anyhow::Result<()> {
        let Some(out) = resolve(output) else { return Ok(()) };
        let hit = self.paths.get(&out).or_else(|| file_id(&out).and_then(|id| self.ids.get(&id)));
        if let Some(input) = hit {
            anyhow::bail!(
                "{}: output is the input file {}; converting would overwrite the source clip, \
                    give another output path",
                output.display(),
                input.display()
            );
        }
        Ok(())
    }
}

/// The absolute path `p` will name once its missing folders are created: its longest existing
/// ancestor canonicalised (symlinks, `.`, `..` resolved), then the remaining components, where a
/// `..` after a folder that does not exist yet goes back to that folder's parent.
fn resolve(p: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let abs = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().ok()?.join(p) };
    let comps: Vec<Component> = abs.components().collect();
    for n in (1..=comps.len()).rev() {
        let prefix: PathBuf = comps[..n].iter().collect();
        if let Ok(mut c) = std::fs::canonicalize(&prefix) {
            for comp in &comps[n..] {
                match comp {
                    Component::ParentDir => {
                        c.pop();
                    }
                    Component::CurDir => {}
                    other => c.push(other),
                }
            }
            return Some(c);
        }
    }
    None
}

/// (device, inode) of an existing file.
#[cfg(unix)]
fn file_id(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &Path) -> Option<(u64, u64)> {
    None
}

#[derive(clap::Args)]
pub struct SynthArgs {
    /// Output folder (default `motions` for the demo clips; required with `--character tokenhsi`,
    /// whose clips must not land among the SkillMimic clips of `motions/`).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Whose clips: `skillmimic` (the demo dribbles with the ball, the files of `motions/`) or
    /// `tokenhsi` (the procedural walks, sits, step-ups and carrying walks that `builtin:walks`,
    /// `builtin:sit`, `builtin:climb` and `builtin:carry` stand for, written as character clips
    /// to look at or to edit; the seat, platform and box they were made against are in each
    /// clip's `source`).
    #[arg(long, default_value = "skillmimic")]
    pub character: String,
}

/// File name of a synthesised clip.
pub fn synth_file_name(clip: &Clip) -> String {
    format!("{}.safetensors", clip.name)
}

/// Write the procedurally synthesised demo clips (deterministic).
pub fn synth(a: SynthArgs) -> anyhow::Result<()> {
    match a.character.as_str() {
        "skillmimic" => {}
        "tokenhsi" => {
            let Some(dir) = &a.out_dir else {
                anyhow::bail!("--character tokenhsi needs --out-dir (a folder outside motions/)");
            };
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let sits = skillmimic_motion::synth_sit::tokenhsi_sits().into_iter().map(|s| s.clip);
            let carries =
                skillmimic_motion::synth_carry::tokenhsi_carries().into_iter().map(|c| c.clip);
            let climbs =
                skillmimic_motion::synth_climb::tokenhsi_climbs().into_iter().map(|c| c.clip);
            let walks = skillmimic_motion::synth_walk::tokenhsi_walks().into_iter();
            for clip in walks.chain(sits).chain(climbs).chain(carries) {
                let path = dir.join(format!("{}.safetensors", clip.name));
                clip.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
                tracing::info!(
                    "wrote {} ({} frames, {})",
                    path.display(),
                    clip.num_frames,
                    clip.source
                );
            }
            return Ok(());
        }
        other => anyhow::bail!("--character: '{other}'; expected skillmimic or tokenhsi"),
    }
    let dir = a.out_dir.unwrap_or_else(|| PathBuf::from("motions"));
    for clip in synth::demo_clips()? {
        let path: PathBuf = dir.join(synth_file_name(&clip));
        clip.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
        tracing::info!(
            "wrote {} ({} frames, skill {})",
            path.display(),
            clip.num_frames,
            clip.skill
        );
    }
    Ok(())
}
