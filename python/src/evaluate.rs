//! `hevo.evaluate`: many genomes of one template on the same samples, through the path
//! `hevo eval` takes: the post-evaluation samples of (task, samples, seed), a request to the
//! engine's dispatcher served by the local worker pool, and the post-evaluation report of each
//! genome's outcomes. So `evaluate(template, genomes, task, samples=S, seed=K)` gives, for each
//! genome, exactly the numbers `hevo eval CONTROLLER --samples S --seed K --json` prints for
//! the template filled with that genome, and each sample's outcome as arrays. The inputs
//! ([`EvaluationInput`]) and the reduction of outcomes to the result ([`Columns`]) are shared
//! with `hevo.Client.evaluate`, which has the master's workers evaluate the same samples.
//!
//! Memory: genomes go to the dispatcher in chunks, at most two in flight, and each chunk's
//! per-sample outcomes are reduced to its rows of the result arrays as soon as it is in, so
//! 10,000 genomes hold their result arrays (19 bytes per genome and sample for the per-sample
//! outcomes, and 4 per descriptor value) and a chunk's summaries, never every sample's summary.

use crate::controller::Controller;
use crate::task::Task;
use crate::{ControllerError, RunError};
use hevo_engine::dispatch::{DispatchError, EvaluationRequest, RequestShared};
use hevo_engine::post_evaluation::{self, EvalReport};
use hevo_sim_core::{ControllerFile, Ending, Sample, SampleSummary, TaskConfig};
use numpy::ndarray::{Array2, Array3};
use numpy::{PyArray1, PyArray2, PyArray3, PyUntypedArrayMethods};
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
/// reached it); `descriptor` the behaviour descriptor, each value the mean over the samples.
/// The `sample_*` arrays are each sample's outcome, shape (n, samples), columns in the order
/// of `sample_seeds`.
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
    /// The behaviour descriptor, each value the mean over the samples (what a strategy is told
    /// in `hevo run`): float64 (n, len(descriptor_names)).
    #[pyo3(get)]
    descriptor: Py<PyArray2<f64>>,
    /// Each sample's fitness: float32 (n, samples).
    #[pyo3(get)]
    sample_fitness: Py<PyArray2<f32>>,
    /// Whether each sample was solved: bool (n, samples).
    #[pyo3(get)]
    sample_solved: Py<PyArray2<bool>>,
    /// Whether the robot touched a wall or obstacle in each sample: bool (n, samples).
    #[pyo3(get)]
    sample_collided: Py<PyArray2<bool>>,
    /// Cycles each sample ran: uint32 (n, samples).
    #[pyo3(get)]
    sample_cycles: Py<PyArray2<u32>>,
    /// The furthest stage each sample reached: uint8 (n, samples).
    #[pyo3(get)]
    sample_stage: Py<PyArray2<u8>>,
    /// Why each sample ended, as an index into `ending_names`: uint8 (n, samples).
    #[pyo3(get)]
    sample_ending: Py<PyArray2<u8>>,
    /// Each sample's behaviour descriptor: float32 (n, samples, len(descriptor_names)).
    #[pyo3(get)]
    sample_descriptor: Py<PyArray3<f32>>,
    /// Each sample's variant (light configuration, start branch): uint32 (n, samples).
    #[pyo3(get)]
    sample_variant: Py<PyArray2<u32>>,
    /// The samples' seeds, the columns of the `sample_*` arrays: uint64 (samples,).
    /// `hevo.trace(controller, task, seed=s, variant=v)` replays one.
    #[pyo3(get)]
    sample_seeds: Py<PyArray1<u64>>,
    /// The variants' names (columns of `per_variant`).
    #[pyo3(get)]
    variant_names: Vec<String>,
    /// The stages' names (columns of `per_stage`).
    #[pyo3(get)]
    stage_names: Vec<String>,
    /// The phases' names (columns of `per_phase`).
    #[pyo3(get)]
    phase_names: Vec<String>,
    /// The descriptor's quantities (columns of `descriptor`): the scenario's `[descriptor]`,
    /// `["final.x", "final.y"]` unless it says otherwise.
    #[pyo3(get)]
    descriptor_names: Vec<String>,
    /// What the codes of `sample_ending` stand for: the endings as a trace's outcome names
    /// them, `["solved", "collision", "wrong_branch", "timeout"]`.
    #[pyo3(get)]
    ending_names: Vec<&'static str>,
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

/// What `hevo.evaluate` and `hevo.Client.evaluate` take, checked and converted: the template,
/// the task, the genomes as float32 rows, and the samples every genome runs on.
#[derive(Debug)]
pub(crate) struct EvaluationInput {
    pub(crate) template: ControllerFile,
    pub(crate) task: TaskConfig,
    /// One genome of the free node per row.
    pub(crate) rows: Vec<Arc<[f32]>>,
    /// The samples themselves.
    pub(crate) sample_list: Arc<[Sample]>,
    node_paths: Vec<String>,
}

impl EvaluationInput {
    /// Checks the template (it has a free node that fits the task's robot), the genomes (see
    /// [`crate::genomes::genome_rows`]) and the sample count.
    pub(crate) fn new(
        template: &Controller,
        genomes: &Bound<'_, PyAny>,
        task: &Task,
        samples: u32,
        seed: u64,
        clip: bool,
    ) -> PyResult<EvaluationInput> {
        let template = template.file.clone();
        let task = task.config.clone();
        let Some((free_path, topology)) = template.free_node_topology() else {
            return Err(ControllerError::new_err(
                "the template has no free node: every node has its genome. Take one out with \
                 controller.without_genome(node) to evaluate genomes for it",
            ));
        };
        let rows = crate::genomes::genome_rows(genomes, topology.n_genes(), &free_path, clip)?;
        if samples == 0 {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "samples must be at least 1",
            ));
        }
        hevo_sim_core::Evaluator::new(task.clone())
            .map_err(|error| crate::ConfigError::new_err(crate::message(&error)))?;
        hevo_sim_core::controller_fits(&template, &task.scenario)
            .map_err(|problem| ControllerError::new_err(format!("the template {problem}")))?;
        let sample_list = post_evaluation::post_evaluation_samples(&task, samples, seed).into();
        Ok(EvaluationInput {
            node_paths: template.node_paths(),
            template,
            task,
            rows,
            sample_list,
        })
    }

    /// Empty result columns for these genomes.
    pub(crate) fn columns(&self) -> Columns {
        Columns::with_capacity(self.rows.len(), self.sample_list.len())
    }

    /// Adds one genome's outcomes (one per sample, in sample order) to `columns`.
    pub(crate) fn reduce(&self, columns: &mut Columns, summaries: &[SampleSummary]) {
        let report = post_evaluation::report(&self.task, summaries, &self.node_paths);
        columns.push(&report, summaries);
    }

    /// The finished columns as an `Evaluation`.
    pub(crate) fn evaluation(&self, py: Python<'_>, columns: Columns) -> PyResult<Evaluation> {
        let n = self.rows.len();
        let variant_names = if self.task.scenario.n_variants() > 1 {
            self.task
                .scenario
                .variants
                .iter()
                .map(|variant| variant.name.clone())
                .collect()
        } else {
            Vec::new()
        };
        let n_samples = self.sample_list.len();
        let descriptor_names: Vec<String> = self
            .task
            .scenario
            .descriptor_names()
            .into_iter()
            .map(str::to_string)
            .collect();
        let n_descriptor = descriptor_names.len();
        let sample_descriptor =
            Array3::from_shape_vec((n, n_samples, n_descriptor), columns.sample_descriptor)
                .map_err(|error| RunError::new_err(format!("internal: result shape: {error}")))?;
        let seeds: Vec<u64> = self.sample_list.iter().map(|sample| sample.seed).collect();
        Ok(Evaluation {
            fitness: PyArray1::from_vec(py, columns.fitness).unbind(),
            solve_rate: PyArray1::from_vec(py, columns.solve_rate).unbind(),
            collision_rate: PyArray1::from_vec(py, columns.collision_rate).unbind(),
            mean_cycles: PyArray1::from_vec(py, columns.mean_cycles).unbind(),
            per_variant: matrix(py, n, columns.per_variant)?.unbind(),
            per_stage: matrix(py, n, columns.per_stage)?.unbind(),
            per_phase: matrix(py, n, columns.per_phase)?.unbind(),
            descriptor: shaped(py, n, n_descriptor, columns.descriptor)?.unbind(),
            sample_fitness: shaped(py, n, n_samples, columns.sample_fitness)?.unbind(),
            sample_solved: shaped(py, n, n_samples, columns.sample_solved)?.unbind(),
            sample_collided: shaped(py, n, n_samples, columns.sample_collided)?.unbind(),
            sample_cycles: shaped(py, n, n_samples, columns.sample_cycles)?.unbind(),
            sample_stage: shaped(py, n, n_samples, columns.sample_stage)?.unbind(),
            sample_ending: shaped(py, n, n_samples, columns.sample_ending)?.unbind(),
            sample_descriptor: PyArray3::from_owned_array(py, sample_descriptor).unbind(),
            sample_variant: shaped(py, n, n_samples, columns.sample_variant)?.unbind(),
            sample_seeds: PyArray1::from_vec(py, seeds).unbind(),
            variant_names,
            stage_names: columns.stage_names,
            phase_names: columns.phase_names,
            descriptor_names,
            ending_names: Ending::ALL.iter().map(|ending| ending.name()).collect(),
            samples: n_samples as u32,
        })
    }
}

/// The result arrays as they fill, a row per genome.
#[derive(Debug)]
pub(crate) struct Columns {
    fitness: Vec<f64>,
    solve_rate: Vec<f64>,
    collision_rate: Vec<f64>,
    mean_cycles: Vec<f64>,
    per_variant: Vec<f64>,
    per_stage: Vec<f64>,
    per_phase: Vec<f64>,
    descriptor: Vec<f64>,
    sample_fitness: Vec<f32>,
    sample_solved: Vec<bool>,
    sample_collided: Vec<bool>,
    sample_cycles: Vec<u32>,
    sample_stage: Vec<u8>,
    sample_variant: Vec<u32>,
    sample_ending: Vec<u8>,
    sample_descriptor: Vec<f32>,
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
    fn with_capacity(n_genomes: usize, n_samples: usize) -> Columns {
        let cells = n_genomes.saturating_mul(n_samples);
        Columns {
            fitness: Vec::with_capacity(n_genomes),
            solve_rate: Vec::with_capacity(n_genomes),
            collision_rate: Vec::with_capacity(n_genomes),
            mean_cycles: Vec::with_capacity(n_genomes),
            per_variant: Vec::new(),
            per_stage: Vec::new(),
            per_phase: Vec::new(),
            descriptor: Vec::new(),
            sample_fitness: Vec::with_capacity(cells),
            sample_solved: Vec::with_capacity(cells),
            sample_collided: Vec::with_capacity(cells),
            sample_cycles: Vec::with_capacity(cells),
            sample_stage: Vec::with_capacity(cells),
            sample_variant: Vec::with_capacity(cells),
            sample_ending: Vec::with_capacity(cells),
            sample_descriptor: Vec::new(),
            stage_names: Vec::new(),
            phase_names: Vec::new(),
        }
    }

    fn push(&mut self, report: &EvalReport, summaries: &[SampleSummary]) {
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
        self.descriptor
            .extend(hevo_engine::runner::mean_descriptor(summaries));
        for summary in summaries {
            self.sample_fitness.push(summary.fitness);
            self.sample_solved.push(summary.solved);
            self.sample_collided.push(summary.collided);
            self.sample_cycles.push(summary.cycles);
            self.sample_stage.push(summary.stage);
            self.sample_variant.push(summary.variant);
            self.sample_ending.push(summary.ending.code());
            self.sample_descriptor.extend(&summary.descriptor);
        }
    }
}

/// `values` as a matrix of `rows` rows (and no columns when there are no rows).
fn matrix<'py, T: numpy::Element>(
    py: Python<'py>,
    rows: usize,
    values: Vec<T>,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let columns = values.len().checked_div(rows).unwrap_or(0);
    shaped(py, rows, columns, values)
}

/// `values` as a `rows` x `columns` matrix.
fn shaped<'py, T: numpy::Element>(
    py: Python<'py>,
    rows: usize,
    columns: usize,
    values: Vec<T>,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let array = Array2::from_shape_vec((rows, columns), values)
        .map_err(|error| RunError::new_err(format!("internal: result shape: {error}")))?;
    Ok(PyArray2::from_owned_array(py, array))
}

/// Evaluates each row of `genomes` (shape (n, template.n_genes), any float dtype: float64
/// rounds to the nearest float32) as the genome of the template's free node, on `samples`
/// samples per variant of `task` drawn from `seed` (the samples of `hevo eval --samples S
/// --seed K`), on `threads` threads (default: every core), with the GIL released. Genes
/// outside [-10, 10] are clipped to it with `clip=True` and refused otherwise (ControllerError
/// naming the row and gene); NaN and infinity are refused either way. Returns an Evaluation:
/// per genome the numbers `hevo eval --json` prints for the template filled with it, bit for
/// bit, and each sample's outcome. Ctrl-C stops it and raises KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (template, genomes, task, samples=50, seed=0, threads=None, clip=false))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    py: Python<'_>,
    template: &Controller,
    genomes: &Bound<'_, PyAny>,
    task: &Task,
    samples: u32,
    seed: u64,
    threads: Option<usize>,
    clip: bool,
) -> PyResult<Evaluation> {
    let input = EvaluationInput::new(template, genomes, task, samples, seed, clip)?;
    let threads = crate::thread_count(threads);
    let shared = Arc::new(RequestShared::new(
        input.template.clone(),
        input.task.clone(),
    ));
    let dispatcher = hevo_engine::local::local_dispatcher(threads);
    let stopper = dispatcher.clone();

    let outcome = crate::interrupt::run_interruptibly(
        py,
        |_events| {
            hevo_engine::local::run_local(dispatcher, threads, async |dispatcher| {
                let mut columns = input.columns();
                let mut in_flight = VecDeque::new();
                let reduce = |columns: &mut Columns, results: Vec<Vec<SampleSummary>>| {
                    for summaries in results {
                        input.reduce(columns, &summaries);
                    }
                };
                for chunk in input.rows.chunks(CHUNK_GENOMES) {
                    let request = EvaluationRequest {
                        job: "python".into(),
                        shared: shared.clone(),
                        genomes: chunk.to_vec(),
                        samples: input.sample_list.clone(),
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
    input.evaluation(py, columns)
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
