//! One validation of configuration values: the valid range of every numeric key is written once,
//! as a schemars attribute on its field, and checked here against the serialised value.
//!
//! Ranges are JSON-schema keywords on the field's schema: `minimum` / `maximum` (inclusive,
//! `#[schemars(range(min = .., max = ..))]`) and `exclusiveMinimum` / `exclusiveMaximum`
//! (`#[schemars(extend("exclusiveMinimum" = 0))]`); a list's or table's values carry them on
//! `items` (`#[schemars(inner(range(..)))]`) or `additionalProperties`. A number with no bound
//! must still be finite. [`check_ranges`] walks the schema of a configuration type (following
//! `$ref`s into `$defs`, [`SchemaDefs`]) next to the value serialised with `serde_json`, which
//! turns NaN and ±∞ into `null`: a `null` where the schema says number is a non-finite value.
//! The configuration reference (`docs/config.md`) prints the same ranges with [`range_text`].

use schemars::{JsonSchema, SchemaGenerator};
use serde::Serialize;
use serde_json::{Map, Value};

use crate::error::{ConfigError, bad};

/// The most worker threads a pool may be asked for (`env.threads`, `run.learner_threads`).
pub const MAX_THREADS: usize = 1024;

/// The root JSON schema of `T` as a value.
pub fn root_schema<T: JsonSchema>() -> Value {
    SchemaGenerator::default().into_root_schema_for::<T>().to_value()
}

/// The `$defs` of a root schema, to follow `$ref`s (one level is all schemars emits).
pub struct SchemaDefs(Map<String, Value>);

impl SchemaDefs {
    /// The definitions of the root schema `root`.
    pub fn of(root: &Value) -> Self {
        Self(root.get("$defs").and_then(Value::as_object).cloned().unwrap_or_default())
    }

    /// `s` itself, or the definition its `$ref` names.
    pub fn resolve<'a>(&'a self, s: &'a Value) -> &'a Value {
        match s.get("$ref").and_then(Value::as_str).and_then(|r| r.strip_prefix("#/$defs/")) {
            Some(name) => self.0.get(name).unwrap_or(s),
            None => s,
        }
    }
}

/// Check every number of `value` against the range its schema gives (and finiteness). `prefix`
/// is the key path of `value` in the configuration file (`""` for the whole file, `"env"` for
/// the `[env]` table); the error names the full key (`ppo.gamma`), the value and the range.
pub fn check_ranges<T: JsonSchema + Serialize>(value: &T, prefix: &str) -> Result<(), ConfigError> {
    let root = root_schema::<T>();
    let json = serde_json::to_value(value)
        .map_err(|e| bad(prefix, format!("cannot be serialised: {e}")))?;
    let defs = SchemaDefs::of(&root);
    check(&defs, prefix, &root, &json)
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() { key.to_string() } else { format!("{path}.{key}") }
}

fn check(defs: &SchemaDefs, path: &str, schema: &Value, value: &Value) -> Result<(), ConfigError> {
    let s = defs.resolve(schema);
    if let Some(alts) = s.get("oneOf").or_else(|| s.get("anyOf")).and_then(Value::as_array) {
        // the alternative of the value's shape (serde accepted the value, so one fits)
        return match alts.iter().find(|a| fits(defs, a, value)) {
            Some(a) => check(defs, path, a, value),
            None => Ok(()),
        };
    }
    match value {
        Value::Object(map) => {
            let props = s.get("properties").and_then(Value::as_object);
            let extra = s.get("additionalProperties").filter(|a| a.is_object());
            for (k, v) in map {
                if let Some(sub) = props.and_then(|p| p.get(k)).or(extra) {
                    check(defs, &join(path, k), sub, v)?;
                }
            }
            Ok(())
        }
        Value::Array(items) => match s.get("items").filter(|i| i.is_object()) {
            Some(item) => {
                for (i, v) in items.iter().enumerate() {
                    check(defs, &format!("{path}[{i}]"), item, v)?;
                }
                Ok(())
            }
            None => Ok(()),
        },
        Value::Number(n) if is_numeric(s) => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            if in_range(s, x) {
                Ok(())
            } else {
                Err(bad(
                    path,
                    format!(
                        "{} is outside the valid range {}",
                        number_text(n),
                        range_text(s).unwrap_or_default()
                    ),
                ))
            }
        }
        Value::Null if is_numeric(s) && !types(s).contains(&"null") => Err(bad(
            path,
            format!(
                "is not a finite number (NaN or infinite); valid range {}",
                range_text(s).unwrap_or_default()
            ),
        )),
        _ => Ok(()),
    }
}

/// The `type` keyword as a list.
fn types(s: &Value) -> Vec<&str> {
    match s.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    }
}

fn is_numeric(s: &Value) -> bool {
    types(s).iter().any(|t| *t == "number" || *t == "integer")
}

/// Whether `value` has the shape of the alternative `alt` (for `oneOf` / `anyOf`).
fn fits(defs: &SchemaDefs, alt: &Value, value: &Value) -> bool {
    let alt = defs.resolve(alt);
    if let Some(c) = alt.get("const") {
        return c == value;
    }
    if let Some(e) = alt.get("enum").and_then(Value::as_array) {
        return e.contains(value);
    }
    let ts = types(alt);
    let has = |t: &str| ts.contains(&t);
    match value {
        Value::Null => has("null") || is_numeric(alt),
        Value::Bool(_) => has("boolean"),
        Value::Number(_) => is_numeric(alt),
        Value::String(_) => has("string"),
        Value::Array(_) => has("array"),
        Value::Object(map) => match alt.get("properties").and_then(Value::as_object) {
            Some(props) => map.keys().all(|k| props.contains_key(k)),
            None => has("object"),
        },
    }
}

fn bound(s: &Value, key: &str) -> Option<f64> {
    s.get(key).and_then(Value::as_f64)
}

fn in_range(s: &Value, x: f64) -> bool {
    x.is_finite()
        && bound(s, "minimum").is_none_or(|m| x >= m)
        && bound(s, "maximum").is_none_or(|m| x <= m)
        && bound(s, "exclusiveMinimum").is_none_or(|m| x > m)
        && bound(s, "exclusiveMaximum").is_none_or(|m| x < m)
}

fn number_text(n: &serde_json::Number) -> String {
    match n.as_f64() {
        Some(x) if n.is_f64() => bound_text(x),
        _ => n.to_string(),
    }
}

/// A bound in short form: `0`, `0.5`, `1e-10`, `1e12`.
fn bound_text(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e6 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else if x.fract() == 0.0 {
        format!("{x:.0}")
    } else {
        format!("{x}")
    }
}

/// The valid range of a numeric schema in interval notation (`[0, 1]`, `(0, ∞)`, `finite`), or
/// of the values of a list or table (`each in [0, ∞)`); `None` for other schemas.
pub fn range_text(s: &Value) -> Option<String> {
    if !is_numeric(s) {
        let inner =
            s.get("items").or_else(|| s.get("additionalProperties")).filter(|i| i.is_object())?;
        return range_text(inner)
            .map(|r| format!("each {}", if r == "finite" { r } else { format!("in {r}") }));
    }
    let (lo, lo_open) = match (bound(s, "minimum"), bound(s, "exclusiveMinimum")) {
        (_, Some(m)) => (Some(m), true),
        (m, None) => (m, false),
    };
    let (hi, hi_open) = match (bound(s, "maximum"), bound(s, "exclusiveMaximum")) {
        (_, Some(m)) => (Some(m), true),
        (m, None) => (m, false),
    };
    if lo.is_none() && hi.is_none() {
        return Some("finite".into());
    }
    let lo = match lo {
        Some(m) => format!("{}{}", if lo_open { "(" } else { "[" }, bound_text(m)),
        None => "(−∞".into(),
    };
    let hi = match hi {
        Some(m) => format!("{}{}", bound_text(m), if hi_open { ")" } else { "]" }),
        None => "∞)".into(),
    };
    Some(format!("{lo}, {hi}"))
}

/// A worker-thread count for a pool: `requested` (0 = one per core, the pool's default), capped
/// to four per core of this machine with a message on standard error — a count far above the
/// cores only adds OS threads. `key` names the setting in the message.
pub fn capped_threads(requested: usize, key: &str) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = 4 * cores;
    if requested > cap {
        eprintln!(
            "warning: {key} = {requested} is far above the {cores} cores of this machine; using \
                {cap} threads"
        );
        cap
    } else {
        requested
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, JsonSchema)]
    struct Inner {
        #[schemars(extend("exclusiveMinimum" = 0), range(max = 1))]
        p: f64,
        #[schemars(inner(range(min = 1)))]
        widths: Vec<usize>,
    }

    #[derive(Serialize, JsonSchema)]
    struct Outer {
        #[schemars(range(min = -20, max = 2))]
        x: f64,
        inner: Inner,
        opt: Option<u32>,
    }

    fn outer(x: f64, p: f64, widths: Vec<usize>) -> Outer {
        Outer { x, inner: Inner { p, widths }, opt: None }
    }

    #[test]
    fn ranges_name_the_key_the_value_and_the_range() {
        check_ranges(&outer(-2.9, 1.0, vec![3]), "t").unwrap();
        let e = check_ranges(&outer(50.0, 0.5, vec![]), "t").unwrap_err().to_string();
        assert_eq!(e, "config field 't.x': 50 is outside the valid range [-20, 2]");
        let e = check_ranges(&outer(0.0, 0.0, vec![]), "").unwrap_err().to_string();
        assert_eq!(e, "config field 'inner.p': 0 is outside the valid range (0, 1]");
        let e = check_ranges(&outer(0.0, f64::NAN, vec![]), "").unwrap_err().to_string();
        assert!(e.contains("'inner.p': is not a finite number") && e.contains("(0, 1]"), "{e}");
        let e = check_ranges(&outer(f64::INFINITY, 0.5, vec![]), "").unwrap_err().to_string();
        assert!(e.contains("'x'") && e.contains("not a finite number"), "{e}");
        let e = check_ranges(&outer(0.0, 0.5, vec![2, 0]), "").unwrap_err().to_string();
        assert_eq!(e, "config field 'inner.widths[1]': 0 is outside the valid range [1, ∞)");
    }

    #[test]
    fn range_texts() {
        let root = root_schema::<Outer>();
        let defs = SchemaDefs::of(&root);
        let props = &root["properties"];
        assert_eq!(range_text(&props["x"]).as_deref(), Some("[-20, 2]"));
        let inner = defs.resolve(&props["inner"]);
        assert_eq!(range_text(&inner["properties"]["p"]).as_deref(), Some("(0, 1]"));
        assert_eq!(range_text(&inner["properties"]["widths"]).as_deref(), Some("each in [1, ∞)"));
        assert_eq!(range_text(&serde_json::json!({"type": "number"})).as_deref(), Some("finite"));
        assert_eq!(range_text(&serde_json::json!({"type": "string"})), None);
        assert_eq!(capped_threads(0, "k"), 0);
        assert!(
            capped_threads(100_000, "k")
                <= 4 * std::thread::available_parallelism().map_or(1, |n| n.get())
        );
    }
}
