//! `hevo.Strategy`: hevo's search algorithms (the paper's GA, CMA-ES, novelty search and any
//! other `hevo_evolve` strategy) in the ask/tell style over numpy arrays, so a notebook can
//! drive them around `hevo.evaluate` or `hevo.Client.evaluate`. The settings are an experiment
//! file's `[evolution]` table, read by the engine's own reader
//! ([`hevo_engine::experiment::evolution_from_table`]): the same keys, defaults, checks and
//! messages, and every algorithm the file knows works here without a change to this file. A
//! strategy's whole state (its settings, seed and the algorithm's state) is JSON text, so a
//! saved strategy resumed asks for the genomes the uninterrupted one asks for, bit for bit.

use crate::ConfigError;
use hevo_engine::experiment::{
    DEFAULT_MAP_ELITES_BINS, evolution_from_table, evolution_table_from_toml,
};
use hevo_evolve::{Evaluation, StrategySettings, StrategyState};
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyString};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Mutex;

/// The format tag of a saved strategy.
const FORMAT: &str = "hevo.strategy/1";

/// Where settings come from, in messages (an experiment file's name stands there otherwise).
const SETTINGS_SOURCE: &str = "hevo.Strategy settings";

/// The most genes a genome may have: the largest network a controller file allows, with room.
const MAX_GENES: usize = 1_000_000;

/// A saved strategy: everything that determines what it asks for from here on.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Saved {
    format: String,
    /// The `[evolution]` table's keys as given (read again on resuming, by the same reader).
    settings: serde_json::Value,
    n_genes: usize,
    seed: u64,
    /// The fitness the strategy's best genome was told with, once it has one.
    best_fitness: Option<f64>,
    strategy: StrategyState,
}

/// The strategy and what the binding keeps beside it.
#[derive(Debug)]
struct Inner {
    strategy: Box<dyn hevo_evolve::Strategy>,
    best_fitness: Option<f64>,
}

/// One of hevo's search algorithms with ask/tell over numpy arrays.
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Strategy {
    settings: serde_json::Value,
    strategy_settings: StrategySettings,
    n_genes: usize,
    seed: u64,
    inner: Mutex<Inner>,
}

fn config_error(error: &dyn std::error::Error) -> PyErr {
    ConfigError::new_err(crate::message(error))
}

/// The settings table given as a dict, TOML text or nothing, with `algorithm` and the keyword
/// keys over it.
fn settings_table(
    algorithm: Option<&str>,
    settings: Option<&Bound<'_, PyAny>>,
    keys: Option<&Bound<'_, PyDict>>,
) -> PyResult<serde_json::Value> {
    let source = Path::new(SETTINGS_SOURCE);
    let mut table = match settings {
        None => serde_json::Value::Object(serde_json::Map::new()),
        Some(text) if text.is_instance_of::<PyString>() => {
            evolution_table_from_toml(&text.extract::<String>()?, source)
                .map_err(|error| config_error(&error))?
        }
        Some(dict) if dict.is_instance_of::<PyDict>() => crate::python_to_json(dict)?,
        Some(other) => {
            return Err(PyTypeError::new_err(format!(
                "settings must be a dict or the TOML text of an [evolution] table, got a {}",
                other.get_type().name()?
            )));
        }
    };
    let serde_json::Value::Object(entries) = &mut table else {
        return Err(ConfigError::new_err("settings must be a table of keys"));
    };
    if let Some(algorithm) = algorithm {
        entries.insert("algorithm".into(), algorithm.into());
    }
    if let Some(keys) = keys
        && let serde_json::Value::Object(keys) = crate::python_to_json(keys.as_any())?
    {
        entries.extend(keys);
    }
    Ok(table)
}

/// The settings a table gives, read as an experiment file's `[evolution]` table is.
/// MAP-Elites' grid has no task here to count the descriptor's values: its ranges (required, as
/// in a file) count them, and bins left out are the file's default per value, filled in before
/// the reader checks the grid.
fn strategy_settings(table: &serde_json::Value) -> PyResult<StrategySettings> {
    let mut table = table.clone();
    if let serde_json::Value::Object(keys) = &mut table
        && keys.get("algorithm").and_then(|a| a.as_str()) == Some("map_elites")
    {
        let Some(n_values) = keys
            .get("map_elites_ranges")
            .and_then(|ranges| ranges.as_array())
            .map(Vec::len)
        else {
            return Err(ConfigError::new_err(format!(
                "{SETTINGS_SOURCE}: at `evolution.map_elites_ranges`: required: the range \
                 [lo, hi] of each descriptor value to cut into bins (a Strategy has no task, so \
                 the ranges also say how many values a descriptor has)"
            )));
        };
        keys.entry("map_elites_bins")
            .or_insert_with(|| serde_json::json!(vec![DEFAULT_MAP_ELITES_BINS; n_values]));
    }
    let params = evolution_from_table(table, Path::new(SETTINGS_SOURCE))
        .map_err(|error| config_error(&error))?;
    Ok(params.strategy_settings())
}

fn check_n_genes(n_genes: usize) -> PyResult<()> {
    if n_genes == 0 || n_genes > MAX_GENES {
        return Err(PyValueError::new_err(format!(
            "n_genes must be 1 to {MAX_GENES}, got {n_genes}"
        )));
    }
    Ok(())
}

/// `value` as float64 values of an array of `ndim` dimensions (any float dtype; float32 and
/// float16 exactly), with its shape; `name` names it in errors.
fn float64_array(
    value: &Bound<'_, PyAny>,
    name: &str,
    ndim: usize,
) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let array = crate::genomes::float_array(value, name, |shape| {
        if shape.len() == ndim {
            Ok(())
        } else {
            Err(PyValueError::new_err(format!(
                "{name} must be {ndim}-D, got shape {shape:?}"
            )))
        }
    })?;
    let array = array
        .call_method1("astype", ("float64",))?
        .extract::<PyReadonlyArrayDyn<'_, f64>>()?;
    Ok((
        array.shape().to_vec(),
        array.as_array().iter().copied().collect(),
    ))
}

/// The genomes as a float64 (n, n_genes) array (each float32 gene exactly).
fn genomes_array<'py>(
    py: Python<'py>,
    genomes: &[Vec<f32>],
    n_genes: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let values = genomes
        .iter()
        .flat_map(|genome| genome.iter().map(|&gene| f64::from(gene)))
        .collect();
    let array = Array2::from_shape_vec((genomes.len(), n_genes), values)
        .map_err(|error| PyValueError::new_err(format!("internal: genome shape: {error}")))?;
    Ok(PyArray2::from_owned_array(py, array))
}

impl Strategy {
    fn inner(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic cannot leave the state half-changed (tell checks before it changes).
        self.inner
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

#[pymethods]
impl Strategy {
    /// A new strategy for genomes of `n_genes` genes, every draw from `seed`. The settings are
    /// an experiment file's `[evolution]` table ([experiment-file.md]): `settings` as a dict
    /// or TOML text, `algorithm` ("ga", "cmaes", "novelty", ...) and keyword keys over it:
    /// `Strategy("cmaes", n_genes=30, seed=7, population=20, cmaes_variant="separable")`.
    /// Keys, defaults and messages are the file's (ConfigError naming `evolution.KEY`).
    #[new]
    #[pyo3(signature = (algorithm=None, *, n_genes, seed=0, settings=None, **keys))]
    fn new(
        algorithm: Option<&str>,
        n_genes: usize,
        seed: u64,
        settings: Option<&Bound<'_, PyAny>>,
        keys: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        check_n_genes(n_genes)?;
        let table = settings_table(algorithm, settings, keys)?;
        let strategy_settings = strategy_settings(&table)?;
        let strategy = strategy_settings
            .start(n_genes, seed)
            .map_err(|error| config_error(&error))?;
        Ok(Strategy {
            settings: table,
            strategy_settings,
            n_genes,
            seed,
            inner: Mutex::new(Inner {
                strategy,
                best_fitness: None,
            }),
        })
    }

    /// The algorithm's name, as an experiment file writes it.
    #[getter]
    fn algorithm(&self) -> &'static str {
        self.strategy_settings.algorithm()
    }

    /// Genes per genome.
    #[getter]
    fn n_genes(&self) -> usize {
        self.n_genes
    }

    /// The seed every draw comes from.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// Generations told so far: the generation `ask()`'s genomes belong to.
    #[getter]
    fn generation(&self) -> u32 {
        self.inner().strategy.generation()
    }

    /// The settings table as given (algorithm and keyword keys included), as a dict.
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json_to_python(py, &self.settings)
    }

    /// The genomes to evaluate next: float64 (n, n_genes), each gene a float32 value exactly
    /// (so `genomes.astype(np.float32)` and `hevo.evaluate` see the strategy's own genes),
    /// within the settings' `gene_range`. Asking again before telling gives the same genomes.
    fn ask<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let inner = self.inner();
        genomes_array(py, inner.strategy.ask(), self.n_genes)
    }

    /// Tells the results of `ask()`'s genomes, in its order: `fitness` (n,) and, for the
    /// algorithms that search behaviours (novelty), `descriptors` (n, d), both of any float
    /// dtype (larger fitness is better). The strategy then moves to the next generation. A
    /// wrong shape, NaN or infinity is refused (ValueError naming the row) and changes nothing.
    #[pyo3(signature = (fitness, descriptors=None))]
    fn tell(
        &self,
        py: Python<'_>,
        fitness: &Bound<'_, PyAny>,
        descriptors: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let mut inner = self.inner();
        let n_asked = inner.strategy.ask().len();
        let (shape, fitness) = float64_array(fitness, "fitness", 1)?;
        if shape[0] != n_asked {
            return Err(PyValueError::new_err(format!(
                "fitness has {} value(s) for the {n_asked} genomes ask() gave",
                shape[0]
            )));
        }
        if let Some(row) = fitness.iter().position(|f| !f.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "fitness[{row}] (row {row} of the batch) is {:?}: fitness must be finite",
                fitness[row]
            )));
        }
        let descriptors = match descriptors {
            None => vec![Vec::new(); n_asked],
            Some(descriptors) => {
                let (shape, values) = float64_array(descriptors, "descriptors", 2)?;
                if shape[0] != n_asked {
                    return Err(PyValueError::new_err(format!(
                        "descriptors has {} row(s) for the {n_asked} genomes ask() gave",
                        shape[0]
                    )));
                }
                let n_columns = shape[1];
                if let Some(idx) = values.iter().position(|v| !v.is_finite()) {
                    let (row, column) = (idx / n_columns, idx % n_columns);
                    return Err(PyValueError::new_err(format!(
                        "descriptors[{row}, {column}] (row {row} of the batch) is {:?}: \
                         descriptors must be finite",
                        values[idx]
                    )));
                }
                if n_columns == 0 {
                    vec![Vec::new(); n_asked]
                } else {
                    values.chunks(n_columns).map(<[f64]>::to_vec).collect()
                }
            }
        };
        let results: Vec<Evaluation> = fitness
            .iter()
            .zip(descriptors)
            .map(|(&fitness, descriptor)| Evaluation::with_descriptor(fitness, descriptor))
            .collect();
        let asked: Vec<Vec<f32>> = inner.strategy.ask().to_vec();
        let Inner {
            strategy,
            best_fitness,
        } = &mut *inner;
        // Large full-covariance updates take a while: the GIL is not needed for them.
        py.detach(|| strategy.tell(&results))
            .map_err(|error| PyValueError::new_err(error.to_string()))?;
        // The best genome is one asked for at some generation: when it is one of these, its
        // fitness is the highest told for it here; else it is older and keeps its fitness.
        if let Some(best) = strategy.best()
            && let Some(told) = asked
                .iter()
                .zip(&fitness)
                .filter(|(genome, _)| genome.as_slice() == best)
                .map(|(_, &fitness)| fitness)
                .reduce(f64::max)
        {
            *best_fitness = Some(told);
        }
        Ok(())
    }

    /// The genome the strategy offers as its result so far, as (float64 genes, the fitness it
    /// was told with); None before the first `tell`.
    #[getter]
    fn best<'py>(&self, py: Python<'py>) -> Option<(Bound<'py, PyArray1<f64>>, f64)> {
        let inner = self.inner();
        let genes: Vec<f64> = inner
            .strategy
            .best()?
            .iter()
            .map(|&gene| f64::from(gene))
            .collect();
        Some((PyArray1::from_vec(py, genes), inner.best_fitness?))
    }

    /// A MAP-Elites strategy's archive now, as a dict: `cells` (the grid's), `filled`,
    /// `coverage` (filled / cells), `qd_score` (the elites' fitness summed, pyribs' with offset
    /// 0), `best`, and per elite in cell order `cell` (int64), `fitness` (float64),
    /// `descriptor` (float64 (n, d)) and `genes` (float64 (n, n_genes)); None for the
    /// algorithms without one.
    #[getter]
    fn archive<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let inner = self.inner();
        let Some(grid) = inner.strategy.grid() else {
            return Ok(None);
        };
        let elites: Vec<_> = grid.elites().collect();
        let n_dims = grid.bins().len();
        let dict = PyDict::new(py);
        let cells = grid.n_cells();
        dict.set_item("cells", cells)?;
        dict.set_item("filled", elites.len())?;
        dict.set_item("coverage", elites.len() as f64 / cells as f64)?;
        dict.set_item("qd_score", elites.iter().map(|e| e.fitness).sum::<f64>())?;
        dict.set_item("best", grid.best().map(|e| e.fitness))?;
        let cell: Vec<i64> = elites.iter().map(|e| e.cell as i64).collect();
        dict.set_item("cell", PyArray1::from_vec(py, cell))?;
        let fitness: Vec<f64> = elites.iter().map(|e| e.fitness).collect();
        dict.set_item("fitness", PyArray1::from_vec(py, fitness))?;
        let descriptor: Vec<f64> = elites
            .iter()
            .flat_map(|e| e.descriptor.iter().copied())
            .collect();
        let descriptor = Array2::from_shape_vec((elites.len(), n_dims), descriptor)
            .map_err(|error| PyValueError::new_err(format!("internal: archive: {error}")))?;
        dict.set_item("descriptor", PyArray2::from_owned_array(py, descriptor))?;
        let genes: Vec<Vec<f32>> = elites.iter().map(|e| e.genes.clone()).collect();
        dict.set_item("genes", genomes_array(py, &genes, self.n_genes)?)?;
        Ok(Some(dict))
    }

    /// The whole state as JSON text (UTF-8 bytes): the settings, the seed and the algorithm's
    /// state. `Strategy.from_state` continues it exactly as this strategy continues.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let inner = self.inner();
        let saved = Saved {
            format: FORMAT.into(),
            settings: self.settings.clone(),
            n_genes: self.n_genes,
            seed: self.seed,
            best_fitness: inner.best_fitness,
            strategy: inner.strategy.state(),
        };
        let text = serde_json::to_vec(&saved)
            .map_err(|error| PyValueError::new_err(format!("internal: state: {error}")))?;
        Ok(PyBytes::new(py, &text))
    }

    /// A strategy continued from `state()`'s text (bytes or str). ConfigError when it is not
    /// one, or its settings or state do not fit.
    #[staticmethod]
    fn from_state(state: &Bound<'_, PyAny>) -> PyResult<Strategy> {
        let text: Vec<u8> = if let Ok(text) = state.extract::<String>() {
            text.into_bytes()
        } else if let Ok(bytes) = state.cast::<PyBytes>() {
            bytes.as_bytes().to_vec()
        } else {
            return Err(PyTypeError::new_err(format!(
                "state must be the bytes or str Strategy.state() gives, got a {}",
                state.get_type().name()?
            )));
        };
        let saved: Saved = serde_json::from_slice(&text)
            .map_err(|error| ConfigError::new_err(format!("not a saved hevo.Strategy: {error}")))?;
        if saved.format != FORMAT {
            return Err(ConfigError::new_err(format!(
                "a saved strategy of format '{}', this hevo reads '{FORMAT}'",
                saved.format
            )));
        }
        check_n_genes(saved.n_genes)?;
        let strategy_settings = strategy_settings(&saved.settings)?;
        let strategy = strategy_settings
            .resume(saved.n_genes, saved.strategy)
            .map_err(|error| config_error(&error))?;
        if saved.best_fitness.is_some_and(|f| !f.is_finite())
            || saved.best_fitness.is_some() != strategy.best().is_some()
        {
            return Err(ConfigError::new_err(
                "the saved state does not fit: best_fitness and the best genome disagree",
            ));
        }
        Ok(Strategy {
            settings: saved.settings,
            strategy_settings,
            n_genes: saved.n_genes,
            seed: saved.seed,
            inner: Mutex::new(Inner {
                strategy,
                best_fitness: saved.best_fitness,
            }),
        })
    }

    fn __repr__(&self) -> String {
        let inner = self.inner();
        format!(
            "Strategy('{}', n_genes={}, seed={}, generation={}, population={})",
            self.algorithm(),
            self.n_genes,
            self.seed,
            inner.strategy.generation(),
            inner.strategy.ask().len()
        )
    }
}
