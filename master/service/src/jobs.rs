//! The job manager: owns the job store, starts a run driver task per job on the shared
//! dispatcher (the same `runner::run_experiment` as `hevo run`, writing the same files under
//! `<state-dir>/jobs/<id>/runs/`), validates submissions, cancels, and publishes each job's
//! progress to watchers. On start every job that had not finished is started again; the run
//! driver's checkpoints make that a resume from the last finished generation, with the same
//! results as an uninterrupted run.
//!
//! Records live in memory while the master runs and every change is written through to the
//! store; state changes durably, progress without waiting for the disk.

use crate::convert::{event_to_proto, job_info, status_event};
use crate::db::{JobRecord, JobState, JobStore, StoreError};
use hevo_engine::dispatch::{DispatchError, Dispatcher};
use hevo_engine::experiment::Experiment;
use hevo_engine::rundir::{self, NodeSummary};
use hevo_engine::runner::{self, Overrides, Progress, ProgressEvent, RunError, RunSettings};
use hevo_proto::v1;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;
use std::time::{SystemTime, UNIX_EPOCH};
use tokio::sync::{broadcast, watch};
use tokio::task::JoinHandle;

/// Limits on what one submission may ask for, so one job cannot exhaust the master.
pub mod limits {
    /// Experiment file size.
    pub const EXPERIMENT_BYTES: usize = 1024 * 1024;
    /// The files an experiment reads from elsewhere, together (paths and contents).
    pub const ATTACHED_FILES_BYTES: usize = 16 * 1024 * 1024;
    /// File name length.
    pub const FILE_NAME_CHARS: usize = 255;
    /// Job id length accepted in requests.
    pub const JOB_ID_CHARS: usize = 64;
    /// Submission request id length.
    pub const REQUEST_ID_CHARS: usize = 64;
}

/// Why a request about jobs failed.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// A field of the request is invalid; the message starts with the field's name.
    #[error("{field}: {message}")]
    Invalid {
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// No such job.
    #[error("no job {0}")]
    NotFound(String),
    /// The job has not finished, and the request needs it finished.
    #[error("job {0} has not finished: cancel it first")]
    NotFinished(String),
    /// The master is stopping.
    #[error("the master is shutting down")]
    ShuttingDown,
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Reading results failed.
    #[error("{0}")]
    Io(String),
}

/// The longest message a refusal carries: it goes back to the client in a gRPC status, and
/// must not quote a huge input back at it.
const MAX_MESSAGE_CHARS: usize = 4096;

fn invalid(field: &str, message: impl Into<String>) -> JobError {
    JobError::Invalid {
        field: field.to_string(),
        message: hevo_engine::experiment::cut(&message.into(), MAX_MESSAGE_CHARS),
    }
}

/// A submission, as received.
#[derive(Debug, Clone, Default)]
pub struct Submission {
    /// The client's id for this submission: a retried submission with the same id returns the
    /// job the first one made.
    pub request_id: Option<String>,
    /// Experiment file text.
    pub experiment_toml: String,
    /// The files it reads from elsewhere, by relative path.
    pub files: BTreeMap<String, String>,
    /// File name for messages.
    pub file_name: String,
    /// Overrides.
    pub settings: Overrides,
}

/// A job's results: its finished nodes and its files.
#[derive(Debug, Clone, Default)]
pub struct JobResults {
    /// Finished nodes, in plan order.
    pub nodes: Vec<v1::NodeResult>,
    /// (path relative to the output directory, content).
    pub files: Vec<(String, Vec<u8>)>,
}

struct Live {
    events: broadcast::Sender<v1::JobEvent>,
    task: Option<JoinHandle<()>>,
}

struct Inner {
    store: JobStore,
    dispatcher: Arc<Dispatcher>,
    state_dir: PathBuf,
    records: Mutex<BTreeMap<String, JobRecord>>,
    live: Mutex<HashMap<String, Live>>,
    stopping: watch::Sender<bool>,
    /// Moves on every published event (the dashboard's streams wait on it).
    changes: watch::Sender<u64>,
}

/// The job manager. Cheap to clone.
#[derive(Clone)]
pub struct JobManager {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for JobManager {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JobManager")
            .field("state_dir", &self.inner.state_dir)
            .finish_non_exhaustive()
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Every update replaces whole values, so a poisoned map is still consistent.
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_millis()).unwrap_or(i64::MAX))
}

/// The finished jobs whose retention of `retention_ms` has run out at `now_ms`: those that
/// reached their final state longer ago than that. Unfinished jobs are never expired. Time is
/// an argument, so the rule is tested without a clock.
pub fn expired(records: &[JobRecord], now_ms: i64, retention_ms: i64) -> Vec<String> {
    records
        .iter()
        .filter(|record| {
            record.state.is_final()
                && record
                    .finished_unix_ms
                    .is_some_and(|finished| now_ms.saturating_sub(finished) > retention_ms)
        })
        .map(|record| record.id.clone())
        .collect()
}

/// Where jobs live in a state directory.
pub fn jobs_dir(state_dir: &Path) -> PathBuf {
    state_dir.join("jobs")
}

/// A job's directory: its record's copy and its outputs.
pub fn job_dir(state_dir: &Path, id: &str) -> PathBuf {
    jobs_dir(state_dir).join(id)
}

/// The output directory of a job.
pub fn job_out_dir(state_dir: &Path, id: &str) -> PathBuf {
    job_dir(state_dir, id).join("runs")
}

impl JobManager {
    /// Opens the manager on a store and resumes every unfinished job. Must run inside a tokio
    /// runtime.
    pub fn start(
        store: JobStore,
        dispatcher: Arc<Dispatcher>,
        state_dir: PathBuf,
    ) -> Result<JobManager, JobError> {
        let records: BTreeMap<String, JobRecord> = store
            .list()?
            .into_iter()
            .map(|r| (r.id.clone(), r))
            .collect();
        let unfinished: Vec<String> = records
            .values()
            .filter(|r| !r.state.is_final())
            .map(|r| r.id.clone())
            .collect();
        let manager = JobManager {
            inner: Arc::new(Inner {
                store,
                dispatcher,
                state_dir,
                records: Mutex::new(records),
                live: Mutex::new(HashMap::new()),
                stopping: watch::channel(false).0,
                changes: watch::channel(0).0,
            }),
        };
        for id in unfinished {
            tracing::info!(job = %id, "resuming job");
            manager.spawn(id);
        }
        Ok(manager)
    }

    /// The dispatcher the jobs run on.
    pub fn dispatcher(&self) -> &Arc<Dispatcher> {
        &self.inner.dispatcher
    }

    /// Validates and stores a job, then starts it; returns its record.
    pub fn submit(&self, submission: Submission) -> Result<JobRecord, JobError> {
        if *self.inner.stopping.borrow() {
            return Err(JobError::ShuttingDown);
        }
        let (experiment, plan, file_name) = validate(&submission)?;
        let (record, new) =
            self.inner
                .store
                .insert_new(submission.request_id.as_deref(), |id| JobRecord {
                    id,
                    request_id: None,
                    experiment_name: experiment.header.name.clone(),
                    file_name: file_name.clone(),
                    experiment_toml: submission.experiment_toml.clone(),
                    files: submission.files.clone(),
                    settings: submission.settings.clone(),
                    plan,
                    state: JobState::Queued,
                    error: None,
                    created_unix_ms: now_ms(),
                    finished_unix_ms: None,
                    generations_done: 0,
                    last_event: None,
                })?;
        if !new {
            // The same request id must mean the same submission: a client that reuses an id
            // for another experiment would otherwise get the first job back without a word.
            let same = record.experiment_toml == submission.experiment_toml
                && record.files == submission.files
                && record.settings == submission.settings
                && record.file_name == file_name;
            if !same {
                return Err(invalid(
                    "request_id",
                    format!(
                        "'{}' was used for another submission (job {}); use a new request id for a new submission",
                        hevo_engine::experiment::cut(
                            submission.request_id.as_deref().unwrap_or_default(),
                            limits::REQUEST_ID_CHARS
                        ),
                        record.id
                    ),
                ));
            }
            tracing::info!(job = %record.id, "a retried submission: its job already exists");
            return Ok(record);
        }
        self.keep_record_copy(&record);
        tracing::info!(job = %record.id, experiment = %record.experiment_name, generations = record.generations_total(), "job submitted");
        lock(&self.inner.records).insert(record.id.clone(), record.clone());
        self.spawn(record.id.clone());
        Ok(record)
    }

    /// Writes the copy of a job's record its directory keeps (`jobs/<id>/job.json`), from
    /// which a lost store can be rebuilt. A failure is logged: the store is the record.
    fn keep_record_copy(&self, record: &JobRecord) {
        let path = job_dir(&self.inner.state_dir, &record.id).join(crate::db::RECORD_FILE);
        if let Err(error) = hevo_engine::store::write_json_atomic(&path, record) {
            tracing::warn!(job = %record.id, %error, "cannot keep the copy of the job's record");
        }
    }

    /// A job's record.
    pub fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        check_id(id)?;
        lock(&self.inner.records)
            .get(id)
            .cloned()
            .ok_or_else(|| JobError::NotFound(id.to_string()))
    }

    /// Every job, newest first.
    pub fn list(&self) -> Vec<JobRecord> {
        lock(&self.inner.records).values().rev().cloned().collect()
    }

    /// Jobs per state.
    pub fn counts(&self) -> BTreeMap<JobState, usize> {
        let mut counts: BTreeMap<JobState, usize> = JobState::ALL.iter().map(|&s| (s, 0)).collect();
        for record in lock(&self.inner.records).values() {
            *counts.entry(record.state).or_default() += 1;
        }
        counts
    }

    /// Cancels a job (a no-op for a finished one); returns its record.
    pub async fn cancel(&self, id: &str) -> Result<JobRecord, JobError> {
        let record = self.get(id)?;
        if record.state.is_final() {
            return Ok(record);
        }
        let record = self.finish(id, JobState::Cancelled, None)?;
        self.stop_driver(id).await;
        tracing::info!(job = %id, "job cancelled");
        Ok(record)
    }

    /// Stops a job's driver, then drops its batches: in that order, so the driver cannot
    /// queue new ones after.
    async fn stop_driver(&self, id: &str) {
        let task = lock(&self.inner.live)
            .get_mut(id)
            .and_then(|live| live.task.take());
        if let Some(task) = task {
            task.abort();
            let _ = task.await;
        }
        self.inner.dispatcher.cancel_job(id);
    }

    /// Evaluates an unfinished job again from the start (after a spot check caught a worker
    /// whose results it accepted): its driver stops, its outputs go, and it runs anew. A job
    /// that finished already keeps its results, with an error logged: a caught worker had
    /// passed its first check, so only results it sent after it are in doubt.
    pub async fn evaluate_again(&self, id: &str) {
        let Ok(record) = self.get(id) else {
            return;
        };
        self.inner.dispatcher.forget_contributors(id);
        if record.state.is_final() {
            tracing::error!(job = %id, "the job accepted results of a worker a spot check caught; it had finished: submit it again to be sure of its results");
            return;
        }
        self.stop_driver(id).await;
        let out_dir = job_out_dir(&self.inner.state_dir, id);
        if let Err(error) = std::fs::remove_dir_all(&out_dir)
            && error.kind() != std::io::ErrorKind::NotFound
        {
            tracing::error!(job = %id, %error, "cannot remove the job's outputs to evaluate it again");
            let _ = self.finish(
                id,
                JobState::Failed,
                Some(format!(
                    "a worker sent false results and the outputs could not be removed: {error}"
                )),
            );
            return;
        }
        if let Some(record) = lock(&self.inner.records).get_mut(id) {
            record.generations_done = 0;
        }
        tracing::warn!(job = %id, "evaluating the job again from the start");
        self.spawn(id.to_string());
    }

    /// Forgets a finished job: its record and request id in the store, its memory here, and
    /// its directory (outputs and the record's copy). Its watchers' streams end.
    pub fn delete(&self, id: &str) -> Result<(), JobError> {
        let record = self.get(id)?;
        if !record.state.is_final() {
            return Err(JobError::NotFinished(id.to_string()));
        }
        self.inner.store.delete(&record)?;
        lock(&self.inner.records).remove(id);
        lock(&self.inner.live).remove(id);
        let dir = job_dir(&self.inner.state_dir, id);
        if let Err(error) = std::fs::remove_dir_all(&dir)
            && error.kind() != std::io::ErrorKind::NotFound
        {
            tracing::warn!(job = %id, %error, "cannot remove the job's directory");
        }
        self.inner.changes.send_modify(|n| *n = n.wrapping_add(1));
        tracing::info!(job = %id, "job deleted");
        Ok(())
    }

    /// Deletes the finished jobs that reached their final state more than `retention` ago
    /// (as [`JobManager::delete`] would one by one); returns how many it deleted.
    pub fn delete_expired(&self, retention: Duration) -> usize {
        let retention_ms = i64::try_from(retention.as_millis()).unwrap_or(i64::MAX);
        expired(&self.list(), now_ms(), retention_ms)
            .iter()
            .filter(|id| match self.delete(id) {
                Ok(()) => true,
                Err(error) => {
                    tracing::warn!(job = %id, %error, "cannot delete an expired job");
                    false
                }
            })
            .count()
    }

    /// Subscribes to a job's events (before reading its status, so nothing is missed).
    pub fn subscribe(
        &self,
        id: &str,
    ) -> Result<(broadcast::Receiver<v1::JobEvent>, watch::Receiver<bool>), JobError> {
        self.get(id)?;
        let receiver = self.sender(id).subscribe();
        Ok((receiver, self.inner.stopping.subscribe()))
    }

    /// Turns true when the master starts stopping.
    pub fn stopping(&self) -> watch::Receiver<bool> {
        self.inner.stopping.subscribe()
    }

    /// A counter that moves whenever any job changes: submitted, progressed or finished.
    pub fn changes(&self) -> watch::Receiver<u64> {
        self.inner.changes.subscribe()
    }

    /// Tells a job's watchers and the change counter.
    fn publish(&self, id: &str, event: v1::JobEvent) {
        let _ = self.sender(id).send(event);
        self.inner.changes.send_modify(|n| *n = n.wrapping_add(1));
    }

    /// The directory a job's runs are written to.
    pub fn out_dir(&self, id: &str) -> PathBuf {
        job_out_dir(&self.inner.state_dir, id)
    }

    fn sender(&self, id: &str) -> broadcast::Sender<v1::JobEvent> {
        lock(&self.inner.live)
            .entry(id.to_string())
            .or_insert_with(|| Live {
                events: broadcast::channel(256).0,
                task: None,
            })
            .events
            .clone()
    }

    /// Stops every job where it is (their state stays running, so the next start resumes
    /// them) and ends the watch streams.
    pub fn shut_down(&self) {
        let _ = self.inner.stopping.send(true);
        self.inner.dispatcher.shut_down();
    }

    /// Sets a final state (unless the job already has one), durably, and tells watchers.
    fn finish(
        &self,
        id: &str,
        state: JobState,
        error: Option<String>,
    ) -> Result<JobRecord, JobError> {
        let record = {
            let mut records = lock(&self.inner.records);
            let record = records
                .get_mut(id)
                .ok_or_else(|| JobError::NotFound(id.to_string()))?;
            if record.state.is_final() {
                return Ok(record.clone());
            }
            record.state = state;
            record.error = error;
            record.finished_unix_ms = Some(now_ms());
            self.inner.store.put(record, true)?;
            self.keep_record_copy(record);
            record.clone()
        };
        self.publish(id, status_event(&record));
        Ok(record)
    }

    fn set_running(&self, id: &str) -> Result<Option<JobRecord>, JobError> {
        let mut records = lock(&self.inner.records);
        let Some(record) = records.get_mut(id) else {
            return Ok(None);
        };
        if record.state.is_final() {
            return Ok(None);
        }
        if record.state != JobState::Running {
            record.state = JobState::Running;
            self.inner.store.put(record, true)?;
            self.keep_record_copy(record);
        }
        Ok(Some(record.clone()))
    }

    fn spawn(&self, id: String) {
        let manager = self.clone();
        let events = self.sender(&id);
        let job = id.clone();
        let task = tokio::spawn(async move { manager.drive(job).await });
        lock(&self.inner.live).insert(
            id,
            Live {
                events,
                task: Some(task),
            },
        );
    }

    async fn drive(&self, id: String) {
        let record = match self.set_running(&id) {
            Ok(Some(record)) => record,
            Ok(None) => return,
            Err(error) => {
                tracing::error!(job = %id, %error, "cannot start job");
                return;
            }
        };
        self.publish(&id, status_event(&record));
        // Compiling the experiment's scenarios and checking its starts is blocking work.
        let parsed = {
            let record = record.clone();
            tokio::task::spawn_blocking(move || {
                Experiment::parse_with(
                    &record.experiment_toml,
                    Path::new(&record.file_name),
                    &record.files,
                )
                .map_err(|error| error.to_string())
            })
            .await
            .unwrap_or_else(|join_error| {
                Err(format!("checking the experiment failed: {join_error}"))
            })
        };
        let experiment = match parsed {
            Ok(experiment) => experiment,
            Err(error) => {
                let _ = self.finish(&id, JobState::Failed, Some(error));
                return;
            }
        };
        let settings = RunSettings {
            out_dir: job_out_dir(&self.inner.state_dir, &id),
            overrides: record.settings.clone(),
            job: id.clone(),
        };
        let progress = JobProgress::new(self.clone(), &record);
        tracing::info!(job = %id, "job started");
        let outcome =
            runner::run_experiment(&experiment, &settings, &self.inner.dispatcher, &progress).await;
        let result = match outcome {
            Ok(_) => {
                tracing::info!(job = %id, "job succeeded");
                self.finish(&id, JobState::Succeeded, None)
            }
            // Stopping with the master: the job stays running and resumes on the next start.
            Err(RunError::Dispatch(DispatchError::ShuttingDown)) => return,
            Err(RunError::Dispatch(DispatchError::Cancelled(_))) => {
                self.finish(&id, JobState::Cancelled, None)
            }
            Err(error) => {
                tracing::warn!(job = %id, %error, "job failed");
                self.finish(&id, JobState::Failed, Some(error.to_string()))
            }
        };
        if let Err(error) = result {
            tracing::error!(job = %id, %error, "cannot record the job's end");
        }
    }

    fn record_progress(
        &self,
        id: &str,
        event: &ProgressEvent,
        done: Option<u64>,
    ) -> Option<v1::JobEvent> {
        let mut records = lock(&self.inner.records);
        let record = records.get_mut(id)?;
        if let Some(done) = done {
            record.generations_done = done;
        }
        record.last_event = Some(event.clone());
        // Progress is recomputed on resume, so it need not wait for the disk; it is stored
        // apart from the record, whose submitted text stays where it is.
        if let Err(error) =
            self.inner
                .store
                .put_progress(id, record.generations_done, record.last_event.as_ref())
        {
            tracing::warn!(job = %id, %error, "cannot store progress");
        }
        Some(event_to_proto(
            id,
            event,
            record.generations_done,
            record.generations_total(),
        ))
    }

    /// The job's finished nodes and, with `files`, its result files.
    pub fn results(&self, id: &str, files: bool) -> Result<JobResults, JobError> {
        let record = self.get(id)?;
        let out_dir = job_out_dir(&self.inner.state_dir, id);
        let mut results = JobResults::default();
        let read = |path: &Path| {
            std::fs::read(path).map_err(|e| JobError::Io(format!("{}: {e}", path.display())))
        };
        for (node, _, _) in &record.plan {
            let node_dir = rundir::node_dir(&out_dir, node);
            let summary_path = node_dir.join(rundir::SUMMARY);
            if let Ok(Some(summary)) = hevo_engine::store::read_json::<NodeSummary>(&summary_path) {
                let best = std::fs::read_to_string(node_dir.join(rundir::BEST)).unwrap_or_default();
                results.nodes.push(v1::NodeResult {
                    node: summary.node.clone(),
                    task: summary.task.clone(),
                    runs: summary.runs.len() as u32,
                    best_run: summary.best_run,
                    best_solve_rate: summary.best_solve_rate,
                    mean_solve_rate: summary.mean_solve_rate,
                    best_controller_json: best,
                });
            }
            if !files {
                continue;
            }
            for name in rundir::FINISHED_NODE_FILES {
                let path = node_dir.join(name);
                if path.is_file() {
                    results.files.push((format!("{node}/{name}"), read(&path)?));
                }
            }
            let runs = rundir::run_dirs(&node_dir).unwrap_or_default();
            for (run, run_dir) in runs {
                for name in rundir::FINISHED_RUN_FILES {
                    let path = run_dir.join(name);
                    if path.is_file() {
                        results.files.push((
                            format!("{node}/{}/{name}", rundir::run_dir_name(run)),
                            read(&path)?,
                        ));
                    }
                }
            }
        }
        Ok(results)
    }
}

fn check_id(id: &str) -> Result<(), JobError> {
    if id.is_empty() || id.len() > limits::JOB_ID_CHARS {
        return Err(invalid(
            "job_id",
            format!("must be 1 to {} characters", limits::JOB_ID_CHARS),
        ));
    }
    Ok(())
}

/// Checks every field of a submission; on success, the parsed experiment, the plan (node,
/// runs, generations in run order) and the file name to use.
#[allow(clippy::type_complexity)]
pub fn validate(
    submission: &Submission,
) -> Result<(Experiment, Vec<(String, u32, u32)>, String), JobError> {
    let file_name = if submission.file_name.is_empty() {
        "experiment.toml".to_string()
    } else {
        submission.file_name.clone()
    };
    if file_name.chars().count() > limits::FILE_NAME_CHARS
        || file_name.chars().any(char::is_control)
    {
        return Err(invalid(
            "file_name",
            format!(
                "must be at most {} characters without control characters",
                limits::FILE_NAME_CHARS
            ),
        ));
    }
    if let Some(request_id) = &submission.request_id
        && (request_id.chars().count() > limits::REQUEST_ID_CHARS
            || request_id.chars().any(char::is_control))
    {
        return Err(invalid(
            "request_id",
            format!(
                "must be at most {} characters without control characters",
                limits::REQUEST_ID_CHARS
            ),
        ));
    }
    let text = &submission.experiment_toml;
    if text.trim().is_empty() {
        return Err(invalid("experiment_toml", "is empty"));
    }
    if text.len() > limits::EXPERIMENT_BYTES {
        return Err(invalid(
            "experiment_toml",
            format!(
                "is {} bytes, at most {} are accepted",
                text.len(),
                limits::EXPERIMENT_BYTES
            ),
        ));
    }
    let files_bytes: usize = submission
        .files
        .iter()
        .map(|(k, v)| k.len() + v.len())
        .sum();
    if files_bytes > limits::ATTACHED_FILES_BYTES {
        return Err(invalid(
            "files",
            format!(
                "are {files_bytes} bytes, at most {} are accepted",
                limits::ATTACHED_FILES_BYTES
            ),
        ));
    }
    let experiment = Experiment::parse_with(text, Path::new(&file_name), &submission.files)
        .map_err(|e| invalid("experiment_toml", e.to_string()))?;
    // A job keeps what it was sent for its whole life: only the files it reads are kept.
    let read: std::collections::BTreeSet<String> =
        hevo_engine::experiment::external_files(&experiment)
            .into_iter()
            .collect();
    if let Some(unread) = submission.files.keys().find(|path| !read.contains(*path)) {
        return Err(invalid(
            "files",
            format!(
                "'{}' is not read by the experiment; send only the files it names (a scenario or a child from elsewhere)",
                hevo_engine::experiment::cut(&unread.escape_default().to_string(), 200)
            ),
        ));
    }
    let settings = &submission.settings;
    settings
        .validate()
        .map_err(|error| invalid(error.field, error.message))?;
    let names = experiment
        .nodes_to_run(settings.node.as_deref())
        .map_err(|error| invalid("node", error.to_string()))?;
    let mut plan = Vec::new();
    for name in names {
        let node = experiment
            .node(&name)
            .expect("names come from the experiment");
        let runs = settings.runs_of(node);
        let generations = settings.generations_of(node);
        plan.push((name, runs, generations));
    }
    Ok((experiment, plan, file_name))
}

/// Receives a job's progress from its run driver: keeps the record's progress and tells
/// watchers.
struct JobProgress {
    manager: JobManager,
    id: String,
    /// Per node: generations of the job before it, and its generations per run.
    offsets: HashMap<String, (u64, u32)>,
}

impl JobProgress {
    fn new(manager: JobManager, record: &JobRecord) -> JobProgress {
        let mut offsets = HashMap::new();
        let mut before = 0u64;
        for (node, runs, generations) in &record.plan {
            offsets.insert(node.clone(), (before, *generations));
            before += u64::from(*runs) * u64::from(*generations);
        }
        JobProgress {
            manager,
            id: record.id.clone(),
            offsets,
        }
    }
}

impl Progress for JobProgress {
    fn event(&self, event: &ProgressEvent) {
        // Progress is a position, not a count: a resumed run that repeats a generation does not
        // count it twice.
        let done = match event {
            ProgressEvent::Generation {
                node,
                run,
                generation,
                ..
            } => self.offsets.get(node).map(|(before, per_run)| {
                before + u64::from(*run) * u64::from(*per_run) + u64::from(*generation) + 1
            }),
            _ => None,
        };
        if let ProgressEvent::Note { message } = event {
            tracing::info!(job = %self.id, "{message}");
        }
        if let Some(proto) = self.manager.record_progress(&self.id, event, done) {
            self.manager.publish(&self.id, proto);
        }
    }
}

/// A job's status for the wire.
pub fn info(record: &JobRecord) -> v1::JobInfo {
    job_info(record)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::db::tests::record;

    #[test]
    fn only_jobs_finished_longer_ago_than_the_retention_expire() {
        let at = |id: &str, state: JobState, finished: Option<i64>| JobRecord {
            state,
            finished_unix_ms: finished,
            ..record(id.to_string())
        };
        let records = [
            at("old-success", JobState::Succeeded, Some(1_000)),
            at("old-failure", JobState::Failed, Some(1_000)),
            at("old-cancel", JobState::Cancelled, Some(1_000)),
            at("recent", JobState::Succeeded, Some(9_500)),
            at("just-expired", JobState::Succeeded, Some(8_999)),
            at("exactly-due", JobState::Succeeded, Some(9_000)),
            // Never final, whatever its timestamps say: never expired.
            at("running", JobState::Running, Some(1_000)),
            at("queued", JobState::Queued, None),
        ];
        assert_eq!(
            expired(&records, 10_000, 1_000),
            ["old-success", "old-failure", "old-cancel", "just-expired"]
        );
        assert!(expired(&records, 10_000, i64::MAX).is_empty());
        assert_eq!(expired(&records, i64::MIN, 0), Vec::<String>::new());
    }
}
