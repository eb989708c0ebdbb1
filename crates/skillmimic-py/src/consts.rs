//! Module-level constants and configuration helpers of `skillmimic_rs._core`: the tables the
//! Python package would otherwise copy by hand (observation layout, reward-term and metric names,
//! dimensions) and the config-file reader shared with the CLI (`skillmimic_learn::config_file`).

use std::path::PathBuf;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::config_file;

/// The `[env]` fields that the TOML file `path` sets, as a JSON object, with relative paths
/// resolved by the CLI's rule (`skillmimic_learn::config_file`). A file with an `[env]`, `[ppo]`
/// or `[run]` table gives its `[env]` table; a file with none of them, its top-level keys.
#[pyfunction]
fn load_env_config(path: PathBuf) -> PyResult<String> {
    let env =
        config_file::load_env_table(&path).map_err(|e| PyValueError::new_err(e.to_string()))?;
    serde_json::to_string(&env).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The whole training configuration that `skillmimic train --preset PRESET --config PATH` starts
/// from (before command-line flags), as JSON.
#[pyfunction]
#[pyo3(signature = (path, preset = "small"))]
fn load_train_config(path: PathBuf, preset: &str) -> PyResult<String> {
    let base = TrainConfig::preset(preset).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let cfg = config_file::load_train_config(&base, &path)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    serde_json::to_string(&cfg).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Resolve one path written in a config file whose folder is `config_dir` (the CLI's rule).
#[pyfunction]
fn resolve_config_path(written: PathBuf, config_dir: PathBuf) -> String {
    config_file::resolve_path(&written, &config_dir).to_string_lossy().into_owned()
}

/// Every registered character (`env.character`) by name, in listing order, with what a user
/// building a policy or an action array by hand needs: `act_dim` (the action width: one entry per
/// driven dof, the same for every hand model; welded fingers ignore theirs), `proprio_dim` (the
/// width of its proprioception block, before any task part), `num_bodies` (including the root),
/// `hands` (the hand models it comes in, `env.hands`), `ballplay` (whether BallPlay-M clips play
/// on it as they are) and `summary`.
fn characters(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    use skillmimic_core::characters::{Character, REGISTERED};
    let out = PyDict::new(py);
    for entry in REGISTERED {
        let spec = Character::new(entry, entry.hands[0]).spec();
        let row = PyDict::new(py);
        row.set_item("act_dim", spec.num_dofs)?;
        row.set_item("proprio_dim", spec.proprio_dim())?;
        row.set_item("num_bodies", spec.num_bodies())?;
        row.set_item("hands", PyTuple::new(py, entry.hands.iter().map(|h| h.name()))?)?;
        row.set_item("ballplay", entry.ballplay)?;
        row.set_item("summary", entry.summary)?;
        out.set_item(entry.name, row)?;
    }
    Ok(out)
}

/// Add the constants and helper functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let blocks = PyDict::new(py);
    for (name, r) in skillmimic_env::obs::BLOCKS.iter() {
        blocks.set_item(*name, (r.start, r.end))?;
    }
    m.add("OBS_BLOCKS", blocks)?;
    m.add("HUMANOID_DIM", skillmimic_env::obs::layout::HUMANOID_DIM)?;
    m.add("STATE_DIM", skillmimic_env::obs::layout::STATE_DIM)?;
    m.add("ACT_DIM", skillmimic_core::characters::skillmimic::NUM_DOFS)?;
    m.add("CHARACTERS", characters(py)?)?;
    m.add("HISTORY_FEATURE_DIM", skillmimic_env::v2::history::FEATURE_DIM)?;
    m.add("TERM_NAMES", PyTuple::new(py, skillmimic_env::reward::TERM_NAMES)?)?;
    m.add("FRAME_METRIC_NAMES", PyTuple::new(py, skillmimic_env::FRAME_METRIC_NAMES)?)?;
    m.add("TASKS", PyTuple::new(py, skillmimic_env::registry::names())?)?;
    let high: Vec<&str> = skillmimic_env::registry::TASKS
        .iter()
        .filter(|t| t.high_level.is_some())
        .map(|t| t.name)
        .collect();
    m.add("HIGH_LEVEL_TASKS", PyTuple::new(py, high)?)?;
    m.add(
        "POLICY_FAMILIES",
        PyTuple::new(py, skillmimic_learn::policies::FAMILIES.iter().map(|f| f.name()))?,
    )?;
    m.add(
        "CONFIG_PATH_KEYS",
        PyTuple::new(py, config_file::ENV_PATH_KEYS.iter().map(|k| k.join(".")))?,
    )?;
    m.add_function(wrap_pyfunction!(load_env_config, m)?)?;
    m.add_function(wrap_pyfunction!(load_train_config, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_config_path, m)?)?;
    Ok(())
}
