//! `skillmimic config reference`: write the configuration reference (`docs/config.md`),
//! generated from the configuration types by `skillmimic_learn::config_doc`.

use std::path::PathBuf;

use anyhow::Context;
use skillmimic_learn::config_doc::train_config_reference;

#[derive(clap::Subcommand)]
pub enum ConfigCommand {
    /// Print (or write) the Markdown reference of every configuration key: table, key, type,
    /// default, description (the committed copy is docs/config.md).
    Reference(ReferenceArgs),
}

#[derive(clap::Args)]
pub struct ReferenceArgs {
    /// Write to this file (e.g. docs/config.md) instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(cmd: ConfigCommand) -> anyhow::Result<()> {
    match cmd {
        ConfigCommand::Reference(a) => reference(a),
    }
}

fn reference(a: ReferenceArgs) -> anyhow::Result<()> {
    let r = train_config_reference();
    if !r.undocumented.is_empty() {
        anyhow::bail!(
            "config keys without a /// doc comment: {} (document the fields, then regenerate)",
            r.undocumented.join(", ")
        );
    }
    match a.out {
        Some(path) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
            }
            std::fs::write(&path, &r.markdown)
                .with_context(|| format!("cannot write {}", path.display()))?;
            println!("wrote {}", path.display());
        }
        None => print!("{}", r.markdown),
    }
    Ok(())
}
