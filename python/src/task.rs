//! `hevo.Task`: what a controller is evaluated on. A shipped scenario by name
//! (`Task("solve_maze")`) or a scenario file (`Task("path/to/mine.toml")`), with keyword
//! overrides shaped like an experiment node's `task_config` table
//! (`Task("follow_wall", max_cycles=500, robot={"v_max": 0.08})`), read and checked by the
//! engine's task inputs, exactly as `hevo eval --task` and experiment files read them.

use crate::ConfigError;
use hevo_sim_core::TaskConfig;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A task: a scenario (the world, its variants, what ends a sample and its fitness) and every
/// number of the model in force.
#[pyclass(module = "hevo")]
#[derive(Debug, Clone)]
pub struct Task {
    pub(crate) config: TaskConfig,
}

#[pymethods]
impl Task {
    /// `name` is a shipped scenario (see `hevo.shipped_tasks()`) or a scenario file (a path
    /// ending in .toml). Keyword arguments override settings as an experiment node's
    /// `task_config` table does: `max_cycles=500`, `end_on_collision=False`,
    /// `robot={"v_max": 0.08}`. Raises ConfigError naming the key and what was expected.
    #[new]
    #[pyo3(signature = (name, **overrides))]
    fn new(name: std::path::PathBuf, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        // A str or a path object (a scenario file); the engine tells names and files apart.
        let name = name.to_string_lossy();
        let name = name.as_ref();
        let task = hevo_engine::inputs::task_by_name(name)
            .map_err(|error| ConfigError::new_err(crate::message(&error)))?;
        let config = match overrides {
            Some(overrides) if !overrides.is_empty() => {
                let overrides = crate::python_to_json(overrides.as_any())?;
                hevo_engine::inputs::task_with_overrides(task, overrides, name)
                    .map_err(|error| ConfigError::new_err(crate::message(&error)))?
            }
            _ => task,
        };
        Ok(Task { config })
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> String {
        self.config.name().to_string()
    }

    /// The cycle limit of a sample.
    #[getter]
    fn max_cycles(&self) -> u32 {
        self.config.max_cycles()
    }

    /// The variants a sample can be (light configurations, start branches); one for a task
    /// without.
    #[getter]
    fn n_variants(&self) -> u32 {
        self.config.scenario.n_variants()
    }

    /// The variants' names, in order.
    #[getter]
    fn variant_names(&self) -> Vec<String> {
        self.config
            .scenario
            .variants
            .iter()
            .map(|variant| variant.name.clone())
            .collect()
    }

    /// Every setting as a dict (the task's wire form: the scenario, then the numbers).
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let value = serde_json::to_value(&self.config)
            .map_err(|error| ConfigError::new_err(error.to_string()))?;
        crate::json_to_python(py, &value)
    }

    fn __repr__(&self) -> String {
        format!("Task('{}')", self.config.name())
    }
}
