//! hevo for Python: the `hevo._hevo` extension module behind the `hevo` package. It binds the
//! engine the `hevo` command runs, not a copy of it: controllers are sim-core's controller
//! files, tasks the engine's task inputs, `evaluate` the dispatcher and local worker pool of
//! `hevo eval`, `trace` the evaluator of `hevo replay` and its SVG renderer, `run` the resumable
//! runner of `hevo run`, and `Client` the client calls of `hevo submit`, `watch`, `jobs`,
//! `fetch` and `cancel`. Long calls release the GIL; Ctrl-C stops them cleanly.

mod client;
mod controller;
mod env;
mod evaluate;
mod genomes;
mod interrupt;
mod run;
mod strategies;
mod task;
mod trace;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

create_exception!(
    hevo,
    HevoError,
    PyException,
    "The base of every error hevo raises; its message is the one the `hevo` command prints."
);
create_exception!(
    hevo,
    ConfigError,
    HevoError,
    "A task, scenario file or experiment file that cannot be used: the message names the file, the key and what was expected."
);
create_exception!(
    hevo,
    ControllerError,
    HevoError,
    "A controller file or genome that cannot be used: the message names the file and the node."
);
create_exception!(
    hevo,
    RunError,
    HevoError,
    "An evaluation or a run that could not finish (an output directory of another experiment, a file that cannot be written)."
);
create_exception!(
    hevo,
    ClientError,
    HevoError,
    "A master that refused a call or could not be reached."
);

/// The error's message with its causes, as the `hevo` command prints it after `error: `
/// (anyhow's alternate form: each cause after a colon).
pub(crate) fn message(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        text.push_str(": ");
        text.push_str(&cause.to_string());
        source = cause.source();
    }
    text
}

/// Every core, or `threads` when given (at least 1).
pub(crate) fn thread_count(threads: Option<usize>) -> usize {
    threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}

/// A JSON value as the Python value `json.loads` would make of it.
pub(crate) fn json_to_python<'py>(
    py: Python<'py>,
    value: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::IntoPyObjectExt;
    Ok(match value {
        serde_json::Value::Null => py.None().into_bound(py),
        serde_json::Value::Bool(flag) => flag.into_bound_py_any(py)?,
        serde_json::Value::Number(number) => match (number.as_i64(), number.as_u64()) {
            (Some(integer), _) => integer.into_bound_py_any(py)?,
            (None, Some(integer)) => integer.into_bound_py_any(py)?,
            _ => number.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)?,
        },
        serde_json::Value::String(text) => text.into_bound_py_any(py)?,
        serde_json::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_python(py, item)?)?;
            }
            list.into_any()
        }
        serde_json::Value::Object(entries) => {
            let dict = PyDict::new(py);
            for (key, item) in entries {
                dict.set_item(key, json_to_python(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// A Python value (dicts, lists, strings, numbers, booleans, None) as JSON, for task overrides.
pub(crate) fn python_to_json(value: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyString};
    if value.is_none() {
        return Ok(serde_json::Value::Null);
    }
    // bool before int: Python's True is an int too.
    if let Ok(flag) = value.cast::<PyBool>() {
        return Ok(serde_json::Value::Bool(flag.is_true()));
    }
    if value.cast::<PyInt>().is_ok() {
        if let Ok(integer) = value.extract::<i64>() {
            return Ok(integer.into());
        }
        return Ok(value.extract::<u64>()?.into());
    }
    if let Ok(number) = value.cast::<PyFloat>() {
        let number = number.value();
        return serde_json::Number::from_f64(number)
            .map(serde_json::Value::Number)
            .ok_or_else(|| ConfigError::new_err(format!("{number} is not a finite number")));
    }
    if value.cast::<PyString>().is_ok() {
        return Ok(serde_json::Value::String(value.extract::<String>()?));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        let mut object = serde_json::Map::new();
        for (key, item) in dict.iter() {
            object.insert(key.extract::<String>()?, python_to_json(&item)?);
        }
        return Ok(serde_json::Value::Object(object));
    }
    if let Ok(items) = value.try_iter() {
        let mut array = Vec::new();
        for item in items {
            array.push(python_to_json(&item?)?);
        }
        return Ok(serde_json::Value::Array(array));
    }
    Err(ConfigError::new_err(format!(
        "cannot use a {} as a setting (expected a number, string, boolean, list or dict)",
        value.get_type().name()?
    )))
}

/// The names of the shipped scenarios: what `Task(name)` takes besides a scenario file.
#[pyfunction]
fn shipped_tasks() -> Vec<String> {
    hevo_sim_core::Scenario::shipped_names()
        .into_iter()
        .map(str::to_string)
        .collect()
}

/// The extension module.
#[pymodule]
#[pyo3(name = "_hevo")]
fn hevo_module(module: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = module.py();
    module.add("HevoError", py.get_type::<HevoError>())?;
    module.add("ConfigError", py.get_type::<ConfigError>())?;
    module.add("ControllerError", py.get_type::<ControllerError>())?;
    module.add("RunError", py.get_type::<RunError>())?;
    module.add("ClientError", py.get_type::<ClientError>())?;
    module.add_class::<controller::Controller>()?;
    module.add_class::<task::Task>()?;
    module.add_class::<evaluate::Evaluation>()?;
    module.add_class::<trace::Trace>()?;
    module.add_class::<client::Client>()?;
    module.add_class::<client::JobWatch>()?;
    module.add_class::<env::Env>()?;
    module.add_class::<env::VectorEnv>()?;
    module.add_class::<env::Space>()?;
    module.add_class::<strategies::Strategy>()?;
    module.add_function(wrap_pyfunction!(shipped_tasks, module)?)?;
    module.add_function(wrap_pyfunction!(evaluate::evaluate, module)?)?;
    module.add_function(wrap_pyfunction!(evaluate::bench_controller, module)?)?;
    module.add_function(wrap_pyfunction!(trace::trace, module)?)?;
    module.add_function(wrap_pyfunction!(run::run, module)?)?;
    module.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // The range every gene of a controller file lies in (both ends included).
    module.add(
        "GENE_RANGE",
        (
            f64::from(hevo_sim_core::GENE_MIN),
            f64::from(hevo_sim_core::GENE_MAX),
        ),
    )?;
    Ok(())
}
