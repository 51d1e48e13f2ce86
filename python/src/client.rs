//! `hevo.Client`: a master's job service from Python, through the client calls `hevo submit`,
//! `watch`, `jobs`, `fetch` and `cancel` make (`hevo_client`), with the same URL forms,
//! token, TLS and retries; and `evaluate`, `hevo.evaluate` on the master's workers (the same
//! inputs and reduction, `crate::evaluate`, so the same results bit for bit). Each call runs on a thread of its own and can be stopped with
//! Ctrl-C; `watch` is an iterator of the job's events that reconnects when the master
//! restarts, as `hevo watch` does.

use crate::controller::Controller;
use crate::evaluate::{Evaluation, EvaluationInput};
use crate::interrupt::Mailbox;
use crate::task::Task;
use crate::{ClientError, ConfigError};
use hevo_client as calls;
use hevo_engine::runner::Overrides;
use hevo_proto::client::ClientOptions;
use hevo_proto::v1;
use hevo_proto::v1::job_event::Event;
use pyo3::exceptions::PyStopIteration;
use pyo3::prelude::*;
use serde_json::json;
use std::path::PathBuf;
use std::sync::Arc;
use tokio::sync::Notify;

/// A job's status as a dict-to-be: the keys of `hevo jobs`' columns.
fn job_info(info: &v1::JobInfo) -> serde_json::Value {
    json!({
        "job_id": info.job_id,
        "state": calls::state_name(info.state),
        "experiment_name": info.experiment_name,
        "file_name": info.file_name,
        "error": info.error,
        "created_unix_ms": info.created_unix_ms,
        "finished_unix_ms": info.finished_unix_ms,
        "generations_done": info.generations_done,
        "generations_total": info.generations_total,
    })
}

/// A job event with the keys of `hevo.run`'s progress events (`event` names the kind).
fn job_event(event: &v1::JobEvent) -> Option<serde_json::Value> {
    Some(match event.event.as_ref()? {
        Event::Status(info) => {
            let mut value = job_info(info);
            value["event"] = json!("status");
            value
        }
        Event::NodeStarted(n) => json!({
            "event": "node_started", "node": n.node, "runs": n.runs, "generations": n.generations,
        }),
        Event::Generation(g) => json!({
            "event": "generation", "node": g.node, "run": g.run, "generation": g.generation,
            "generations": g.generations, "best": g.best, "mean": g.mean, "cycles": g.cycles,
            "job_generations_done": g.job_generations_done,
            "job_generations_total": g.job_generations_total,
        }),
        Event::RunFinished(r) => json!({
            "event": "run_finished", "node": r.node, "run": r.run, "solve_rate": r.solve_rate,
        }),
        Event::NodeFinished(n) => json!({
            "event": "node_finished", "node": n.node, "best_run": n.best_run,
            "best_solve_rate": n.best_solve_rate, "mean_solve_rate": n.mean_solve_rate,
        }),
        Event::Note(message) => json!({"event": "note", "message": message}),
    })
}

fn client_error(error: &anyhow::Error) -> PyErr {
    ClientError::new_err(format!("{error:#}"))
}

/// Runs one client call on a thread of its own with its own runtime; Ctrl-C abandons it.
fn call<T: Send>(
    py: Python<'_>,
    future: impl std::future::Future<Output = anyhow::Result<T>> + Send,
) -> PyResult<T> {
    let cancel = Notify::new();
    let outcome = crate::interrupt::run_interruptibly(
        py,
        |_events: &Mailbox<(), _>| {
            let runtime = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()?;
            Ok::<_, anyhow::Error>(runtime.block_on(async {
                tokio::select! {
                    result = future => Some(result),
                    _ = cancel.notified() => None,
                }
            }))
        },
        || cancel.notify_one(),
        |_py, ()| Ok(()),
    )?;
    match outcome {
        Ok(Some(Ok(value))) => Ok(value),
        Ok(Some(Err(error))) | Err(error) => Err(client_error(&error)),
        // Cancelled: only on Ctrl-C, which `run_interruptibly` has raised already.
        Ok(None) => Err(ClientError::new_err("the call was cancelled")),
    }
}

/// A master's job service: submit experiments, follow, list, fetch and cancel jobs.
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Client {
    options: ClientOptions,
}

#[pymethods]
impl Client {
    /// `url` is `http://HOST:PORT`, `https://HOST:PORT` or `HOST:PORT`. The token is a client
    /// token of the master (its --token-file): `token`, else the first line of `token_file`,
    /// else the environment variable HEVO_TOKEN. `tls_ca` is a PEM CA certificate to trust
    /// for an https:// master with a private certificate.
    #[new]
    #[pyo3(signature = (url, token=None, token_file=None, tls_ca=None))]
    fn new(
        url: String,
        token: Option<String>,
        token_file: Option<PathBuf>,
        tls_ca: Option<PathBuf>,
    ) -> PyResult<Self> {
        let token = token.or_else(|| std::env::var("HEVO_TOKEN").ok());
        let token = hevo_proto::auth::resolve_token(token.as_deref(), token_file.as_deref())
            .map_err(|error| ConfigError::new_err(crate::message(&error)))?;
        let options = ClientOptions { url, token, tls_ca };
        // Checks the URL and TLS settings now rather than at the first call.
        options
            .endpoint()
            .map_err(|error| ConfigError::new_err(crate::message(&error)))?;
        Ok(Client { options })
    }

    /// Submits an experiment file, with the files it reads from elsewhere; returns the job id.
    /// `node`, `runs`, `generations` and `seed` are `hevo submit`'s overrides.
    #[pyo3(signature = (experiment, node=None, runs=None, generations=None, seed=None))]
    fn submit(
        &self,
        py: Python<'_>,
        experiment: PathBuf,
        node: Option<String>,
        runs: Option<u32>,
        generations: Option<u32>,
        seed: Option<u64>,
    ) -> PyResult<String> {
        let overrides = Overrides {
            node,
            runs,
            generations,
            seed,
        };
        call(py, calls::submit(&self.options, &experiment, overrides))
    }

    /// The master's jobs, each a dict (job_id, state, experiment_name, file_name, error,
    /// created_unix_ms, finished_unix_ms, generations_done, generations_total).
    fn jobs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyAny>>> {
        let jobs = call(py, calls::list_jobs(&self.options))?;
        jobs.iter()
            .map(|info| crate::json_to_python(py, &job_info(info)))
            .collect()
    }

    /// Writes a job's result files under `out` (the layout `hevo run --out` writes); returns
    /// the job's status dict with `files`, the number of files written.
    fn fetch<'py>(
        &self,
        py: Python<'py>,
        job: String,
        out: PathBuf,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (info, files) = call(py, calls::fetch(&self.options, &job, &out))?;
        let mut value = job_info(&info);
        value["files"] = json!(files);
        crate::json_to_python(py, &value)
    }

    /// Cancels a job; returns its status dict.
    fn cancel<'py>(&self, py: Python<'py>, job: String) -> PyResult<Bound<'py, PyAny>> {
        let info = call(py, calls::cancel(&self.options, &job))?;
        crate::json_to_python(py, &job_info(&info))
    }

    /// `hevo.evaluate` on the master's workers: the same arguments (`threads` is accepted and
    /// ignored: the workers' threads count) and the same Evaluation, bit for bit. The genomes
    /// are checked and converted here as `hevo.evaluate` does, sent to the master in one
    /// call, split over every connected worker with the leases, checks and fault tolerance of
    /// jobs, and reduced here as their results stream in. A lost connection (or an evaluation
    /// a spot check ended) is evaluated again from the start, up to six attempts. Ctrl-C
    /// drops the call, which cancels the evaluation on the master.
    #[pyo3(signature = (template, genomes, task, samples=50, seed=0, threads=None, clip=false))]
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &self,
        py: Python<'_>,
        template: &Controller,
        genomes: &Bound<'_, PyAny>,
        task: &Task,
        samples: u32,
        seed: u64,
        threads: Option<usize>,
        clip: bool,
    ) -> PyResult<Evaluation> {
        let _ = threads;
        let input = EvaluationInput::new(template, genomes, task, samples, seed, clip)?;
        let columns = call(py, async {
            let mut columns = input.columns();
            calls::evaluate_genomes(
                &self.options,
                &input.template,
                &input.task,
                &input.rows,
                samples,
                seed,
                |event| match event {
                    // A new attempt sends every result again.
                    calls::EvaluationEvent::Started(_) => columns = input.columns(),
                    calls::EvaluationEvent::Results { results, .. } => {
                        for summaries in results {
                            input.reduce(&mut columns, &summaries);
                        }
                    }
                },
            )
            .await?;
            Ok(columns)
        })?;
        input.evaluation(py, columns)
    }

    /// Follows a job until it ends: an iterator of its events as dicts (`event` is `status`,
    /// `node_started`, `generation`, `run_finished`, `node_finished` or `note`), the last one
    /// the final `status`. It reconnects when the master restarts, as `hevo watch` does.
    fn watch(&self, job: String) -> JobWatch {
        JobWatch::start(self.options.clone(), job)
    }

    fn __repr__(&self) -> String {
        format!("Client('{}')", self.options.normalized_url())
    }
}

/// What a watch's thread hands over: events, then how the watch ended.
type WatchMailbox = Mailbox<serde_json::Value, Result<(), String>>;

/// The iterator `Client.watch` returns.
#[pyclass(module = "hevo")]
#[derive(Debug)]
pub struct JobWatch {
    mailbox: Arc<WatchMailbox>,
    stop: Arc<Notify>,
    pending: std::collections::VecDeque<serde_json::Value>,
    ended: Option<Result<(), String>>,
}

impl JobWatch {
    fn start(options: ClientOptions, job: String) -> JobWatch {
        let mailbox = Arc::new(WatchMailbox::default());
        let stop = Arc::new(Notify::new());
        let (events, stopped) = (mailbox.clone(), stop.clone());
        std::thread::spawn(move || {
            let outcome = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .map_err(|error| format!("cannot start the async runtime: {error}"))
                .and_then(|runtime| {
                    runtime.block_on(async {
                        let follow = calls::follow_job(
                            &options,
                            &job,
                            |event| {
                                if let Some(value) = job_event(event) {
                                    events.post(value);
                                }
                            },
                            |note| events.post(json!({"event": "note", "message": note})),
                        );
                        tokio::select! {
                            result = follow => result.map(|_| ()).map_err(|error| format!("{error:#}")),
                            _ = stopped.notified() => Ok(()),
                        }
                    })
                });
            events.finish(outcome);
        });
        JobWatch {
            mailbox,
            stop,
            pending: Default::default(),
            ended: None,
        }
    }
}

impl Drop for JobWatch {
    fn drop(&mut self) {
        // The thread ends at its next await point; nothing waits for it.
        self.stop.notify_one();
    }
}

#[pymethods]
impl JobWatch {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        loop {
            if let Some(event) = self.pending.pop_front() {
                return crate::json_to_python(py, &event);
            }
            match self.ended.take() {
                Some(Err(message)) => {
                    self.ended = Some(Ok(()));
                    return Err(ClientError::new_err(message));
                }
                Some(Ok(())) => {
                    self.ended = Some(Ok(()));
                    return Err(PyStopIteration::new_err(()));
                }
                None => {}
            }
            let mailbox = self.mailbox.clone();
            let (events, ended) = py.detach(move || mailbox.wait(crate::interrupt::SIGNAL_POLL));
            self.pending.extend(events);
            if ended.is_some() {
                self.ended = ended;
            }
            if let Err(error) = py.check_signals() {
                self.stop.notify_one();
                self.ended = Some(Ok(()));
                return Err(error);
            }
        }
    }

    /// Stops following the job.
    fn close(&mut self) {
        self.stop.notify_one();
    }
}
