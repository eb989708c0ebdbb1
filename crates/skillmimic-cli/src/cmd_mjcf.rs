//! `skillmimic mjcf`: write the shipped scene files.

use std::path::PathBuf;

use anyhow::Context;
use skillmimic_sim::mjcf::{default_scene_file, scene_xml};
use skillmimic_sim::{HandModel, SceneOptions};

#[derive(clap::Args)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "mjcf")]
    pub out_dir: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    for hands in [HandModel::Full, HandModel::Box] {
        let path = a.out_dir.join(default_scene_file(hands));
        let xml = scene_xml(&SceneOptions { hands, ..Default::default() });
        skillmimic_core::tensorfile::write_bytes_atomic(&path, xml.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        tracing::info!("wrote {}", path.display());
    }
    Ok(())
}
