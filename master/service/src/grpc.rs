//! The two gRPC services of `hevo serve`. `JobService` turns requests into job manager calls
//! (every submitted field validated, INVALID_ARGUMENT naming the field). `WorkerService` is the
//! dispatcher on the wire: a long-polled lease, heartbeats, results checked value by value and
//! shape by shape before the dispatcher accepts them, hand-backs and failure reports. Every
//! lease carries the master's epoch, a random number drawn at start, so results for a lease of
//! an earlier master process are recognised and ignored instead of being matched to an
//! unrelated batch that happens to reuse the id.

use crate::convert::{batch_to_proto, job_info, status_event};
use crate::evaluations::{EvaluationStream, Evaluations};
use crate::jobs::{JobError, JobManager, Submission};
use hevo_engine::dispatch::{CompleteError, Dispatcher};
use hevo_engine::runner::Overrides;
use hevo_proto::convert as wire;
use hevo_proto::v1;
use hevo_proto::v1::job_service_server::JobService;
use hevo_proto::v1::worker_service_server::WorkerService;
use std::collections::{HashMap, HashSet};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::broadcast::error::RecvError;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status};

fn job_status(error: JobError) -> Status {
    match error {
        JobError::Invalid { .. } => Status::invalid_argument(error.to_string()),
        JobError::NotFound(_) => Status::not_found(error.to_string()),
        JobError::NotFinished(_) => Status::failed_precondition(error.to_string()),
        JobError::ShuttingDown => Status::unavailable(error.to_string()),
        JobError::Store(_) | JobError::Io(_) => {
            tracing::error!(%error, "job request failed");
            Status::internal(error.to_string())
        }
    }
}

/// The client-facing service.
#[derive(Debug, Clone)]
pub struct JobApi {
    manager: JobManager,
    evaluations: Evaluations,
    /// Places for open watch streams.
    watches: Arc<tokio::sync::Semaphore>,
    max_watches: usize,
}

impl JobApi {
    /// Serves the manager's jobs and remote evaluations, with at most `max_watches` watch
    /// streams open at once.
    pub fn new(manager: JobManager, evaluations: Evaluations, max_watches: usize) -> JobApi {
        JobApi {
            manager,
            evaluations,
            watches: Arc::new(tokio::sync::Semaphore::new(max_watches)),
            max_watches,
        }
    }
}

#[tonic::async_trait]
impl JobService for JobApi {
    async fn submit_job(
        &self,
        request: Request<v1::SubmitJobRequest>,
    ) -> Result<Response<v1::SubmitJobResponse>, Status> {
        let request = request.into_inner();
        let submission = Submission {
            request_id: (!request.request_id.is_empty()).then_some(request.request_id),
            experiment_toml: request.experiment_toml,
            files: request.files.into_iter().collect(),
            file_name: request.file_name,
            settings: Overrides {
                node: request.node,
                runs: request.runs,
                generations: request.generations,
                seed: request.seed,
            },
        };
        let manager = self.manager.clone();
        let mut stopping = self.manager.stopping();
        // Parsing and the durable commit block; keep them off the async threads, and do not
        // hold a stopping master's drain up for them.
        let work = tokio::task::spawn_blocking(move || manager.submit(submission));
        let record = tokio::select! {
            done = work => done
                .map_err(|e| Status::internal(format!("submission task failed: {e}")))?
                .map_err(job_status)?,
            _ = stopping.wait_for(|&s| s) => return Err(job_status(JobError::ShuttingDown)),
        };
        Ok(Response::new(v1::SubmitJobResponse { job_id: record.id }))
    }

    type WatchJobStream = ReceiverStream<Result<v1::JobEvent, Status>>;

    async fn watch_job(
        &self,
        request: Request<v1::WatchJobRequest>,
    ) -> Result<Response<Self::WatchJobStream>, Status> {
        let id = request.into_inner().job_id;
        let Ok(place) = self.watches.clone().try_acquire_owned() else {
            tracing::warn!(
                max_watches = self.max_watches,
                "watch stream limit reached: a watch was refused"
            );
            return Err(Status::resource_exhausted(format!(
                "{} watch streams are open, the most this master serves; try again later",
                self.max_watches
            )));
        };
        let (mut events, mut stopping) = self.manager.subscribe(&id).map_err(job_status)?;
        let record = self.manager.get(&id).map_err(job_status)?;
        let (sender, receiver) = tokio::sync::mpsc::channel(64);
        let manager = self.manager.clone();
        tokio::spawn(async move {
            let _place = place;
            let finished = record.state.is_final();
            if sender.send(Ok(status_event(&record))).await.is_err() || finished {
                return;
            }
            loop {
                let event = tokio::select! {
                    event = events.recv() => event,
                    // The master is stopping: end the stream; the client reconnects later.
                    _ = stopping.wait_for(|&s| s) => return,
                    // The client went away: free the stream's place now, not at the next event.
                    () = sender.closed() => return,
                };
                let event = match event {
                    Ok(event) => event,
                    // A slow watcher missed events: send the current status instead.
                    Err(RecvError::Lagged(_)) => match manager.get(&id) {
                        Ok(record) => status_event(&record),
                        Err(_) => return,
                    },
                    Err(RecvError::Closed) => return,
                };
                let last = matches!(&event.event, Some(v1::job_event::Event::Status(info)) if hevo_proto::is_final(info.state));
                if sender.send(Ok(event)).await.is_err() || last {
                    return;
                }
            }
        });
        Ok(Response::new(ReceiverStream::new(receiver)))
    }

    async fn get_job(
        &self,
        request: Request<v1::GetJobRequest>,
    ) -> Result<Response<v1::GetJobResponse>, Status> {
        let request = request.into_inner();
        let record = self.manager.get(&request.job_id).map_err(job_status)?;
        let manager = self.manager.clone();
        let id = request.job_id.clone();
        let results =
            tokio::task::spawn_blocking(move || manager.results(&id, request.include_files))
                .await
                .map_err(|e| Status::internal(format!("results task failed: {e}")))?
                .map_err(job_status)?;
        Ok(Response::new(v1::GetJobResponse {
            job: Some(job_info(&record)),
            nodes: results.nodes,
            files: results
                .files
                .into_iter()
                .map(|(path, content)| v1::ResultFile { path, content })
                .collect(),
        }))
    }

    async fn list_jobs(
        &self,
        _request: Request<v1::ListJobsRequest>,
    ) -> Result<Response<v1::ListJobsResponse>, Status> {
        let records = self.manager.list();
        let jobs = records.iter().map(|record| {
            // The list is for an overview: the experiment text stays out of it.
            let mut info = job_info(record);
            info.last_event = None;
            info
        });
        Ok(Response::new(v1::ListJobsResponse {
            jobs: jobs.collect(),
        }))
    }

    async fn cancel_job(
        &self,
        request: Request<v1::CancelJobRequest>,
    ) -> Result<Response<v1::CancelJobResponse>, Status> {
        let id = request.into_inner().job_id;
        if self.evaluations.cancel(&id) {
            // A running evaluation: it has no record, only its id and state.
            return Ok(Response::new(v1::CancelJobResponse {
                job: Some(v1::JobInfo {
                    job_id: id,
                    state: v1::JobState::Cancelled as i32,
                    ..v1::JobInfo::default()
                }),
            }));
        }
        let record = self.manager.cancel(&id).await.map_err(job_status)?;
        Ok(Response::new(v1::CancelJobResponse {
            job: Some(job_info(&record)),
        }))
    }

    type EvaluateGenomesStream = EvaluationStream;

    async fn evaluate_genomes(
        &self,
        request: Request<v1::EvaluateGenomesRequest>,
    ) -> Result<Response<Self::EvaluateGenomesStream>, Status> {
        let stream = self.evaluations.start(request.into_inner()).await?;
        Ok(Response::new(stream))
    }

    async fn delete_job(
        &self,
        request: Request<v1::DeleteJobRequest>,
    ) -> Result<Response<v1::DeleteJobResponse>, Status> {
        let manager = self.manager.clone();
        let id = request.into_inner().job_id;
        // Removing a job's files is blocking work.
        tokio::task::spawn_blocking(move || manager.delete(&id))
            .await
            .map_err(|e| Status::internal(format!("delete task failed: {e}")))?
            .map_err(job_status)?;
        Ok(Response::new(v1::DeleteJobResponse {}))
    }
}

/// Counters the dispatcher does not keep.
#[derive(Debug, Default)]
pub struct WorkerCounters {
    /// Results refused before they reached the dispatcher (values that do not fit).
    pub refused_results: AtomicU64,
    /// Results for leases of an earlier master process.
    pub stale_results: AtomicU64,
    /// Batches a worker said it could not evaluate but the master could (re-queued).
    pub disputed_failures: AtomicU64,
}

/// The worker-facing service. A lease belongs to the worker that leased it *on that
/// connection* (`<worker>@<peer address>`): only calls on the same connection with the same
/// worker name can extend, complete, release or fail it, and when the connection closes its
/// leases go back to the queue at once.
#[derive(Debug, Clone)]
pub struct WorkerApi {
    dispatcher: Arc<Dispatcher>,
    epoch: u64,
    lease: Duration,
    max_wait: Duration,
    counters: Arc<WorkerCounters>,
    seen: Arc<Mutex<HashSet<String>>>,
    /// The lease holders seen on each open connection.
    holders: Arc<Mutex<HashMap<SocketAddr, HashSet<String>>>>,
}

/// Who holds a lease: the worker's name on the connection the call came on.
fn holder<T>(request: &Request<T>, worker: &str) -> String {
    match request.remote_addr() {
        Some(peer) => format!("{worker}@{peer}"),
        None => worker.to_string(),
    }
}

/// Longest worker name accepted.
const MAX_WORKER_NAME: usize = 128;
/// Most threads a worker may claim (batch sizing trusts it).
const MAX_WORKER_THREADS: u32 = 4096;

impl WorkerApi {
    /// Serves the dispatcher; `lease` is its lease timeout, `max_wait` caps long polls.
    pub fn new(dispatcher: Arc<Dispatcher>, lease: Duration, max_wait: Duration) -> WorkerApi {
        use std::hash::{BuildHasher, Hasher};
        // A fresh random number per process (std's hasher keys are seeded from the OS).
        let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
        hasher.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        hasher.write_u32(std::process::id());
        WorkerApi {
            dispatcher,
            epoch: hasher.finish(),
            lease,
            max_wait,
            counters: Arc::default(),
            seen: Arc::default(),
            holders: Arc::default(),
        }
    }

    /// Takes back the leases of every worker on a connection when it closes, for as long as
    /// `closed` sends the peers of closed connections (see [`crate::conn`]).
    pub async fn revoke_on_close(
        self,
        mut closed: tokio::sync::mpsc::UnboundedReceiver<SocketAddr>,
    ) {
        while let Some(peer) = closed.recv().await {
            let holders = self
                .holders
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .remove(&peer)
                .unwrap_or_default();
            for holder in holders {
                let revoked = self.dispatcher.revoke_worker(&holder);
                if revoked > 0 {
                    tracing::warn!(worker = %holder, revoked, "worker connection closed; its batches re-queued");
                }
            }
        }
    }

    /// The counters, for metrics.
    pub fn counters(&self) -> Arc<WorkerCounters> {
        self.counters.clone()
    }

    /// This process's epoch.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    fn check_worker(name: &str) -> Result<(), Status> {
        if name.is_empty() || name.len() > MAX_WORKER_NAME {
            return Err(Status::invalid_argument(format!(
                "worker: must be 1 to {MAX_WORKER_NAME} characters"
            )));
        }
        Ok(())
    }
}

#[tonic::async_trait]
impl WorkerService for WorkerApi {
    async fn lease_batch(
        &self,
        request: Request<v1::LeaseBatchRequest>,
    ) -> Result<Response<v1::LeaseBatchResponse>, Status> {
        let asked = request.get_ref();
        Self::check_worker(&asked.worker)?;
        if asked.threads == 0 || asked.threads > MAX_WORKER_THREADS {
            return Err(Status::invalid_argument(format!(
                "threads: must be between 1 and {MAX_WORKER_THREADS}, got {}",
                asked.threads
            )));
        }
        let new_worker = {
            let mut seen = lock_set(&self.seen);
            // Names include process ids, so restarts add names: forget them now and then.
            if seen.len() > 10_000 {
                seen.clear();
            }
            seen.insert(asked.worker.clone())
        };
        if new_worker {
            tracing::info!(worker = %asked.worker, threads = asked.threads, "worker connected");
        }
        let wait = Duration::from_millis(u64::from(asked.wait_ms)).min(self.max_wait);
        let holder = holder(&request, &asked.worker);
        if let Some(peer) = request.remote_addr() {
            self.holders
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .entry(peer)
                .or_default()
                .insert(holder.clone());
        }
        let request = request.into_inner();
        let leased = self
            .dispatcher
            .lease(&holder, request.threads as usize, wait)
            .await;
        let lease_ms = u32::try_from(self.lease.as_millis()).unwrap_or(u32::MAX);
        let batch =
            leased.map(|batch| batch_to_proto(&batch, self.epoch, lease_ms, &request.cached));
        Ok(Response::new(v1::LeaseBatchResponse { batch }))
    }

    async fn extend_lease(
        &self,
        request: Request<v1::ExtendLeaseRequest>,
    ) -> Result<Response<v1::ExtendLeaseResponse>, Status> {
        let holder = holder(&request, &request.get_ref().worker);
        let request = request.into_inner();
        let valid = request.epoch == self.epoch
            && self
                .dispatcher
                .extend(request.lease_id, &holder, std::time::Instant::now())
                .is_ok();
        Ok(Response::new(v1::ExtendLeaseResponse { valid }))
    }

    async fn complete_batch(
        &self,
        request: Request<v1::CompleteBatchRequest>,
    ) -> Result<Response<v1::CompleteBatchResponse>, Status> {
        let holder = holder(&request, &request.get_ref().worker);
        let request = request.into_inner();
        if request.epoch != self.epoch {
            self.counters.stale_results.fetch_add(1, Ordering::Relaxed);
            tracing::debug!(worker = %request.worker, lease_id = request.lease_id, "result for an earlier master ignored");
            return Ok(Response::new(v1::CompleteBatchResponse { accepted: false }));
        }
        let results = match wire::results_from_proto(&request.genomes) {
            Ok(results) => results,
            Err(error) => {
                self.counters
                    .refused_results
                    .fetch_add(1, Ordering::Relaxed);
                tracing::warn!(worker = %request.worker, batch_id = request.batch_id, %error, "refused a malformed result");
                // Only the lease's holder can hand its batch back; anyone else changes nothing.
                if self.dispatcher.release(request.lease_id, &holder).is_ok() {
                    tracing::warn!(batch_id = request.batch_id, "batch re-queued");
                }
                return Err(Status::invalid_argument(error.to_string()));
            }
        };
        match self
            .dispatcher
            .complete(request.lease_id, request.batch_id, &holder, results)
        {
            Ok(()) => Ok(Response::new(v1::CompleteBatchResponse { accepted: true })),
            Err(CompleteError::Lease(error)) => {
                tracing::debug!(worker = %holder, %error, "result refused");
                Ok(Response::new(v1::CompleteBatchResponse { accepted: false }))
            }
            Err(error @ CompleteError::Malformed { .. }) => {
                tracing::warn!(worker = %holder, %error, "refused a result");
                Err(Status::invalid_argument(error.to_string()))
            }
        }
    }

    async fn release_batch(
        &self,
        request: Request<v1::ReleaseBatchRequest>,
    ) -> Result<Response<v1::ReleaseBatchResponse>, Status> {
        let holder = holder(&request, &request.get_ref().worker);
        let request = request.into_inner();
        if request.epoch == self.epoch && self.dispatcher.release(request.lease_id, &holder).is_ok()
        {
            tracing::info!(worker = %holder, lease_id = request.lease_id, "batch handed back");
        }
        Ok(Response::new(v1::ReleaseBatchResponse {}))
    }

    async fn fail_batch(
        &self,
        request: Request<v1::FailBatchRequest>,
    ) -> Result<Response<v1::FailBatchResponse>, Status> {
        let holder = holder(&request, &request.get_ref().worker);
        let request = request.into_inner();
        if request.epoch != self.epoch {
            return Ok(Response::new(v1::FailBatchResponse {}));
        }
        let Ok(shared) = self.dispatcher.leased_request(request.lease_id, &holder) else {
            return Ok(Response::new(v1::FailBatchResponse {}));
        };
        // One worker's word does not fail a job: the master checks the template and task
        // itself. If they are fine, the worker is at fault (say, an older version) and the
        // batch goes to another worker.
        let check = tokio::task::spawn_blocking(move || {
            hevo_sim_core::BatchEvaluator::new(shared.template.clone(), shared.task.clone())
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
        .await
        .unwrap_or_else(|e| Err(e.to_string()));
        match check {
            Ok(()) => {
                self.counters
                    .disputed_failures
                    .fetch_add(1, Ordering::Relaxed);
                tracing::warn!(worker = %holder, message = %request.message, "a worker could not evaluate a batch the master can; re-queued");
                let _ = self.dispatcher.release(request.lease_id, &holder);
            }
            Err(message) => {
                tracing::error!(worker = %holder, %message, "batch cannot be evaluated; failing its request");
                let _ = self.dispatcher.fail(request.lease_id, &holder, message);
            }
        }
        Ok(Response::new(v1::FailBatchResponse {}))
    }
}

fn lock_set(set: &Mutex<HashSet<String>>) -> std::sync::MutexGuard<'_, HashSet<String>> {
    set.lock().unwrap_or_else(|p| p.into_inner())
}
