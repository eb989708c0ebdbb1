//! Configuration tables owned by tasks: a task (or a family of tasks) defines its options as a
//! struct next to its code, implements [`TaskConfig`] (its key under `[env]` and a one-line
//! description) and lists [`TableEntry::of`] it in its registry line. [`EnvConfig`] holds every
//! registered table ([`TaskTables`]) without naming any: `[env.<key>]` in TOML, typed access
//! with [`EnvConfig::table`] / [`EnvConfig::table_mut`], unknown keys still refused, the
//! generated reference still lists every key.
//!
//! The list of registered tables is the registry's (`crate::registry::TABLES`); this module only
//! knows how one table is defaulted, parsed, written and described.
//!
//! [`EnvConfig`]: crate::config::EnvConfig
//! [`EnvConfig::table`]: crate::config::EnvConfig::table
//! [`EnvConfig::table_mut`]: crate::config::EnvConfig::table_mut

use std::any::Any;
use std::fmt::Debug;

use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The options of a task (or a family of tasks): `[env.<KEY>]`.
pub trait TaskConfig:
    Serialize
    + DeserializeOwned
    + JsonSchema
    + Clone
    + Default
    + PartialEq
    + Debug
    + Send
    + Sync
    + 'static
{
    /// The table's key under `[env]`.
    const KEY: &'static str;
    /// One line for the configuration reference ("Options of the `stand` task").
    const DOC: &'static str;
}

/// A table of any registered type.
pub trait AnyTable: Debug + Send + Sync {
    fn clone_box(&self) -> Box<dyn AnyTable>;
    fn eq_dyn(&self, other: &dyn AnyTable) -> bool;
    /// The table as a TOML value (what is written into saved configurations).
    fn to_toml(&self) -> Result<toml::Value, String>;
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: TaskConfig> AnyTable for T {
    fn clone_box(&self) -> Box<dyn AnyTable> {
        Box::new(self.clone())
    }
    fn eq_dyn(&self, other: &dyn AnyTable) -> bool {
        other.as_any().downcast_ref::<T>() == Some(self)
    }
    fn to_toml(&self) -> Result<toml::Value, String> {
        toml::Value::try_from(self).map_err(|e| e.to_string())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// How one registered table is defaulted, parsed and described.
#[derive(Clone, Copy)]
pub struct TableEntry {
    /// The key under `[env]`.
    pub key: &'static str,
    /// One line for the configuration reference.
    pub doc: &'static str,
    pub(crate) default: fn() -> Box<dyn AnyTable>,
    pub(crate) parse: fn(toml::Value) -> Result<Box<dyn AnyTable>, String>,
    pub(crate) schema: fn(&mut SchemaGenerator) -> Schema,
}

impl std::fmt::Debug for TableEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TableEntry({})", self.key)
    }
}

fn default_of<T: TaskConfig>() -> Box<dyn AnyTable> {
    Box::new(T::default())
}

fn parse_of<T: TaskConfig>(v: toml::Value) -> Result<Box<dyn AnyTable>, String> {
    v.try_into::<T>().map(|t| Box::new(t) as Box<dyn AnyTable>).map_err(|e| e.message().to_string())
}

fn schema_of<T: TaskConfig>(generator: &mut SchemaGenerator) -> Schema {
    generator.subschema_for::<T>()
}

impl TableEntry {
    /// The entry of table type `T`.
    pub const fn of<T: TaskConfig>() -> Self {
        Self {
            key: T::KEY,
            doc: T::DOC,
            default: default_of::<T>,
            parse: parse_of::<T>,
            schema: schema_of::<T>,
        }
    }
}

/// Every registered table of a configuration, in registry order (see the module doc). Its
/// `Default`, `Deserialize` and `JsonSchema` come from the registry's table list
/// (`crate::registry`).
#[derive(Debug)]
pub struct TaskTables(pub(crate) Vec<(&'static str, Box<dyn AnyTable>)>);

impl Clone for TaskTables {
    fn clone(&self) -> Self {
        Self(self.0.iter().map(|(k, t)| (*k, t.clone_box())).collect())
    }
}

impl PartialEq for TaskTables {
    fn eq(&self, other: &Self) -> bool {
        self.0.len() == other.0.len()
            && self.0.iter().zip(&other.0).all(|((a, x), (b, y))| a == b && x.eq_dyn(y.as_ref()))
    }
}

impl Serialize for TaskTables {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::{Error, SerializeMap};
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, t) in &self.0 {
            m.serialize_entry(k, &t.to_toml().map_err(S::Error::custom)?)?;
        }
        m.end()
    }
}

impl TaskTables {
    /// The table of type `T` (a registered table is always present).
    pub fn get<T: TaskConfig>(&self) -> &T {
        self.0
            .iter()
            .find(|(k, _)| *k == T::KEY)
            .and_then(|(_, t)| t.as_any().downcast_ref::<T>())
            .unwrap_or_else(|| panic!("configuration table `{}` is not registered", T::KEY))
    }
    /// The table of type `T`, mutably.
    pub fn get_mut<T: TaskConfig>(&mut self) -> &mut T {
        self.0
            .iter_mut()
            .find(|(k, _)| *k == T::KEY)
            .and_then(|(_, t)| t.as_any_mut().downcast_mut::<T>())
            .unwrap_or_else(|| panic!("configuration table `{}` is not registered", T::KEY))
    }
}
