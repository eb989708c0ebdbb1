//! `skillmimic mjcf`: write the shipped scene files, one per character variant (the SkillMimic
//! humanoid with its ball and either hand model, the bare TokenHSI character and SMPL humanoid).

use std::path::PathBuf;

use anyhow::Context;
use skillmimic_sim::Character;
use skillmimic_sim::mjcf::{default_scene, default_scene_file, scene_xml};

#[derive(clap::Args)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "mjcf")]
    pub out_dir: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    for character in Character::variants() {
        let path = a.out_dir.join(default_scene_file(character));
        let xml = scene_xml(&default_scene(character));
        skillmimic_core::tensorfile::write_bytes_atomic(&path, xml.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        tracing::info!("wrote {}", path.display());
    }
    Ok(())
}
