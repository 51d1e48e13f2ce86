//! `hevo.run`: an experiment evolved bottom-up by the engine's resumable runner, as `hevo run`
//! does it (the same runner, dispatcher and local worker pool, so the same files bit for bit).
//! Progress events go to a Python callback on the caller's thread; Ctrl-C stops the run
//! between writes (every output is written atomically), and calling `run` again with the same
//! arguments resumes it from the last finished generation.

use crate::interrupt::Mailbox;
use crate::{ConfigError, RunError};
use hevo_engine::experiment::{Experiment, ExperimentError};
use hevo_engine::runner::{self, Overrides, Progress, ProgressEvent, RunSettings};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Hands the runner's events to the waiting Python thread.
struct Forward<'a, T> {
    mailbox: &'a Mailbox<ProgressEvent, T>,
}

impl<T: Send> Progress for Forward<'_, T> {
    fn event(&self, event: &ProgressEvent) {
        self.mailbox.post(event.clone());
    }
}

fn experiment_error(error: &ExperimentError) -> PyErr {
    ConfigError::new_err(crate::message(error))
}

/// Evolves `experiment` (an experiment file's path) into `out`, resuming what is already
/// there, and returns each evolved node's summary as a dict (its runs, best run, solve rates).
/// `node` evolves only that node (after its children); `runs`, `generations` and `seed`
/// override the file's as `hevo run --runs/--generations/--seed` do. `progress`, if given, is
/// called with each event as a dict (`event` is `node_started`, `generation`, `run_finished`,
/// `node_finished` or `note`). Ctrl-C stops the run and raises KeyboardInterrupt; the same call
/// again continues it.
#[pyfunction]
#[pyo3(signature = (experiment, out, node=None, threads=None, progress=None, runs=None, generations=None, seed=None))]
#[allow(clippy::too_many_arguments)]
pub fn run<'py>(
    py: Python<'py>,
    experiment: PathBuf,
    out: PathBuf,
    node: Option<String>,
    threads: Option<usize>,
    progress: Option<Bound<'py, PyAny>>,
    runs: Option<u32>,
    generations: Option<u32>,
    seed: Option<u64>,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let experiment = Experiment::load(&experiment).map_err(|error| experiment_error(&error))?;
    let settings = RunSettings {
        out_dir: out,
        overrides: Overrides {
            node,
            runs,
            generations,
            seed,
        },
        job: "local".into(),
    };
    settings
        .overrides
        .validate()
        .map_err(|error| ConfigError::new_err(crate::message(&error)))?;
    if let Some(node) = &settings.overrides.node {
        experiment
            .named_node(node)
            .map_err(|error| experiment_error(&error))?;
    }
    let threads = crate::thread_count(threads);
    let dispatcher = hevo_engine::local::local_dispatcher(threads);
    let stopper = dispatcher.clone();
    let outcome = crate::interrupt::run_interruptibly(
        py,
        |mailbox| {
            let forward = Forward { mailbox };
            hevo_engine::local::run_local(dispatcher, threads, async |dispatcher| {
                runner::run_experiment(&experiment, &settings, dispatcher, &forward).await
            })
        },
        || stopper.shut_down(),
        |py, event| {
            if let Some(callback) = &progress {
                let value = serde_json::to_value(&event)
                    .map_err(|error| RunError::new_err(error.to_string()))?;
                callback.call1((crate::json_to_python(py, &value)?,))?;
            }
            Ok(())
        },
    )?;
    let summaries = outcome
        .map_err(|error| RunError::new_err(format!("cannot start the async runtime: {error}")))?
        .map_err(|error| match &error {
            runner::RunError::Experiment(inner) => experiment_error(inner),
            runner::RunError::Override(_) => ConfigError::new_err(crate::message(&error)),
            _ => RunError::new_err(crate::message(&error)),
        })?;
    summaries
        .iter()
        .map(|summary| {
            let value = serde_json::to_value(summary)
                .map_err(|error| RunError::new_err(error.to_string()))?;
            crate::json_to_python(py, &value)
        })
        .collect()
}
