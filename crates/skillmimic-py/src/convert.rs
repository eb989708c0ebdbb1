//! Argument checks and array helpers shared by the binding modules.

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A `ValueError` with the message of `e`.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A `ValueError` naming `name` unless `got == want`.
pub(crate) fn check_shape(name: &str, got: &[usize], want: &[usize]) -> PyResult<()> {
    if got != want {
        return Err(PyValueError::new_err(format!("{name}: expected shape {want:?}, got {got:?}")));
    }
    Ok(())
}

/// A new `(rows, cols)` float32 array holding `data`.
pub(crate) fn to_2d<'py>(
    py: Python<'py>,
    data: &[f32],
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    PyArray1::from_slice(py, data).reshape([rows, cols])
}

/// Run `f` with the GIL released and turn a panic inside it into an ordinary `RuntimeError`
/// naming `what` (pyo3 would raise `PanicException`, a `BaseException` that `except Exception`
/// does not catch). A panic is a bug of this package, never a user mistake: user mistakes are
/// `ValueError`s returned by `f`.
pub(crate) fn detach_guarded<T: Send>(
    py: Python<'_>,
    what: &str,
    f: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))).map_err(|p| {
        pyo3::exceptions::PyRuntimeError::new_err(format!(
            "internal error in {what}: {} (a bug of skillmimic-rs; please report it)",
            skillmimic_core::panic_message(&*p)
        ))
    })
}
