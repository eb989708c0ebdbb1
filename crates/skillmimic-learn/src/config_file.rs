//! Reading a configuration file, and the one rule for the relative paths written in it.
//!
//! The CLI (`--config`) and the Python package (`VecEnv(config=path)`, `load_config`) both read
//! files through this module, so a file means the same thing to both.
//!
//! **Rule.** A relative path written in a config file (`env.motion` entries,
//! `env.v2.history.encoder`,
//! `env.hlc.llc`) names a file or folder next to the config file: it becomes
//! `<folder of the file>/<path>`. One exception keeps the files the trainer writes usable: their
//! paths were given relative to the working directory of the run (`runs/x/config.toml` says
//! `motion = ["motions"]`), so a path that does not exist next to the file but does exist relative
//! to the working directory stays as written. Absolute paths, empty paths and built-in names
//! (`builtin:…`, e.g. [`BUILTIN_DEMO`](skillmimic_env::BUILTIN_DEMO)) are kept. Paths the file
//! does not set (preset defaults, command-line flags) are not touched.

use std::path::{Path, PathBuf};

use crate::config::TrainConfig;
use crate::error::LearnError;

/// Key paths, inside an `[env]` table, whose values are input paths (a string or an array of them).
pub const ENV_PATH_KEYS: [&[&str]; 3] =
    [&["motion"], &["v2", "history", "encoder"], &["hlc", "llc"]];

/// The top-level tables of a training config file.
pub const TABLES: [&str; 3] = ["env", "ppo", "run"];

/// Resolve one path written in a config file whose folder is `config_dir` (see the module docs).
pub fn resolve_path(written: &Path, config_dir: &Path) -> PathBuf {
    if written.as_os_str().is_empty()
        || written.is_absolute()
        || written.to_str().is_some_and(|s| s.starts_with("builtin:"))
    {
        return written.to_path_buf();
    }
    let beside = config_dir.join(written);
    if !beside.exists() && written.exists() { written.to_path_buf() } else { beside }
}

/// Rewrite the relative paths of an `[env]` table (keys [`ENV_PATH_KEYS`]) against `config_dir`.
pub fn resolve_env_paths(env: &mut toml::Table, config_dir: &Path) {
    let fix = |v: &mut toml::Value| {
        if let toml::Value::String(s) = v {
            *s = resolve_path(Path::new(s.as_str()), config_dir).to_string_lossy().into_owned();
        }
    };
    for key in ENV_PATH_KEYS {
        let (last, parents) = key.split_last().expect("non-empty key path");
        let mut table = Some(&mut *env);
        for p in parents {
            table = table.and_then(|t| t.get_mut(*p)).and_then(|v| v.as_table_mut());
        }
        match table.and_then(|t| t.get_mut(*last)) {
            Some(toml::Value::Array(items)) => items.iter_mut().for_each(fix),
            Some(v) => fix(v),
            None => {}
        }
    }
}

/// Folder that relative paths of the config file `path` are resolved against.
pub fn config_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// Parse the config file `path` (`text` is its content) into a TOML table with its paths resolved.
pub fn parse_resolved(text: &str, path: &Path) -> Result<toml::Table, LearnError> {
    let mut doc: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| LearnError::Config(format!("{}: {e}", path.display())))?;
    if let Some(toml::Value::Table(env)) = doc.get_mut("env") {
        resolve_env_paths(env, config_dir(path));
    }
    Ok(doc)
}

fn read(path: &Path) -> Result<String, LearnError> {
    std::fs::read_to_string(path).map_err(crate::error::io(path))
}

/// The training configuration of `skillmimic train --preset … --config path` (before the
/// command-line flags): the file over `base`, its relative paths resolved.
pub fn load_train_config(base: &TrainConfig, path: &Path) -> Result<TrainConfig, LearnError> {
    let doc = parse_resolved(&read(path)?, path)?;
    let text = toml::to_string(&doc)
        .map_err(|e| LearnError::Config(format!("{}: {e}", path.display())))?;
    TrainConfig::from_toml_over(base, &text, path)
}

/// The `[env]` fields that the config file `path` sets, its relative paths resolved, for a
/// standalone environment (Python `VecEnv`): the `[env]` table of a training config file, or, in
/// a file with none of the tables `[env]`, `[ppo]`, `[run]`, the top-level keys.
pub fn load_env_table(path: &Path) -> Result<toml::Table, LearnError> {
    let text = read(path)?;
    let mut doc: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| LearnError::Config(format!("{}: {e}", path.display())))?;
    let mut env = if TABLES.iter().any(|t| doc.contains_key(*t)) {
        match doc.remove("env") {
            Some(toml::Value::Table(t)) => t,
            Some(_) => {
                return Err(LearnError::Config(format!(
                    "{}: `env` must be a table",
                    path.display()
                )));
            }
            None => toml::Table::new(),
        }
    } else {
        doc
    };
    resolve_env_paths(&mut env, config_dir(path));
    Ok(env)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir()
            .join(format!("skillmimic-config-file-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("sub/clips")).unwrap();
        d
    }

    #[test]
    fn relative_paths_are_relative_to_the_file() {
        let d = scratch("rel");
        std::fs::write(d.join("sub/enc.safetensors"), b"").unwrap();
        let text = "[env]\nmotion = [\"clips\", \"missing\", \"/abs/clip.pt\", \
            \"builtin:demo\"]\n[env.v2.history]\nencoder = \"enc.safetensors\"\n";
        let file = d.join("sub/cfg.toml");
        std::fs::write(&file, text).unwrap();
        let c = load_train_config(&TrainConfig::default(), &file).unwrap();
        let sub = d.join("sub");
        assert_eq!(
            c.env.motion,
            vec![
                sub.join("clips"),
                sub.join("missing"),
                PathBuf::from("/abs/clip.pt"),
                PathBuf::from("builtin:demo")
            ]
        );
        assert_eq!(c.env.v2.history.encoder, sub.join("enc.safetensors"));
        // the same table for a standalone environment; a file without tables = top-level keys
        let env = load_env_table(&file).unwrap();
        assert_eq!(env["motion"][0].as_str(), Some(sub.join("clips").to_str().unwrap()));
        std::fs::write(&file, "num_envs = 3\nmotion = [\"clips\"]\n").unwrap();
        let env = load_env_table(&file).unwrap();
        assert_eq!(
            (env["num_envs"].as_integer(), env["motion"][0].as_str()),
            (Some(3), Some(sub.join("clips").to_str().unwrap()))
        );
        std::fs::write(&file, "[ppo]\nlr = 1e-4\n").unwrap();
        assert!(load_env_table(&file).unwrap().is_empty());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn paths_of_the_working_directory_survive_when_nothing_is_next_to_the_file() {
        let d = scratch("cwd");
        let here = Path::new("Cargo.toml"); // exists in the crate folder, the working directory of tests
        assert_eq!(resolve_path(here, &d), here);
        std::fs::write(d.join("Cargo.toml"), b"").unwrap();
        assert_eq!(resolve_path(here, &d), d.join("Cargo.toml"), "next to the file wins");
        assert_eq!(resolve_path(Path::new(""), &d), PathBuf::new());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn unset_paths_keep_the_preset_values() {
        let d = scratch("unset");
        let file = d.join("sub/cfg.toml");
        std::fs::write(&file, "[env]\nnum_envs = 4\n").unwrap();
        let c = load_train_config(&TrainConfig::default(), &file).unwrap();
        assert_eq!(c.env.motion, TrainConfig::default().env.motion);
        assert_eq!(c.env.num_envs, 4);
        std::fs::remove_dir_all(&d).ok();
    }
}
