//! The configuration reference `docs/config.md`, generated from the Rust types.
//!
//! Every configuration struct and enum derives [`schemars::JsonSchema`], so its `///` doc
//! comments become descriptions of a JSON schema. This module walks that schema (following
//! `$ref`s into `$defs`): every struct-valued field is a TOML sub-table, every other field a key
//! with its type in plain words, its valid range (the one [`skillmimic_env::config_range`]
//! checks), its default (serialised from the `Default` value, in TOML
//! syntax) and the first sentence of its doc comment. Keys appear in declaration order, which is
//! taken from the serialised value (the schema's property maps are sorted).
//!
//! A new field or table needs nothing here: derive `JsonSchema` on new structs/enums, write a
//! `///` doc comment on every field, and regenerate with [`REGENERATE`].

use schemars::JsonSchema;
use serde::de::{Deserializer, MapAccess, Visitor};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use skillmimic_env::config_range::{SchemaDefs, range_text, root_schema};

use crate::config::TrainConfig;
use crate::config_presets::PRESETS;

/// The command that rewrites `docs/config.md` (run from the repository root).
pub const REGENERATE: &str =
    "cargo run --release -p skillmimic-cli -- config reference --out docs/config.md";

/// A generated reference and the keys that have no doc comment (neither on the field nor on its
/// type).
pub struct ConfigReference {
    pub markdown: String,
    pub undocumented: Vec<String>,
}

/// The Markdown of `docs/config.md`.
pub fn config_reference_markdown() -> String {
    train_config_reference().markdown
}

/// The reference of [`TrainConfig`]: header, one table per TOML table, presets.
pub fn train_config_reference() -> ConfigReference {
    let tables = reference_tables(&TrainConfig::default());
    let mut md = format!(
        "# Configuration reference\n\n\
         <!-- Generated file: do not edit. Regenerate with `{REGENERATE}`. -->\n\n\
         > Generated from the Rust configuration types (`skillmimic_learn::config::TrainConfig` and the \
         structs below it) by `{REGENERATE}` (or `skillmimic config reference --out docs/config.md`); do not edit \
         by hand. `cargo test -p skillmimic-learn --test config_doc` fails when this file is out of date.\n\n\
         A training configuration is one TOML file (`--config FILE`) with the tables below, read over the preset \
         chosen by `--preset` (see [Presets](#presets)); keys left out keep the preset's value and unknown keys \
         are errors. Any key can also be set on the command line with `--set table.key=value` (TOML value \
         syntax, bare words are strings), e.g. `--set env.reward.variant=additive`. The configuration of a run \
         is saved next to its checkpoints. The *Default* column shows `TrainConfig::default()`. The *Range* \
         column gives the valid values of every number (of each element for lists and tables; every number \
         must be finite): a value outside it is refused with an error naming the key, by `train` and when a \
         checkpoint's stored configuration is loaded.\n\n\
         The history-encoder pre-training (`skillmimic history pretrain`) is configured by its command-line \
         flags only (`skillmimic history pretrain --help`), not by this file.\n"
    );
    md.push_str(&tables.markdown);
    md.push_str(&presets_markdown());
    ConfigReference { markdown: md, undocumented: tables.undocumented }
}

/// One Markdown section per TOML table of `value`'s type (`value` gives the defaults).
pub fn reference_tables<T: JsonSchema + Serialize>(value: &T) -> ConfigReference {
    let root = root_schema::<T>();
    let mut w =
        Walker { defs: SchemaDefs::of(&root), markdown: String::new(), undocumented: Vec::new() };
    w.table("", "", &root, &ordered(value));
    ConfigReference { markdown: w.markdown, undocumented: w.undocumented }
}

struct Walker {
    defs: SchemaDefs,
    markdown: String,
    undocumented: Vec<String>,
}

impl Walker {
    /// Follow a `$ref` into `$defs`.
    fn resolve<'a>(&'a self, s: &'a Value) -> &'a Value {
        self.defs.resolve(s)
    }

    fn table(&mut self, path: &str, field_doc: &str, schema: &Value, defaults: &Node) {
        if !path.is_empty() {
            let doc = description(schema).unwrap_or_else(|| field_doc.to_string());
            if doc.is_empty() {
                self.undocumented.push(path.to_string());
            }
            self.markdown.push_str(&format!("\n## `[{path}]`\n\n{}\n", paragraphs(&doc)));
        }
        let props =
            schema.get("properties").and_then(Value::as_object).cloned().unwrap_or_default();
        // declaration order from the serialised value, then any key it leaves out (e.g. `None`)
        let mut keys: Vec<String> = defaults
            .entries()
            .iter()
            .map(|(k, _)| k.clone())
            .filter(|k| props.contains_key(k))
            .collect();
        keys.extend(props.keys().filter(|k| !keys.contains(k)).cloned().collect::<Vec<_>>());
        let (mut rows, mut values, mut subtables) = (String::new(), String::new(), Vec::new());
        for key in keys {
            let prop = &props[&key];
            let target = self.resolve(prop).clone();
            let full = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
            let doc = description(prop).or_else(|| description(&target)).unwrap_or_default();
            let default = defaults.get(&key);
            if target.get("properties").is_some() {
                subtables.push((
                    full,
                    doc,
                    target,
                    default.cloned().unwrap_or(Node::Table(Entries(Vec::new()))),
                ));
                continue;
            }
            if doc.is_empty() {
                self.undocumented.push(full.clone());
            }
            let default = default
                .map(|d| format!("`{}`", toml_text(&d.to_value())))
                .unwrap_or_else(|| "*unset*".into());
            let summary = if doc.is_empty() {
                "**undocumented**".into()
            } else {
                cell(&first_sentence(&doc))
            };
            let range = range_text(&target).unwrap_or_default();
            rows.push_str(&format!(
                "| `{key}` | {} | {} | {default} | {summary} |\n",
                cell(&self.type_name(prop)),
                cell(&range)
            ));
            let variants = self.variants(&target);
            if variants.iter().any(|(_, d)| !d.is_empty()) {
                values.push_str(&format!("\nValues of `{key}`:\n\n"));
                for (v, d) in variants {
                    values.push_str(&format!("- `{v}`: {}\n", first_sentence(&d)));
                }
            }
        }
        if !rows.is_empty() {
            self.markdown.push_str(&format!(
                "\n| Key | Type | Range | Default | Description \
                |\n|---|---|---|---|---|\n{rows}{values}"
            ));
        }
        for (full, doc, target, default) in subtables {
            self.table(&full, &doc, &target, &default);
        }
    }

    /// A type in plain words: integer, float, bool, string, path, list of …, one of … .
    fn type_name(&self, s: &Value) -> String {
        let s = self.resolve(s);
        if let Some(alts) = s.get("oneOf").or_else(|| s.get("anyOf")).and_then(Value::as_array) {
            let is_null = |a: &Value| a.get("type").and_then(Value::as_str) == Some("null");
            if alts.len() == 2 && alts.iter().any(is_null) {
                let some = alts.iter().find(|a| !is_null(a)).expect("two alternatives");
                return format!("{}, optional", self.type_name(some));
            }
            return self.one_of(s);
        }
        if s.get("enum").is_some() || s.get("const").is_some() {
            return self.one_of(s);
        }
        let plural = |t: String| match t.split_once(' ').map_or((t.as_str(), ""), |(a, b)| (a, b)) {
            (w @ ("integer" | "float" | "bool" | "string" | "path"), "") => format!("{w}s"),
            ("integer", rest) if !rest.contains(',') => format!("integers {rest}"),
            _ => format!("({t})"),
        };
        let name = |t: &str| match t {
            "number" => "float".into(),
            "boolean" => "bool".into(),
            "string" if s.get("format").and_then(Value::as_str) == Some("path") => "path".into(),
            "array" => format!(
                "list of {}",
                plural(
                    s.get("items").map(|i| self.type_name(i)).unwrap_or_else(|| "values".into())
                )
            ),
            "object" => match s.get("additionalProperties").filter(|a| a.is_object()) {
                Some(a) => format!("table of string → {}", self.type_name(a)),
                None => "table".into(),
            },
            other => other.into(),
        };
        match s.get("type") {
            Some(Value::String(t)) => name(t),
            Some(Value::Array(ts)) => {
                let ts: Vec<&str> = ts.iter().filter_map(Value::as_str).collect();
                let main: Vec<String> =
                    ts.iter().filter(|t| **t != "null").map(|t| name(t)).collect();
                let optional = if ts.contains(&"null") { ", optional" } else { "" };
                format!("{}{optional}", main.join(" or "))
            }
            _ => "any".into(),
        }
    }

    fn one_of(&self, s: &Value) -> String {
        let names: Vec<String> =
            self.variants(s).into_iter().map(|(v, _)| format!("`{v}`")).collect();
        format!("one of {}", names.join(" | "))
    }

    /// The values of an enum in TOML syntax with their docs.
    fn variants(&self, s: &Value) -> Vec<(String, String)> {
        let s = self.resolve(s);
        let doc = || description(s).unwrap_or_default();
        if let Some(c) = s.get("const") {
            return vec![(toml_text(c), doc())];
        }
        if let Some(e) = s.get("enum").and_then(Value::as_array) {
            return e
                .iter()
                .map(|v| (toml_text(v), if e.len() == 1 { doc() } else { String::new() }))
                .collect();
        }
        if let Some(props) = s.get("properties").and_then(Value::as_object) {
            let fields: Vec<String> =
                props.iter().map(|(k, v)| format!("{k} = <{}>", self.type_name(v))).collect();
            return vec![(format!("{{ {} }}", fields.join(", ")), doc())];
        }
        match s.get("oneOf").or_else(|| s.get("anyOf")).and_then(Value::as_array) {
            Some(alts) => alts.iter().flat_map(|a| self.variants(a)).collect(),
            None => Vec::new(),
        }
    }
}

/// The table of what each preset changes.
fn presets_markdown() -> String {
    let base = flatten(&ordered(&TrainConfig::default()));
    let presets: Vec<(&str, Vec<(String, String)>)> = PRESETS
        .iter()
        .map(|p| (*p, flatten(&ordered(&TrainConfig::preset(p).expect("listed preset")))))
        .collect();
    let mut md = format!(
        "\n## Presets\n\n`--preset NAME` starts from `TrainConfig::preset(NAME)`: the defaults \
         above with these keys changed (see `skillmimic train --help` for the default \
         preset).\n\n| Key | Default | {} |\n|---|---|{}\n",
        PRESETS.map(|p| format!("`{p}`")).join(" | "),
        "---|".repeat(PRESETS.len())
    );
    for (key, default) in &base {
        let values: Vec<&str> = presets
            .iter()
            .map(|(_, kv)| kv.iter().find(|(k, _)| k == key).map_or("", |(_, v)| v.as_str()))
            .collect();
        if values.iter().any(|v| v != default) {
            md.push_str(&format!(
                "| `{key}` | `{default}` | {} |\n",
                values.iter().map(|v| format!("`{v}`")).collect::<Vec<_>>().join(" | ")
            ));
        }
    }
    md
}

/// Every leaf key of a serialised value with its default in TOML syntax.
fn flatten(node: &Node) -> Vec<(String, String)> {
    fn go(prefix: &str, node: &Node, out: &mut Vec<(String, String)>) {
        match node {
            Node::Table(entries) => {
                for (k, v) in &entries.0 {
                    go(
                        &if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") },
                        v,
                        out,
                    );
                }
            }
            Node::Leaf(v) => out.push((prefix.to_string(), toml_text(v))),
        }
    }
    let mut out = Vec::new();
    go("", node, &mut out);
    out
}

/// A value in TOML syntax (`null`, which TOML cannot hold, reads "unset").
fn toml_text(v: &Value) -> String {
    match v {
        Value::Null => "unset".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => match (n.is_f64(), n.as_f64()) {
            (true, Some(x)) if x != 0.0 && (x.abs() >= 1e6 || x.abs() < 1e-3) => format!("{x:e}"),
            (true, Some(x)) => format!("{x:?}"),
            _ => n.to_string(),
        },
        Value::String(s) => serde_json::to_string(s).expect("string"),
        Value::Array(a) => format!("[{}]", a.iter().map(toml_text).collect::<Vec<_>>().join(", ")),
        Value::Object(o) => format!(
            "{{ {} }}",
            o.iter().map(|(k, v)| format!("{k} = {}", toml_text(v))).collect::<Vec<_>>().join(", ")
        ),
    }
}

fn description(s: &Value) -> Option<String> {
    s.get("description")
        .and_then(Value::as_str)
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(String::from)
}

/// Doc paragraphs with their lines joined.
fn paragraphs(doc: &str) -> String {
    doc.split("\n\n")
        .map(|p| p.lines().map(str::trim).collect::<Vec<_>>().join(" "))
        .collect::<Vec<_>>()
        .join("\n\n")
}

/// The first sentence of the first paragraph: up to a '.' outside brackets that is followed by a
/// capital letter or a code span (so "Tab. 9", "e.g. `x`" and "0.1. 0 = off" do not end it).
fn first_sentence(doc: &str) -> String {
    let para = paragraphs(doc).split("\n\n").next().unwrap_or_default().to_string();
    let chars: Vec<char> = para.chars().collect();
    let mut depth = 0i32;
    for i in 0..chars.len() {
        match chars[i] {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            '.' if depth == 0
                && chars.get(i + 1) == Some(&' ')
                && chars.get(i + 2).is_some_and(|c| c.is_uppercase() || *c == '`')
                && !(i >= 2 && chars[i - 2] == '.') =>
            {
                return chars[..=i].iter().collect();
            }
            _ => {}
        }
    }
    para
}

/// Text safe inside a Markdown table cell.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

/// A serialised value that keeps the declaration order of struct fields (`serde_json::Map` is
/// sorted unless serde_json's `preserve_order` feature is on, which would change other output;
/// serde's untagged buffering keeps map entries in order).
#[derive(Clone, Deserialize)]
#[serde(untagged)]
enum Node {
    Table(Entries),
    Leaf(Value),
}

#[derive(Clone)]
struct Entries(Vec<(String, Node)>);

impl Node {
    fn entries(&self) -> &[(String, Node)] {
        match self {
            Node::Table(e) => &e.0,
            Node::Leaf(_) => &[],
        }
    }

    fn get(&self, key: &str) -> Option<&Node> {
        self.entries().iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    fn to_value(&self) -> Value {
        match self {
            Node::Table(e) => {
                Value::Object(e.0.iter().map(|(k, v)| (k.clone(), v.to_value())).collect())
            }
            Node::Leaf(v) => v.clone(),
        }
    }
}

fn ordered<T: Serialize>(value: &T) -> Node {
    let text = serde_json::to_string(value).expect("configuration serialises to JSON");
    serde_json::from_str(&text).expect("own JSON parses")
}

impl<'de> Deserialize<'de> for Entries {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Entries;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Entries, A::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry::<String, Node>()? {
                    entries.push(entry);
                }
                Ok(Entries(entries))
            }
        }
        d.deserialize_map(V)
    }
}
