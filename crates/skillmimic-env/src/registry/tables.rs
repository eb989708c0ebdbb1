//! The registered configuration tables as one [`TaskTables`] value: defaults, parsing of the
//! `[env.<key>]` tables (unknown keys refused, naming the registered ones) and the schema of the
//! configuration reference.

use super::TASKS;
use crate::config_table::{TableEntry, TaskTables};

/// Every registered configuration table, once each, in listing order of the tasks that read it.
pub fn tables() -> Vec<&'static TableEntry> {
    let mut out: Vec<&'static TableEntry> = Vec::new();
    for t in TASKS.iter().flat_map(|e| e.tables) {
        if !out.iter().any(|o| o.key == t.key) {
            out.push(t);
        }
    }
    out
}

/// Every registered table at its defaults.
impl Default for TaskTables {
    fn default() -> Self {
        TaskTables(tables().into_iter().map(|e| (e.key, (e.default)())).collect())
    }
}

/// The `[env]` keys that are not the driver's or the imitation task's: each must be a registered
/// table (the message lists them); a table's own keys are checked by its type.
impl<'de> serde::Deserialize<'de> for TaskTables {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let given = toml::Table::deserialize(d)?;
        let mut out = TaskTables::default();
        let all = tables();
        for (key, value) in given {
            let Some(entry) = all.iter().find(|e| e.key == key) else {
                let keys: Vec<&str> = all.iter().map(|e| e.key).collect();
                return Err(D::Error::custom(format!(
                    "unknown field `{key}`: not a key of [env] nor a task's table ({})",
                    keys.join(", ")
                )));
            };
            let table =
                (entry.parse)(value).map_err(|e| D::Error::custom(format!("[env.{key}]: {e}")))?;
            let slot = out.0.iter_mut().find(|(k, _)| *k == key).expect("every table is defaulted");
            slot.1 = table;
        }
        Ok(out)
    }
}

/// One property per registered table (with its one-line description), for the configuration
/// reference and the range checks.
impl schemars::JsonSchema for TaskTables {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "TaskTables".into()
    }
    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let mut props = serde_json::Map::new();
        for e in tables() {
            let mut s = (e.schema)(generator).to_value();
            if let Some(o) = s.as_object_mut() {
                o.insert("description".into(), e.doc.into());
            }
            props.insert(e.key.to_string(), s);
        }
        schemars::json_schema!({ "type": "object", "properties": props })
    }
}

#[cfg(test)]
mod tests {
    use crate::config::EnvConfig;

    #[test]
    fn task_tables_load_from_their_keys_and_unknown_keys_are_named() {
        use crate::tasks::hlc::config::HlcConfig;
        use crate::tasks::hsi::config::HsiConfig;
        use crate::tasks::stand::StandConfig;
        // the layout saved configurations of every earlier version use
        let c: EnvConfig = toml::from_str(
            "task = \"stand\"\n[stand]\nstart_height = 0.95\nepisode_length = 7\n[hlc]\nllc_steps \
                = 2\n[hsi.follow]\nepisode_length = 9\n",
        )
        .unwrap();
        assert_eq!(c.table::<StandConfig>().episode_length, 7);
        assert_eq!(c.table::<StandConfig>().start_height, 0.95);
        assert_eq!(c.table::<HlcConfig>().llc_steps, 2);
        assert_eq!(c.table::<HsiConfig>().follow.episode_length, 9);
        // written back and read again: the same configuration
        let text = toml::to_string(&c).unwrap();
        assert_eq!(toml::from_str::<EnvConfig>(&text).unwrap(), c);
        let e = toml::from_str::<EnvConfig>("[juggle]\nballs = 3\n").unwrap_err().to_string();
        assert!(
            e.contains("unknown field `juggle`") && e.contains("stand") && e.contains("hlc"),
            "{e}"
        );
        let e = toml::from_str::<EnvConfig>("[stand]\nhieght = 3\n").unwrap_err().to_string();
        assert!(e.contains("[env.stand]") && e.contains("hieght"), "{e}");
    }
}
