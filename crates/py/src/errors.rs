//! The exceptions Python sees, and [`guarded`], which keeps Rust panics out of Python.

use std::panic::{AssertUnwindSafe, catch_unwind};

use foosball_env::{EnvError, VecEnvError};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _core,
    ConfigError,
    PyValueError,
    "A setting of the table was refused; the message names its dotted key (or the file)."
);
create_exception!(
    _core,
    ActionError,
    PyValueError,
    "An action was refused: wrong shape, or a value that is NaN or infinite."
);
create_exception!(
    _core,
    ResetNeeded,
    PyRuntimeError,
    "step() before reset(), or after the episode ended."
);

/// The Python exception of a refused step.
pub fn env_error(e: &EnvError) -> PyErr {
    match e {
        EnvError::NeedsReset => ResetNeeded::new_err(e.to_string()),
        EnvError::ActionDim { .. } | EnvError::NonFiniteAction { .. } => {
            ActionError::new_err(e.to_string())
        }
        EnvError::ResetOption { .. } => PyValueError::new_err(e.to_string()),
    }
}

/// The Python exception of a refused batch.
pub fn vec_env_error(e: &VecEnvError) -> PyErr {
    match e {
        VecEnvError::Env { source, .. } => match source {
            EnvError::NeedsReset => ResetNeeded::new_err(e.to_string()),
            _ => ActionError::new_err(e.to_string()),
        },
        VecEnvError::BatchSize { .. } => ActionError::new_err(e.to_string()),
        VecEnvError::NotReset => ResetNeeded::new_err(e.to_string()),
        VecEnvError::Setup(_) => PyValueError::new_err(e.to_string()),
    }
}

/// Runs `f`, turning a panic into a `RuntimeError` that says it is a bug of this package
/// (PyO3 would raise `PanicException`, a `BaseException` that `except Exception` misses).
pub fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        Err(PyRuntimeError::new_err(format!(
            "internal error in foosball_rl (a bug; please report it): {message}"
        )))
    })
}
