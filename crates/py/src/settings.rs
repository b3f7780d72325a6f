//! A [`FoosballConfig`] the way Python callers give it: a preset name, a TOML file and
//! keyword overrides, each layer over the one before.
//!
//! The file is either a run configuration (`configs/*.toml`: its `[env]` section is
//! taken) or a bare table of env keys. Overrides are nested dicts
//! (`rules={"end_on_goal": True}`) or dotted keys (`{"rules.end_on_goal": True}`). Every
//! refusal names its dotted key, or the file.

use std::path::Path;

use foosball_env::FoosballConfig;
use foosball_env::config::overlay;
use foosball_env::config_file;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::Deserialize;
use toml::{Table, Value};

use crate::errors::ConfigError;

/// The table's configuration from `preset`, then `file`, then `overrides` (the later
/// layer wins), validated.
pub fn resolve(
    preset: Option<&str>,
    file: Option<&Path>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<FoosballConfig> {
    let mut table = match file {
        Some(path) => read_env_table(path)?,
        None => Table::new(),
    };
    if let Some(preset) = preset {
        table.insert("preset".into(), Value::String(preset.into()));
    }
    if let Some(overrides) = overrides {
        for (key, value) in overrides.iter() {
            let key: String = key
                .extract()
                .map_err(|_| ConfigError::new_err(format!("override key {key} is not a string")))?;
            let value = to_toml(&value, &key)?;
            insert_dotted(&mut table, &key, value)?;
        }
    }
    let config = <FoosballConfig as Deserialize>::deserialize(Value::Table(table))
        .map_err(|e| ConfigError::new_err(e.message().trim().to_string()))?;
    config
        .validate()
        .map_err(|e| ConfigError::new_err(e.to_string()))?;
    Ok(config)
}

/// The env keys of a TOML file (merged with the files it `extends`): its `[env]` section,
/// or the whole file when it has none.
fn read_env_table(path: &Path) -> PyResult<Table> {
    let shown = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConfigError::new_err(format!("cannot read config file {shown}: {e}")))?;
    let layers =
        config_file::layers(&text, path).map_err(|e| ConfigError::new_err(e.to_string()))?;
    let mut table: Table = match layers {
        Some(layers) => layers.merged,
        None => text
            .parse()
            .map_err(|e| ConfigError::new_err(format!("config file {shown}: {e}")))?,
    };
    match table.remove("env") {
        Some(Value::Table(env)) => Ok(env),
        Some(_) => Err(ConfigError::new_err(format!(
            "config file {shown}: `env` must be a table"
        ))),
        None => Ok(table),
    }
}

/// Puts `value` at the dotted `key`, merging into tables already there.
fn insert_dotted(table: &mut Table, key: &str, value: Value) -> PyResult<()> {
    let mut parts = key.split('.').peekable();
    let mut at = table;
    let mut walked = String::new();
    while let Some(part) = parts.next() {
        if part.is_empty() {
            return Err(ConfigError::new_err(format!(
                "override key `{key}` has an empty part"
            )));
        }
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(part);
        if parts.peek().is_none() {
            let mut top = Table::new();
            top.insert(part.into(), value);
            overlay(at, top);
            return Ok(());
        }
        let next = at.entry(part).or_insert_with(|| Value::Table(Table::new()));
        at = next
            .as_table_mut()
            .ok_or_else(|| ConfigError::new_err(format!("`{walked}` is a value, not a section")))?;
    }
    Ok(())
}

/// A Python value as TOML: bool, int, float, str, list/tuple, dict (numpy scalars too).
fn to_toml(value: &Bound<'_, PyAny>, key: &str) -> PyResult<Value> {
    if value.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() {
        let i: i64 = value
            .extract()
            .map_err(|_| ConfigError::new_err(format!("`{key}`: {value} does not fit 64 bits")))?;
        return Ok(Value::Integer(i));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(value.extract()?));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(Value::String(s.to_cow()?.into()));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut table = Table::new();
        for (k, v) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| ConfigError::new_err(format!("`{key}`: key {k} is not a string")))?;
            let v = to_toml(&v, &format!("{key}.{k}"))?;
            insert_dotted(&mut table, &k, v)?;
        }
        return Ok(Value::Table(table));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items = value
            .try_iter()?
            .enumerate()
            .map(|(i, item)| to_toml(&item?, &format!("{key}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(Value::Array(items));
    }
    // numpy scalars and other numbers: integers through __index__, reals through __float__.
    if value.hasattr("__index__")? {
        return Ok(Value::Integer(value.extract()?));
    }
    if let Ok(f) = value.extract::<f64>() {
        return Ok(Value::Float(f));
    }
    Err(ConfigError::new_err(format!(
        "`{key}`: {} is not a TOML value (bool, int, float, str, list or dict)",
        value.get_type().name()?
    )))
}
