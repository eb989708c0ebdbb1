//! `docs/config.md` is generated from the configuration types and must match them.

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::Serialize;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::config_doc::{
    REGENERATE, config_reference_markdown, reference_tables, train_config_reference,
};

fn doc_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/config.md")
}

/// Set `UPDATE_CONFIG_DOC=1` to rewrite the file instead of comparing.
#[test]
fn committed_reference_is_current() {
    let generated = config_reference_markdown();
    let path = doc_path();
    if std::env::var_os("UPDATE_CONFIG_DOC").is_some() {
        std::fs::write(&path, &generated).expect("write docs/config.md");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != generated {
        let line = committed
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(committed.lines().count().min(generated.lines().count()));
        panic!(
            "docs/config.md does not match the configuration types (first difference at line {}).\n\
             Regenerate it from the repository root with:\n    {REGENERATE}\n\
             (or: UPDATE_CONFIG_DOC=1 cargo test --release -p skillmimic-learn --test config_doc)",
            line + 1
        );
    }
}

#[test]
fn every_key_is_documented() {
    let r = train_config_reference();
    assert!(
        r.undocumented.is_empty(),
        "config keys without a /// doc comment: {:?} — document them, then run {REGENERATE}",
        r.undocumented
    );
}

/// Rows of the document: (table, key).
fn rows(md: &str) -> Vec<(String, String)> {
    let mut table = String::new();
    let mut out = Vec::new();
    for line in md.lines() {
        if let Some(t) = line.strip_prefix("## `[").and_then(|l| l.strip_suffix("]`")) {
            table = t.to_string();
        } else if line == "## Presets" {
            table.clear();
        } else if let Some(key) =
            line.strip_prefix("| `").and_then(|l| l.split_once("` |")).map(|(k, _)| k)
            && !table.is_empty()
        {
            out.push((table.clone(), key.to_string()));
        }
    }
    out
}

fn leaf_keys(prefix: &str, t: &toml::Table, out: &mut Vec<String>) {
    for (k, v) in t {
        let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match v {
            toml::Value::Table(sub) => leaf_keys(&key, sub, out),
            _ => out.push(key),
        }
    }
}

#[test]
fn every_serialised_key_is_in_the_reference() {
    let md = config_reference_markdown();
    let rows = rows(&md);
    let mut keys = Vec::new();
    leaf_keys("", &toml::Table::try_from(TrainConfig::default()).unwrap(), &mut keys);
    assert!(keys.len() > 50, "{keys:?}");
    for key in keys {
        // a key is listed under its table, or (an inline table value) its parent is
        let parts: Vec<&str> = key.split('.').collect();
        let found =
            (1..parts.len()).any(|i| rows.contains(&(parts[..i].join("."), parts[i].to_string())));
        assert!(found, "config key '{key}' is missing from docs/config.md");
    }
}

#[test]
fn reference_shows_types_defaults_enums_and_presets() {
    let md = config_reference_markdown();
    for needle in [
        "## `[env.reward.deepmimic]`",
        "## `[env.v2.history]`",
        "| `hidden` | list of integers | each in [1, ∞) | `[1024, 512, 512]` |",
        "| `lr` | float | (0, 1000] | `2e-5` | Adam learning rate (constant). |",
        "| `gamma` | float | (0, 1] | `0.99` |",
        "| `termination_height` | float | finite | `0.3` |",
        "| `out_dir` | path |  | `\"runs/skillmimic\"` |",
        "| `backend` | one of `\"fast\"` \\| `\"candle\"` |  | `\"fast\"` |",
        "- `\"candle\"`: candle's generic autograd",
        "| `env.num_envs` | `64` | `2048` | `256` | `128` | `16` |",
    ] {
        assert!(md.contains(needle), "missing {needle:?} in\n{md}");
    }
}

/// A field without a doc comment is reported (and `every_key_is_documented` then fails).
#[test]
fn undocumented_fields_are_reported() {
    #[derive(Serialize, JsonSchema, Default)]
    #[serde(default)]
    struct Inner {
        flag: bool,
    }
    /// Demo.
    #[derive(Serialize, JsonSchema, Default)]
    #[serde(default)]
    struct Demo {
        /// Documented.
        a: u32,
        b: f64,
        inner: Inner,
    }
    let r = reference_tables(&Demo::default());
    assert_eq!(r.undocumented, vec!["b".to_string(), "inner".into(), "inner.flag".into()]);
    assert!(
        r.markdown.contains("| `b` | float | finite | `0.0` | **undocumented** |"),
        "{}",
        r.markdown
    );
}
