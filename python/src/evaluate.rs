//! `hevo.evaluate`: many genomes of one template on the same samples, through the path
//! `hevo eval` takes: the post-evaluation samples of (task, samples, seed), a request to the
//! engine's dispatcher served by the local worker pool, and the post-evaluation report of each
//! genome's outcomes. So `evaluate(template, genomes, task, samples=S, seed=K)` gives, for each
//! genome, exactly the numbers `hevo eval CONTROLLER --samples S --seed K --json` prints for
//! the template filled with that genome.
//!
//! Memory: genomes go to the dispatcher in chunks, at most two in flight, and each chunk's
//! per-sample outcomes are reduced to its rows of the result arrays as soon as it is in, so
//! 10,000 genomes hold their result arrays and a chunk's outcomes, never every sample's.

use crate::controller::Controller;
use crate::task::Task;
use crate::{ControllerError, RunError};
use hevo_engine::dispatch::{DispatchError, EvaluationRequest, RequestShared};
use hevo_engine::post_evaluation::{self, EvalReport};
use hevo_sim_core::Sample;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

/// Genomes per request to the dispatcher: enough for every worker to get several batches,
/// few enough that a request's per-sample outcomes stay small.
const CHUNK_GENOMES: usize = 256;

/// The results of `hevo.evaluate`, one row per genome. The per-genome numbers are the keys of
/// `hevo eval --json`: `fitness` is its `mean_fitness`, then `solve_rate`, `collision_rate`,
/// `mean_cycles`; `per_variant[:, v]` is `per_variant[v].solve_rate`; `per_stage` the share of
/// samples that reached each stage (`stages` for the rescue, `per_stage` for other scenarios);
/// `per_phase` the share of right choices per phase of a derived fitness (NaN where no sample
/// reached it).
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Evaluation {
    /// Mean fitness over the samples, per genome: float64 (n,).
    #[pyo3(get)]
    fitness: Py<PyArray1<f64>>,
    /// Share of samples solved, per genome: float64 (n,).
    #[pyo3(get)]
    solve_rate: Py<PyArray1<f64>>,
    /// Share of samples with a collision, per genome: float64 (n,).
    #[pyo3(get)]
    collision_rate: Py<PyArray1<f64>>,
    /// Mean cycles per sample, per genome: float64 (n,).
    #[pyo3(get)]
    mean_cycles: Py<PyArray1<f64>>,
    /// Solve rate per variant: float64 (n, n_variants); (n, 0) for a task with one variant.
    #[pyo3(get)]
    per_variant: Py<PyArray2<f64>>,
    /// Share that reached each stage: float64 (n, len(stage_names)).
    #[pyo3(get)]
    per_stage: Py<PyArray2<f64>>,
    /// Share of right choices per phase of a derived fitness: float64 (n, len(phase_names)).
    #[pyo3(get)]
    per_phase: Py<PyArray2<f64>>,
    /// The variants' names (columns of `per_variant`).
    #[pyo3(get)]
    variant_names: Vec<String>,
    /// The stages' names (columns of `per_stage`).
    #[pyo3(get)]
    stage_names: Vec<String>,
    /// The phases' names (columns of `per_phase`).
    #[pyo3(get)]
    phase_names: Vec<String>,
    /// Samples each genome ran (samples per variant times variants).
    #[pyo3(get)]
    samples: u32,
}

#[pymethods]
impl Evaluation {
    fn __len__(&self, py: Python<'_>) -> usize {
        self.fitness.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Evaluation({} genome(s) x {} sample(s))",
            self.__len__(py),
            self.samples
        )
    }
}

/// The result arrays as they fill, a row per genome.
#[derive(Debug)]
struct Columns {
    fitness: Vec<f64>,
    solve_rate: Vec<f64>,
    collision_rate: Vec<f64>,
    mean_cycles: Vec<f64>,
    per_variant: Vec<f64>,
    per_stage: Vec<f64>,
    per_phase: Vec<f64>,
    stage_names: Vec<String>,
    phase_names: Vec<String>,
}

/// A report's stage shares and their names: the rescue's three, or a scenario's own.
fn stages_of(report: &EvalReport) -> (Vec<String>, Vec<f64>) {
    match &report.stages {
        Some(stages) => (
            vec![
                "exited_room".into(),
                "reached_teammate".into(),
                "returned".into(),
            ],
            vec![stages.exited_room, stages.reached_teammate, stages.returned],
        ),
        None => report
            .per_stage
            .iter()
            .map(|share| (share.stage.clone(), share.share))
            .unzip(),
    }
}

/// A report's phase shares and their names: the rescue's three sub-tasks, or a scenario's.
fn phases_of(report: &EvalReport) -> (Vec<String>, Vec<f64>) {
    report
        .phase_shares()
        .iter()
        .map(|phase| (phase.phase.clone(), phase.right_choice.unwrap_or(f64::NAN)))
        .unzip()
}

impl Columns {
    fn with_capacity(n: usize) -> Columns {
        Columns {
            fitness: Vec::with_capacity(n),
            solve_rate: Vec::with_capacity(n),
            collision_rate: Vec::with_capacity(n),
            mean_cycles: Vec::with_capacity(n),
            per_variant: Vec::new(),
            per_stage: Vec::new(),
            per_phase: Vec::new(),
            stage_names: Vec::new(),
            phase_names: Vec::new(),
        }
    }

    fn push(&mut self, report: &EvalReport) {
        self.fitness.push(report.mean_fitness);
        self.solve_rate.push(report.solve_rate);
        self.collision_rate.push(report.collision_rate);
        self.mean_cycles.push(report.mean_cycles);
        self.per_variant
            .extend(report.per_variant.iter().map(|variant| variant.solve_rate));
        let (stage_names, stages) = stages_of(report);
        self.per_stage.extend(stages);
        self.stage_names = stage_names;
        let (phase_names, phases) = phases_of(report);
        self.per_phase.extend(phases);
        self.phase_names = phase_names;
    }
}

fn matrix<'py>(
    py: Python<'py>,
    rows: usize,
    values: Vec<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let columns = values.len().checked_div(rows).unwrap_or(0);
    let array = Array2::from_shape_vec((rows, columns), values)
        .map_err(|error| RunError::new_err(format!("internal: result shape: {error}")))?;
    Ok(PyArray2::from_owned_array(py, array))
}

/// Evaluates each row of `genomes` (float32, shape (n, template.n_genes)) as the genome of the
/// template's free node, on `samples` samples per variant of `task` drawn from `seed` (the
/// samples of `hevo eval --samples S --seed K`), on `threads` threads (default: every core),
/// with the GIL released. Returns an Evaluation: per genome the numbers `hevo eval --json`
/// prints for the template filled with it, bit for bit. Ctrl-C stops it and raises
/// KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (template, genomes, task, samples=50, seed=0, threads=None))]
pub fn evaluate(
    py: Python<'_>,
    template: &Controller,
    genomes: PyReadonlyArray2<'_, f32>,
    task: &Task,
    samples: u32,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<Evaluation> {
    let template = template.file.clone();
    let task = task.config.clone();
    let Some((free_path, topology)) = template.free_node_topology() else {
        return Err(ControllerError::new_err(
            "the template has no free node: every node has its genome. Take one out with \
             controller.without_genome(node) to evaluate genomes for it",
        ));
    };
    let n_genes = topology.n_genes();
    let shape = genomes.shape();
    if shape[1] != n_genes {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "genomes has {} column(s), but the free node '{free_path}' takes {n_genes} genes",
            shape[1]
        )));
    }
    if samples == 0 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "samples must be at least 1",
        ));
    }
    hevo_sim_core::Evaluator::new(task.clone())
        .map_err(|error| crate::ConfigError::new_err(crate::message(&error)))?;
    hevo_sim_core::controller_fits(&template, &task.scenario)
        .map_err(|problem| ControllerError::new_err(format!("the template {problem}")))?;
    let rows: Vec<Arc<[f32]>> = genomes
        .as_array()
        .rows()
        .into_iter()
        .map(|row| row.iter().copied().collect::<Vec<f32>>().into())
        .collect();
    let n = rows.len();
    let threads = crate::thread_count(threads);
    let sample_list: Arc<[Sample]> =
        post_evaluation::post_evaluation_samples(&task, samples, seed).into();
    let n_samples = sample_list.len() as u32;
    let node_paths = template.node_paths();
    let variant_names = if task.scenario.n_variants() > 1 {
        task.scenario
            .variants
            .iter()
            .map(|variant| variant.name.clone())
            .collect()
    } else {
        Vec::new()
    };
    let shared = Arc::new(RequestShared::new(template, task.clone()));
    let dispatcher = hevo_engine::local::local_dispatcher(threads);
    let stopper = dispatcher.clone();

    let outcome = crate::interrupt::run_interruptibly(
        py,
        |_events| {
            hevo_engine::local::run_local(dispatcher, threads, async |dispatcher| {
                let mut columns = Columns::with_capacity(n);
                let mut in_flight = VecDeque::new();
                let reduce =
                    |columns: &mut Columns, results: Vec<Vec<hevo_sim_core::SampleSummary>>| {
                        for summaries in results {
                            columns.push(&post_evaluation::report(&task, &summaries, &node_paths));
                        }
                    };
                for chunk in rows.chunks(CHUNK_GENOMES) {
                    let request = EvaluationRequest {
                        job: "python".into(),
                        shared: shared.clone(),
                        genomes: chunk.to_vec(),
                        samples: sample_list.clone(),
                    };
                    in_flight.push_back(dispatcher.submit(request, Instant::now()));
                    // Two in flight: the workers start on the next chunk while this thread
                    // reduces the last one.
                    if in_flight.len() >= 2
                        && let Some(pending) = in_flight.pop_front()
                    {
                        reduce(&mut columns, pending.wait().await?);
                    }
                }
                while let Some(pending) = in_flight.pop_front() {
                    reduce(&mut columns, pending.wait().await?);
                }
                Ok::<_, DispatchError>(columns)
            })
        },
        || stopper.shut_down(),
        |_py, ()| Ok(()),
    )?;
    let columns = outcome
        .map_err(|error| RunError::new_err(format!("cannot start the async runtime: {error}")))?
        .map_err(|error| match error {
            DispatchError::Failed(message) => ControllerError::new_err(message),
            other => RunError::new_err(crate::message(&other)),
        })?;
    Ok(Evaluation {
        fitness: PyArray1::from_vec(py, columns.fitness).unbind(),
        solve_rate: PyArray1::from_vec(py, columns.solve_rate).unbind(),
        collision_rate: PyArray1::from_vec(py, columns.collision_rate).unbind(),
        mean_cycles: PyArray1::from_vec(py, columns.mean_cycles).unbind(),
        per_variant: matrix(py, n, columns.per_variant)?.unbind(),
        per_stage: matrix(py, n, columns.per_stage)?.unbind(),
        per_phase: matrix(py, n, columns.per_phase)?.unbind(),
        variant_names,
        stage_names: columns.stage_names,
        phase_names: columns.phase_names,
        samples: n_samples,
    })
}

/// The controller `hevo bench` measures a task with (the paper's network sizes for its tasks),
/// with random genes drawn from `seed`; `hevo bench --pipeline` evaluates perturbed copies of
/// its root's genome.
#[pyfunction]
#[pyo3(signature = (task, seed=1))]
pub fn bench_controller(task: &Task, seed: u64) -> Controller {
    Controller {
        file: hevo_engine::bench::paper_controller(&task.config, seed),
    }
}
