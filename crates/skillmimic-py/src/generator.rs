//! Python callables as clip generators of active skill learning
//! (`skillmimic_motion::generate::Callback`, registered by name for this process).

use std::path::Path;
use std::sync::Arc;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use skillmimic_motion::generate::{Callback, Generator, register};

/// Register `fn(failed_clip_path: str, out_dir: str) -> None` as the generator `name`
/// (`run.active.generator = "<name>"`): it reads the failed clip (project format) and writes new
/// clips as `*.safetensors` into `out_dir`; they are read back and pass the validity filter. An
/// exception fails the round with its text.
#[pyfunction]
pub(crate) fn register_generator(name: &str, callable: Py<PyAny>) -> PyResult<()> {
    let label = format!("python:{name}");
    let factory = Arc::new(move |work_dir: &Path| -> Box<dyn Generator> {
        let f = Python::attach(|py| callable.clone_ref(py));
        let run = move |input: &Path, out: &Path| -> Result<(), String> {
            Python::attach(|py| {
                f.call1(
                    py,
                    (input.to_string_lossy().into_owned(), out.to_string_lossy().into_owned()),
                )
                .map(|_| ())
                .map_err(|e| {
                    let tb = e.traceback(py).and_then(|t| t.format().ok()).unwrap_or_default();
                    format!("{tb}{e}")
                })
            })
        };
        Box::new(Callback::new(label.clone(), work_dir.join(name_dir(&label)), Box::new(run)))
    });
    register(name, factory).map_err(PyValueError::new_err)
}

fn name_dir(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect()
}
