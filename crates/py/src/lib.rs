//! The foosball table for Python: the extension module `foosball_rl._core`.
//!
//! - [`table::Table`]: one [`foosball_env::FoosballEnv`] (Gymnasium's `Env` is built on
//!   it in `python/foosball_rl/env.py`).
//! - [`vec_table::VecTable`]: N tables stepped in parallel by the Rust
//!   [`foosball_env::VecEnv`] with the GIL released, batches handed over as numpy arrays
//!   (`python/foosball_rl/vector.py` makes it a Gymnasium `VectorEnv`).
//! - [`settings`]: a [`foosball_env::FoosballConfig`] from a preset name, a TOML file and
//!   keyword overrides, refused by dotted key.
//! - [`episode`]: the paper's per-episode metrics, tallied as the steps go.
//! - [`standard_test`]: the paper's 1,000-episode test of a Python policy, the same
//!   starts, metrics and intervals as the framework's `evaluate`.
//! - [`to_python`]: shapes, infos, metrics and frames as Python objects.
//! - [`errors`]: the Python exceptions, and the guard that turns a Rust panic into one.
//!
//! Python is an optional front: nothing of the training framework depends on this crate.

pub mod episode;
pub mod errors;
pub mod settings;
pub mod standard_test;
pub mod table;
pub mod to_python;
pub mod vec_table;

use foosball_env::seeding;
use pyo3::prelude::*;

/// The extension module: the two classes, the exceptions, the preset names and the
/// seeding of the Rust framework.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<table::Table>()?;
    m.add_class::<vec_table::VecTable>()?;
    m.add("ConfigError", py.get_type::<errors::ConfigError>())?;
    m.add("ActionError", py.get_type::<errors::ActionError>())?;
    m.add("ResetNeeded", py.get_type::<errors::ResetNeeded>())?;
    let presets: Vec<&str> = foosball_env::Preset::ALL.iter().map(|p| p.name()).collect();
    m.add("PRESETS", presets)?;
    m.add(
        "END_REASONS",
        foosball_env::EndReason::ALL.map(|e| e.name()).to_vec(),
    )?;
    m.add_function(wrap_pyfunction!(derive_seed, m)?)?;
    m.add_function(wrap_pyfunction!(standard_test::standard_test, m)?)?;
    m.add("TRAIN_ENVS", seeding::TRAIN_ENVS)?;
    m.add("EVAL_ENVS", seeding::EVAL_ENVS)?;
    m.add("TEST_ENVS", seeding::TEST_ENVS)?;
    Ok(())
}

/// The seed of item `index` of stream `stream` under run seed `run_seed`, as every
/// random stream of the Rust framework derives (e.g. test episode `i` of a run:
/// `derive_seed(seed, TEST_ENVS, i)`).
#[pyfunction]
fn derive_seed(run_seed: u64, stream: u64, index: u64) -> u64 {
    seeding::derive_seed(run_seed, stream, index)
}
