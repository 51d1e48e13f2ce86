//! The scheduler between the evolutionary loops and the workers. A loop hands it an evaluation
//! request (genomes x samples of one generation); it splits the request into batches sized so
//! that every worker stays busy, queues them per job, and leases them to workers that ask,
//! round-robin across jobs so concurrent jobs share the workers fairly. Every lease has a
//! deadline, renewed by heartbeats up to a maximum lifetime: a batch whose worker dies, stalls
//! or never finishes is leased again. A lease belongs to the worker it was given to: only that
//! worker can extend, complete, release or fail it, so a result for anything but a live lease
//! of one's own changes nothing. Results are checked value by value against the batch they
//! answer before they are accepted, so a broken or hostile worker cannot corrupt a job. Batches
//! are sized so that neither a batch nor its results outgrow a message.
//!
//! In-process workers (local mode) and remote gRPC workers use the same `lease` / `complete`
//! calls, so local mode runs exactly the service's path.
//!
//! Time is an argument, as in quinn-proto: every method that needs it takes `now`, so the
//! scheduling rules are tested with made-up instants and no sleeping. The two async entry
//! points, [`Dispatcher::evaluate`] and the long-polling [`Dispatcher::lease`], are the edge
//! where the clock is read.

use hevo_sim_core::ControllerFile;
use hevo_sim_core::Sample;
use hevo_sim_core::SampleSummary;
use hevo_sim_core::TaskConfig;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::{Notify, oneshot};

/// What one evaluation request shares with all its batches.
#[derive(Debug)]
pub struct RequestShared {
    /// The controller template (the evolved node is the free one).
    pub template: ControllerFile,
    /// `template.content_hash()`, for worker caches.
    pub template_hash: String,
    /// The task.
    pub task: TaskConfig,
    /// `task_content_hash(task)`.
    pub task_hash: String,
    /// Nodes of the template's tree (what a result's node use must cover).
    pub n_nodes: usize,
    /// Genes of the free node (0 for a complete controller).
    pub n_genes: usize,
    /// Bytes of the template's and the task's JSON, which a batch carries to a worker that
    /// has not cached them.
    pub text_bytes: usize,
}

impl RequestShared {
    /// The template and task with their content hashes and sizes.
    pub fn new(template: ControllerFile, task: TaskConfig) -> RequestShared {
        RequestShared {
            template_hash: template.content_hash(),
            task_hash: hevo_sim_core::task_content_hash(&task),
            n_nodes: template.node_paths().len(),
            n_genes: template
                .free_node_topology()
                .map_or(0, |(_, topology)| topology.n_genes()),
            text_bytes: serde_json::to_string(&template).map_or(0, |text| text.len())
                + serde_json::to_string(&task).map_or(0, |text| text.len()),
            template,
            task,
        }
    }
}

/// One generation's (or one post-evaluation's) work.
#[derive(Debug, Clone)]
pub struct EvaluationRequest {
    /// The job it belongs to (fair sharing is per job).
    pub job: String,
    /// Template and task.
    pub shared: Arc<RequestShared>,
    /// The genomes; `None` genes for a template without a free node.
    pub genomes: Vec<Arc<[f32]>>,
    /// The samples every genome is evaluated on.
    pub samples: Arc<[Sample]>,
}

/// A leased batch: some genomes of a request, on a contiguous range of its samples.
#[derive(Debug, Clone)]
pub struct Batch {
    /// The batch.
    pub batch_id: u64,
    /// This lease of it.
    pub lease_id: u64,
    /// The job.
    pub job: String,
    /// Template and task.
    pub shared: Arc<RequestShared>,
    /// (genome index within the request, genes).
    pub genomes: Vec<(u32, Arc<[f32]>)>,
    /// The samples of this batch.
    pub samples: Arc<[Sample]>,
    /// When the lease ends unless extended.
    pub deadline: Instant,
}

/// What an evaluation request's results are, when they are all in.
pub type EvaluationResult = Result<Vec<Vec<SampleSummary>>, DispatchError>;

/// A submitted request's results to come (see [`Dispatcher::submit`]).
#[derive(Debug)]
pub struct PendingEvaluation(oneshot::Receiver<EvaluationResult>);

impl PendingEvaluation {
    /// Waits for the results.
    pub async fn wait(self) -> EvaluationResult {
        self.0.await.unwrap_or(Err(DispatchError::ShuttingDown))
    }

    /// The results if they are all in, without waiting.
    pub fn try_result(&mut self) -> Option<EvaluationResult> {
        match self.0.try_recv() {
            Ok(result) => Some(result),
            Err(oneshot::error::TryRecvError::Empty) => None,
            Err(oneshot::error::TryRecvError::Closed) => Some(Err(DispatchError::ShuttingDown)),
        }
    }
}

/// Why an evaluation request did not complete.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DispatchError {
    /// The job was cancelled.
    #[error("job {0} was cancelled")]
    Cancelled(String),
    /// A worker reported that the batch cannot be evaluated (bad template or task).
    #[error("batch could not be evaluated: {0}")]
    Failed(String),
    /// The dispatcher is shutting down.
    #[error("the dispatcher is shutting down")]
    ShuttingDown,
}

/// Why a worker's call about a lease was refused. Nothing changed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LeaseError {
    /// The lease is not live: it never existed, expired, was revoked, or its batch finished
    /// or was cancelled.
    #[error("lease {0} is not live")]
    NotLive(u64),
    /// The lease is held by another worker.
    #[error("lease {0} is held by another worker")]
    NotYours(u64),
    /// The lease is for another batch.
    #[error("lease {lease_id} is for batch {leased}, not batch {named}")]
    OtherBatch {
        /// The lease.
        lease_id: u64,
        /// Its batch.
        leased: u64,
        /// The batch the call named.
        named: u64,
    },
}

/// Why a returned result was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CompleteError {
    /// The result does not fit the batch (shape, or a value no evaluation could give): the
    /// batch is leased again.
    #[error("malformed result for batch {batch_id}: {message}")]
    Malformed {
        /// The batch.
        batch_id: u64,
        /// What is wrong.
        message: String,
    },
    /// Not a live lease of the caller's: nothing changed.
    #[error(transparent)]
    Lease(#[from] LeaseError),
}

/// Tuning.
#[derive(Debug, Clone)]
pub struct DispatchConfig {
    /// How long a lease lasts without a heartbeat.
    pub lease_timeout: Duration,
    /// How long a lease may last at all, heartbeats or not: a worker that heartbeats but never
    /// returns its batch loses it then, and the batch goes to another.
    pub max_lease_lifetime: Duration,
    /// The most bytes a batch, or a batch's results, may take on the wire (estimated
    /// generously); requests are cut finer where they would be larger.
    pub max_batch_bytes: usize,
    /// Batches per active worker a request is split into (more: better balance, more overhead).
    pub batches_per_worker: usize,
    /// Workers that asked for work within this window count as active.
    pub worker_window: Duration,
    /// The number of workers assumed before any has asked (local mode knows its threads).
    pub expected_workers: usize,
    /// The share of batches whose results are checked against an evaluation of the master's
    /// own before they are accepted (0: none). A worker's first result is always checked
    /// when the share is above 0; see [`Dispatcher::next_spot_check`].
    pub verify_share: f64,
}

impl Default for DispatchConfig {
    fn default() -> Self {
        DispatchConfig {
            lease_timeout: Duration::from_secs(30),
            max_lease_lifetime: Duration::from_secs(15 * 60),
            max_batch_bytes: 16 * 1024 * 1024,
            batches_per_worker: 3,
            worker_window: Duration::from_secs(30),
            expected_workers: 1,
            verify_share: 0.0,
        }
    }
}

/// Counters for metrics and progress.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DispatchStats {
    /// Workers seen within the window.
    pub active_workers: usize,
    /// Their threads, added up (what batches are sized for).
    pub active_threads: usize,
    /// Batches waiting for a worker.
    pub queued_batches: usize,
    /// Batches out on lease.
    pub leased_batches: usize,
    /// (genome, sample) evaluations accepted since start.
    pub evaluations: u64,
    /// Simulated control cycles accepted since start.
    pub cycles: u64,
    /// Leases that ran out and were re-queued.
    pub lease_expiries: u64,
    /// Results refused as malformed.
    pub malformed_results: u64,
    /// Calls refused because they named no live lease of the caller's (late duplicates
    /// included).
    pub refused_lease_calls: u64,
    /// Leases taken back before their deadline: the worker's connection closed, or the
    /// lease reached its maximum lifetime.
    pub lease_revocations: u64,
    /// Batches completed.
    pub batches_completed: u64,
    /// Results checked against the master's own evaluation.
    pub spot_checks: u64,
    /// Workers whose checked results differed from the master's: refused from then on.
    pub lying_workers: u64,
}

#[derive(Debug)]
struct BatchEntry {
    request_id: u64,
    job: String,
    genome_indices: Vec<u32>,
    sample_range: std::ops::Range<usize>,
    /// The current lease, if out.
    lease: Option<u64>,
    done: bool,
    /// The last refusal of a result for it, and how many refusals in a row said the same.
    refusals: Option<(String, usize)>,
    /// Results held for a spot check: the worker that sent them, and what it sent.
    checking: Option<(String, Vec<Vec<SampleSummary>>)>,
}

#[derive(Debug)]
struct RequestState {
    request: EvaluationRequest,
    results: Vec<Vec<Option<SampleSummary>>>,
    remaining_batches: usize,
    batch_ids: Vec<u64>,
    reply: Option<oneshot::Sender<EvaluationResult>>,
}

#[derive(Debug)]
struct LeaseEntry {
    batch_id: u64,
    worker: String,
    deadline: Instant,
    /// When it was given: its lifetime counts from here.
    granted: Instant,
}

#[derive(Debug, Default)]
struct State {
    /// Pending batch ids per job; jobs are served round-robin.
    pending: BTreeMap<String, VecDeque<u64>>,
    /// The job served last, for round-robin.
    last_job: Option<String>,
    batches: HashMap<u64, BatchEntry>,
    requests: HashMap<u64, RequestState>,
    leases: HashMap<u64, LeaseEntry>,
    /// Worker name -> (last seen, threads).
    workers: HashMap<String, (Instant, usize)>,
    next_id: u64,
    stats: DispatchStats,
    shutting_down: bool,
    /// Batches whose results wait for a spot check, oldest first.
    checks: VecDeque<u64>,
    /// Workers whose results passed a spot check.
    checked_workers: std::collections::HashSet<String>,
    /// Workers caught sending results that differ from the master's: never leased to again.
    refused_workers: std::collections::HashSet<String>,
    /// Per job, the workers whose results it accepted (kept while spot checks are on).
    contributors: HashMap<String, std::collections::HashSet<String>>,
}

/// The scheduler. Share it as `Arc<Dispatcher>`.
#[derive(Debug)]
pub struct Dispatcher {
    config: DispatchConfig,
    state: Mutex<State>,
    work_available: Notify,
    check_available: Notify,
}

impl Dispatcher {
    /// A dispatcher with the given tuning.
    pub fn new(config: DispatchConfig) -> Dispatcher {
        Dispatcher {
            config,
            state: Mutex::new(State {
                next_id: 1,
                ..State::default()
            }),
            work_available: Notify::new(),
            check_available: Notify::new(),
        }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while holding the lock cannot leave the maps half-updated in a way that
        // matters more than losing the whole master, so a poisoned lock is still used.
        self.state
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Evaluates every genome of the request on every sample; returns the summaries indexed
    /// `[genome][sample]`. Waits for workers; never fails because a worker died.
    pub async fn evaluate(
        &self,
        request: EvaluationRequest,
    ) -> Result<Vec<Vec<SampleSummary>>, DispatchError> {
        self.submit(request, Instant::now()).wait().await
    }

    /// Queues the request's batches (sized for the workers active at `now`) and returns what
    /// to wait on for its results.
    pub fn submit(&self, request: EvaluationRequest, now: Instant) -> PendingEvaluation {
        let (reply, wait) = oneshot::channel();
        let pending = PendingEvaluation(wait);
        {
            let mut state = self.lock();
            if state.shutting_down {
                let _ = reply.send(Err(DispatchError::ShuttingDown));
                return pending;
            }
            let n_genomes = request.genomes.len();
            let n_samples = request.samples.len();
            if n_genomes == 0 || n_samples == 0 {
                let _ = reply.send(Ok(vec![Vec::new(); n_genomes]));
                return pending;
            }
            let active = self
                .active_threads(&state, now)
                .max(self.config.expected_workers)
                .max(1);
            let target = active * self.config.batches_per_worker.max(1);
            let pieces = split(
                n_genomes,
                n_samples,
                target,
                &BatchBytes::of(&request.shared, &self.config),
            );
            let request_id = state.next_id;
            state.next_id += 1;
            let job = request.job.clone();
            let mut batch_ids = Vec::with_capacity(pieces.len());
            for (genome_indices, sample_range) in pieces {
                let batch_id = state.next_id;
                state.next_id += 1;
                state.batches.insert(
                    batch_id,
                    BatchEntry {
                        request_id,
                        job: job.clone(),
                        genome_indices,
                        sample_range,
                        lease: None,
                        done: false,
                        refusals: None,
                        checking: None,
                    },
                );
                state
                    .pending
                    .entry(job.clone())
                    .or_default()
                    .push_back(batch_id);
                batch_ids.push(batch_id);
            }
            state.stats.queued_batches += batch_ids.len();
            state.requests.insert(
                request_id,
                RequestState {
                    results: vec![vec![None; n_samples]; n_genomes],
                    remaining_batches: batch_ids.len(),
                    batch_ids,
                    request,
                    reply: Some(reply),
                },
            );
        }
        self.work_available.notify_waiters();
        pending
    }

    fn active(&self, state: &State, now: Instant) -> impl Iterator<Item = usize> {
        let window = self.config.worker_window;
        state
            .workers
            .values()
            .filter(move |(seen, _)| now.duration_since(*seen) < window)
            .map(|&(_, threads)| threads)
            .collect::<Vec<_>>()
            .into_iter()
    }

    fn active_threads(&self, state: &State, now: Instant) -> usize {
        self.active(state, now).sum()
    }

    /// Gives a worker that evaluates a batch on `threads` threads a batch, waiting up to
    /// `wait` for one (it counts as that many workers when requests are split into batches).
    /// Also expires overdue leases.
    pub async fn lease(&self, worker: &str, threads: usize, wait: Duration) -> Option<Batch> {
        let until = Instant::now() + wait;
        loop {
            // Register interest before looking, so a notification between the look and the
            // wait is not lost.
            let notified = self.work_available.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            let now = Instant::now();
            if let Some(batch) = self.try_lease(worker, threads, now) {
                return Some(batch);
            }
            // A shutting-down dispatcher answers long polls at once, so servers can stop.
            if now >= until || self.lock().shutting_down {
                return None;
            }
            // Wake at least every half second to expire leases even when nobody returns work.
            let nap = (until - now).min(Duration::from_millis(500));
            let _ = tokio::time::timeout(nap, notified).await;
        }
    }

    /// One non-blocking attempt, at `now`, to lease a batch to a worker with `threads` threads.
    pub fn try_lease(&self, worker: &str, threads: usize, now: Instant) -> Option<Batch> {
        let mut state = self.lock();
        state
            .workers
            .insert(worker.to_string(), (now, threads.max(1)));
        self.expire_leases(&mut state, now);
        if state.shutting_down || state.refused_workers.contains(worker) {
            return None;
        }
        // Round-robin: the first job after the one served last that has work.
        let jobs: Vec<String> = state
            .pending
            .iter()
            .filter(|(_, q)| !q.is_empty())
            .map(|(j, _)| j.clone())
            .collect();
        if jobs.is_empty() {
            return None;
        }
        let start = match &state.last_job {
            Some(last) => jobs.iter().position(|j| j > last).unwrap_or(0),
            None => 0,
        };
        let job = jobs[start].clone();
        let batch_id = state.pending.get_mut(&job).and_then(VecDeque::pop_front)?;
        state.last_job = Some(job.clone());
        let lease_id = state.next_id;
        state.next_id += 1;
        let deadline = now + self.config.lease_timeout;
        state.leases.insert(
            lease_id,
            LeaseEntry {
                batch_id,
                worker: worker.to_string(),
                deadline,
                granted: now,
            },
        );
        state.stats.queued_batches = state.stats.queued_batches.saturating_sub(1);
        state.stats.leased_batches += 1;
        let entry = state.batches.get_mut(&batch_id)?;
        entry.lease = Some(lease_id);
        let (request_id, genome_indices, range) = (
            entry.request_id,
            entry.genome_indices.clone(),
            entry.sample_range.clone(),
        );
        let request = &state.requests.get(&request_id)?.request;
        Some(Batch {
            batch_id,
            lease_id,
            job,
            shared: request.shared.clone(),
            genomes: genome_indices
                .iter()
                .map(|&g| (g, request.genomes[g as usize].clone()))
                .collect(),
            samples: request.samples[range].into(),
            deadline,
        })
    }

    fn expire_leases(&self, state: &mut State, now: Instant) {
        let mut expired: Vec<u64> = state
            .leases
            .iter()
            .filter(|(_, l)| l.deadline <= now)
            .map(|(&id, _)| id)
            .collect();
        // Each goes back to the front of its queue: the latest first, so that the batches
        // leased earliest are leased again first.
        expired.sort_unstable_by(|a, b| b.cmp(a));
        for lease_id in expired {
            if let Some(lease) = state.leases.remove(&lease_id) {
                tracing::warn!(lease_id, batch_id = lease.batch_id, worker = %lease.worker, "lease expired; batch re-queued");
                state.stats.lease_expiries += 1;
                state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
                requeue(state, lease.batch_id, lease_id);
            }
        }
    }

    /// The live lease `lease_id` if `worker` holds it (for `batch_id`, when given).
    fn held<'s>(
        state: &'s State,
        lease_id: u64,
        worker: &str,
        batch_id: Option<u64>,
    ) -> Result<&'s LeaseEntry, LeaseError> {
        let lease = state
            .leases
            .get(&lease_id)
            .ok_or(LeaseError::NotLive(lease_id))?;
        if lease.worker != worker {
            return Err(LeaseError::NotYours(lease_id));
        }
        if let Some(named) = batch_id
            && named != lease.batch_id
        {
            return Err(LeaseError::OtherBatch {
                lease_id,
                leased: lease.batch_id,
                named,
            });
        }
        Ok(lease)
    }

    /// Counts a refused call and passes its error on.
    fn refused<T>(state: &mut State, error: LeaseError) -> Result<T, LeaseError> {
        state.stats.refused_lease_calls += 1;
        Err(error)
    }

    /// Extends `worker`'s lease (its heartbeat). Refused when the lease is not the worker's
    /// live lease; a lease at its maximum lifetime is taken back instead, and its batch queued
    /// for another worker. Either way the worker may stop: its batch is not its own any more.
    pub fn extend(&self, lease_id: u64, worker: &str, now: Instant) -> Result<(), LeaseError> {
        let mut state = self.lock();
        let granted = match Self::held(&state, lease_id, worker, None) {
            Ok(lease) => lease.granted,
            Err(error) => return Self::refused(&mut state, error),
        };
        if now.duration_since(granted) >= self.config.max_lease_lifetime {
            tracing::warn!(
                lease_id,
                worker,
                "lease reached its maximum lifetime; batch re-queued"
            );
            revoke(&mut state, lease_id);
            drop(state);
            self.work_available.notify_waiters();
            return Err(LeaseError::NotLive(lease_id));
        }
        let deadline =
            (now + self.config.lease_timeout).min(granted + self.config.max_lease_lifetime);
        if let Some(lease) = state.leases.get_mut(&lease_id) {
            lease.deadline = deadline;
        }
        // A worker busy with a long batch is still an active worker.
        if let Some(seen) = state.workers.get_mut(worker) {
            seen.0 = now;
        }
        Ok(())
    }

    /// The template and task of the batch out on `worker`'s lease (to check a worker's claim
    /// that they cannot be evaluated).
    pub fn leased_request(
        &self,
        lease_id: u64,
        worker: &str,
    ) -> Result<Arc<RequestShared>, LeaseError> {
        let mut state = self.lock();
        let batch_id = match Self::held(&state, lease_id, worker, None) {
            Ok(lease) => lease.batch_id,
            Err(error) => return Self::refused(&mut state, error),
        };
        state
            .batches
            .get(&batch_id)
            .and_then(|batch| state.requests.get(&batch.request_id))
            .map(|request| request.request.shared.clone())
            .ok_or(LeaseError::NotLive(lease_id))
    }

    /// A worker hands its batch back unfinished (for example on SIGTERM): it is queued again
    /// at the front.
    pub fn release(&self, lease_id: u64, worker: &str) -> Result<(), LeaseError> {
        let mut state = self.lock();
        if let Err(error) = Self::held(&state, lease_id, worker, None) {
            return Self::refused(&mut state, error);
        }
        revoke(&mut state, lease_id);
        state.stats.lease_revocations = state.stats.lease_revocations.saturating_sub(1);
        drop(state);
        self.work_available.notify_waiters();
        Ok(())
    }

    /// Takes back every lease `worker` holds (its connection closed: it cannot return them),
    /// queueing their batches for others at once, and forgets the worker. Returns how many.
    pub fn revoke_worker(&self, worker: &str) -> usize {
        let mut state = self.lock();
        let mut held: Vec<u64> = state
            .leases
            .iter()
            .filter(|(_, lease)| lease.worker == worker)
            .map(|(&id, _)| id)
            .collect();
        // Latest first to the front of the queue, so the earliest batch is leased first.
        held.sort_unstable_by(|a, b| b.cmp(a));
        for &lease_id in &held {
            tracing::warn!(lease_id, worker = %worker, "worker gone; its batch re-queued");
            revoke(&mut state, lease_id);
        }
        state.workers.remove(worker);
        drop(state);
        if !held.is_empty() {
            self.work_available.notify_waiters();
        }
        held.len()
    }

    /// A worker reports that its batch cannot be evaluated at all (its template or task is
    /// invalid): the whole request fails, since every worker would fail the same way.
    pub fn fail(&self, lease_id: u64, worker: &str, message: String) -> Result<(), LeaseError> {
        let mut state = self.lock();
        let batch_id = match Self::held(&state, lease_id, worker, None) {
            Ok(lease) => lease.batch_id,
            Err(error) => return Self::refused(&mut state, error),
        };
        state.leases.remove(&lease_id);
        state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        if let Some(request_id) = state.batches.get(&batch_id).map(|b| b.request_id) {
            finish_request(&mut state, request_id, Err(DispatchError::Failed(message)));
        }
        Ok(())
    }

    /// `worker` returns the summaries of the batch on its lease, indexed by the batch's genome,
    /// then its sample. Only the live lease's holder may; each summary is checked against the
    /// task and the sample it answers. A malformed result is refused and the batch leased
    /// again; a call naming no live lease of the worker's (a late duplicate, a forged lease)
    /// changes nothing.
    pub fn complete(
        &self,
        lease_id: u64,
        batch_id: u64,
        worker: &str,
        results: Vec<Vec<SampleSummary>>,
    ) -> Result<(), CompleteError> {
        let mut state = self.lock();
        if let Err(error) = Self::held(&state, lease_id, worker, Some(batch_id)) {
            return Ok(Self::refused(&mut state, error)?);
        }
        let problem = {
            let entry = state
                .batches
                .get(&batch_id)
                .ok_or(LeaseError::NotLive(lease_id))?;
            let request = state
                .requests
                .get(&entry.request_id)
                .ok_or(LeaseError::NotLive(lease_id))?;
            check_results(entry, &request.request, &results)
        };
        if let Some(message) = problem {
            state.stats.malformed_results += 1;
            if same_refusal_again(&mut state, batch_id, &message) >= MAX_SAME_REFUSALS {
                // Evaluation is deterministic: a batch refused for the same reason this often
                // would be refused for ever (a task whose fitness is not a number, say).
                tracing::warn!(batch_id, worker, %message, "refused a malformed result again; the evaluation fails");
                state.leases.remove(&lease_id);
                state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
                if let Some(request_id) = state.batches.get(&batch_id).map(|b| b.request_id) {
                    finish_request(
                        &mut state,
                        request_id,
                        Err(DispatchError::Failed(format!(
                            "the results of a batch were refused {MAX_SAME_REFUSALS} times for the same reason: {message}"
                        ))),
                    );
                }
                return Err(CompleteError::Malformed { batch_id, message });
            }
            tracing::warn!(batch_id, worker, %message, "refused a malformed result; batch re-queued");
            revoke(&mut state, lease_id);
            state.stats.lease_revocations = state.stats.lease_revocations.saturating_sub(1);
            drop(state);
            self.work_available.notify_waiters();
            return Err(CompleteError::Malformed { batch_id, message });
        }

        state.leases.remove(&lease_id);
        state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        if self.config.verify_share > 0.0
            && (!state.checked_workers.contains(worker)
                || chosen_for_check(batch_id, self.config.verify_share))
        {
            // Held until the master's own evaluation of the batch says whether they are true.
            let entry = state.batches.get_mut(&batch_id).expect("checked above");
            entry.lease = None;
            entry.checking = Some((worker.to_string(), results));
            state.checks.push_back(batch_id);
            drop(state);
            self.check_available.notify_one();
            return Ok(());
        }
        accept(
            &mut state,
            batch_id,
            worker,
            results,
            self.config.verify_share > 0.0,
        );
        Ok(())
    }

    /// The next batch whose results wait for a spot check, waiting for one; `None` once the
    /// dispatcher is shutting down. The caller evaluates the batch itself (evaluation is
    /// deterministic, so the true results are its own) and passes them to
    /// [`Dispatcher::settle_spot_check`].
    pub async fn next_spot_check(&self) -> Option<Batch> {
        loop {
            let notified = self.check_available.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            {
                let mut state = self.lock();
                if state.shutting_down {
                    return None;
                }
                while let Some(batch_id) = state.checks.pop_front() {
                    if let Some(batch) = held_batch(&state, batch_id) {
                        return Some(batch);
                    }
                }
            }
            notified.await;
        }
    }

    /// Settles a spot check of `batch_id` with the master's own results `truth`: the worker's
    /// results are accepted when they are the same bit for bit; otherwise the master's are,
    /// the worker is refused from then on (its leases taken back), and the jobs that accepted
    /// any result of its are returned, for their runs to be evaluated again from the start.
    pub fn settle_spot_check(
        &self,
        batch_id: u64,
        truth: Vec<Vec<SampleSummary>>,
    ) -> Option<LyingWorker> {
        let mut state = self.lock();
        let (worker, claimed) = state.batches.get_mut(&batch_id)?.checking.take()?;
        state.stats.spot_checks += 1;
        if same_bits(&claimed, &truth) {
            state.checked_workers.insert(worker.clone());
            accept(&mut state, batch_id, &worker, truth, true);
            return None;
        }
        tracing::warn!(
            batch_id,
            worker,
            "a worker's results differ from the master's own evaluation: the worker is refused from now on"
        );
        state.stats.lying_workers += 1;
        state.refused_workers.insert(worker.clone());
        let held: Vec<u64> = state
            .leases
            .iter()
            .filter(|(_, lease)| lease.worker == worker)
            .map(|(&id, _)| id)
            .collect();
        for lease_id in held {
            revoke(&mut state, lease_id);
        }
        let job = state.batches.get(&batch_id).map(|b| b.job.clone());
        accept(&mut state, batch_id, "master", truth, true);
        let mut jobs: Vec<String> = state
            .contributors
            .iter()
            .filter(|(_, workers)| workers.contains(&worker))
            .map(|(job, _)| job.clone())
            .collect();
        // Results it sent for batches still waiting for a check are dropped and queued again.
        let waiting: Vec<u64> = state.checks.iter().copied().collect();
        for other in waiting {
            if let Some(entry) = state.batches.get_mut(&other)
                && entry.checking.as_ref().is_some_and(|(w, _)| *w == worker)
            {
                entry.checking = None;
                requeue(&mut state, other, 0);
            }
        }
        jobs.extend(job);
        jobs.sort();
        jobs.dedup();
        drop(state);
        self.work_available.notify_waiters();
        Some(LyingWorker { worker, jobs })
    }

    /// Fails the request of a batch held for a spot check that the master could not evaluate
    /// itself (every worker would fail it too).
    pub fn fail_spot_check(&self, batch_id: u64, message: String) {
        let mut state = self.lock();
        if let Some(request_id) = state.batches.get(&batch_id).map(|b| b.request_id) {
            finish_request(&mut state, request_id, Err(DispatchError::Failed(message)));
        }
    }

    /// Forgets which workers a job's results came from (its runs start again from scratch).
    pub fn forget_contributors(&self, job: &str) {
        self.lock().contributors.remove(job);
    }
}

/// A worker caught by a spot check, and the jobs that accepted results of its.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LyingWorker {
    /// The worker.
    pub worker: String,
    /// The jobs.
    pub jobs: Vec<String>,
}

/// Whether batch `batch_id` is among the share checked: a fixed hash of its id, so the choice
/// does not depend on timing and cannot be steered by a worker.
fn chosen_for_check(batch_id: u64, share: f64) -> bool {
    // SplitMix64's finaliser: every bit of the id moves every bit of the hash.
    let mut mixed = batch_id ^ 0x5b0d_c4ec_6e1f_a3d1;
    mixed = (mixed ^ (mixed >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    mixed = (mixed ^ (mixed >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    mixed ^= mixed >> 31;
    ((mixed >> 11) as f64) / ((1u64 << 53) as f64) < share
}

/// Whether two sets of results are the same bit for bit (fitness and descriptor compared as
/// bits, so that even a sign of zero counts).
fn same_bits(a: &[Vec<SampleSummary>], b: &[Vec<SampleSummary>]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(a, b)| {
            a.len() == b.len()
                && a.iter().zip(b).all(|(a, b)| {
                    let bits = |s: &SampleSummary| {
                        std::iter::once(s.fitness)
                            .chain(s.descriptor.iter().copied())
                            .map(f32::to_bits)
                            .collect::<Vec<u32>>()
                    };
                    let rest = |s: &SampleSummary| SampleSummary {
                        fitness: 0.0,
                        descriptor: Vec::new(),
                        ..s.clone()
                    };
                    bits(a) == bits(b) && rest(a) == rest(b)
                })
        })
}

/// Batch `batch_id` as a worker would have leased it, with no lease (for a spot check).
fn held_batch(state: &State, batch_id: u64) -> Option<Batch> {
    let entry = state.batches.get(&batch_id)?;
    entry.checking.as_ref()?;
    let request = &state.requests.get(&entry.request_id)?.request;
    Some(Batch {
        batch_id,
        lease_id: 0,
        job: entry.job.clone(),
        shared: request.shared.clone(),
        genomes: entry
            .genome_indices
            .iter()
            .map(|&g| (g, request.genomes[g as usize].clone()))
            .collect(),
        samples: request.samples[entry.sample_range.clone()].into(),
        deadline: Instant::now(),
    })
}

/// Accepts `results` (checked, and spot-checked when asked) for batch `batch_id` into its
/// request, finishing the request when it was the last; `worker` is remembered as a
/// contributor of the job when `track` is set.
fn accept(
    state: &mut State,
    batch_id: u64,
    worker: &str,
    results: Vec<Vec<SampleSummary>>,
    track: bool,
) {
    let Some(entry) = state.batches.get_mut(&batch_id) else {
        return;
    };
    if entry.done {
        return;
    }
    entry.done = true;
    entry.lease = None;
    let (job, request_id, genome_indices, range) = (
        entry.job.clone(),
        entry.request_id,
        entry.genome_indices.clone(),
        entry.sample_range.clone(),
    );
    if track {
        state
            .contributors
            .entry(job)
            .or_default()
            .insert(worker.to_string());
    }
    let Some(request) = state.requests.get_mut(&request_id) else {
        return;
    };
    let mut cycles = 0u64;
    let mut evaluations = 0u64;
    for (genome_results, &genome_idx) in results.into_iter().zip(&genome_indices) {
        for (summary, sample_idx) in genome_results.into_iter().zip(range.clone()) {
            cycles += u64::from(summary.cycles);
            evaluations += 1;
            request.results[genome_idx as usize][sample_idx] = Some(summary);
        }
    }
    request.remaining_batches -= 1;
    let finished = request.remaining_batches == 0;
    state.stats.cycles += cycles;
    state.stats.evaluations += evaluations;
    state.stats.batches_completed += 1;
    if finished {
        let request = state.requests.get_mut(&request_id).expect("present");
        // The request is finished, so its results can move out rather than be copied.
        let results: Option<Vec<Vec<SampleSummary>>> = std::mem::take(&mut request.results)
            .into_iter()
            .map(|genome| genome.into_iter().collect::<Option<Vec<_>>>())
            .collect();
        let outcome = results
            .ok_or_else(|| DispatchError::Failed("internal: a finished request has holes".into()));
        finish_request(state, request_id, outcome);
    }
}

impl Dispatcher {
    /// Drops every queued batch of a job and fails its waiting requests.
    pub fn cancel_job(&self, job: &str) {
        let mut state = self.lock();
        let request_ids: Vec<u64> = state
            .requests
            .iter()
            .filter(|(_, r)| r.request.job == job)
            .map(|(&id, _)| id)
            .collect();
        for request_id in request_ids {
            finish_request(
                &mut state,
                request_id,
                Err(DispatchError::Cancelled(job.to_string())),
            );
        }
    }

    /// Stops handing out work and fails every waiting request.
    pub fn shut_down(&self) {
        let mut state = self.lock();
        state.shutting_down = true;
        let request_ids: Vec<u64> = state.requests.keys().copied().collect();
        for request_id in request_ids {
            finish_request(&mut state, request_id, Err(DispatchError::ShuttingDown));
        }
        drop(state);
        self.work_available.notify_waiters();
        self.check_available.notify_waiters();
    }

    /// The share of batches checked against the master's own evaluation (0: none).
    pub fn verify_share(&self) -> f64 {
        self.config.verify_share
    }

    /// The workers a spot check caught, refused from then on, in name order.
    pub fn refused_workers(&self) -> Vec<String> {
        let mut workers: Vec<String> = self.lock().refused_workers.iter().cloned().collect();
        workers.sort();
        workers
    }

    /// A snapshot of the counters, with the workers active at `now`.
    pub fn stats(&self, now: Instant) -> DispatchStats {
        let state = self.lock();
        DispatchStats {
            active_workers: self.active(&state, now).count(),
            active_threads: self.active_threads(&state, now),
            ..state.stats.clone()
        }
    }
}

/// How many times in a row a batch's results may be refused for the same reason before its
/// request fails with that reason. Evaluation is deterministic, so the same refusal again means
/// any worker would give the same result; a refusal for another reason starts the count anew.
pub const MAX_SAME_REFUSALS: usize = 3;

/// Counts a refusal of a batch's result: how many refusals in a row have given `message`.
fn same_refusal_again(state: &mut State, batch_id: u64, message: &str) -> usize {
    let Some(entry) = state.batches.get_mut(&batch_id) else {
        return 0;
    };
    let count = match &entry.refusals {
        Some((last, count)) if last == message => count + 1,
        _ => 1,
    };
    entry.refusals = Some((message.to_string(), count));
    count
}

/// Takes a live lease back before its deadline and queues its batch again at the front.
fn revoke(state: &mut State, lease_id: u64) {
    if let Some(lease) = state.leases.remove(&lease_id) {
        state.stats.lease_revocations += 1;
        state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        requeue(state, lease.batch_id, lease_id);
    }
}

/// What is wrong with a batch's results, if anything: their shape, and every summary checked
/// against the task and the sample it answers.
fn check_results(
    entry: &BatchEntry,
    request: &EvaluationRequest,
    results: &[Vec<SampleSummary>],
) -> Option<String> {
    let n_samples = entry.sample_range.len();
    if results.len() != entry.genome_indices.len() {
        return Some(format!(
            "{} genomes returned, batch has {}",
            results.len(),
            entry.genome_indices.len()
        ));
    }
    let shared = &request.shared;
    for (genome_idx, genome_results) in results.iter().enumerate() {
        if genome_results.len() != n_samples {
            return Some(format!(
                "genome {genome_idx} has {} samples, batch has {n_samples}",
                genome_results.len()
            ));
        }
        let samples = &request.samples[entry.sample_range.clone()];
        for (sample_idx, (summary, sample)) in genome_results.iter().zip(samples).enumerate() {
            if let Err(message) = summary.check(&shared.task, shared.n_nodes, sample) {
                return Some(format!(
                    "genome {genome_idx}, sample {sample_idx}: {message}"
                ));
            }
        }
    }
    None
}

/// Puts a batch back at the front of its job's queue unless it is done or already queued.
fn requeue(state: &mut State, batch_id: u64, lease_id: u64) {
    let Some(entry) = state.batches.get_mut(&batch_id) else {
        return;
    };
    if entry.done || (entry.lease.is_some() && entry.lease != Some(lease_id)) {
        return;
    }
    entry.lease = None;
    let job = entry.job.clone();
    let queue = state.pending.entry(job).or_default();
    if !queue.contains(&batch_id) {
        queue.push_front(batch_id);
        state.stats.queued_batches += 1;
    }
}

/// Removes a request and its batches, leases and queue entries, and replies.
fn finish_request(state: &mut State, request_id: u64, outcome: EvaluationResult) {
    let Some(mut request) = state.requests.remove(&request_id) else {
        return;
    };
    for batch_id in &request.batch_ids {
        if let Some(entry) = state.batches.remove(batch_id) {
            if let Some(lease) = entry.lease
                && state.leases.remove(&lease).is_some()
            {
                state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
            }
            if let Some(queue) = state.pending.get_mut(&entry.job)
                && let Some(pos) = queue.iter().position(|b| b == batch_id)
            {
                queue.remove(pos);
                state.stats.queued_batches = state.stats.queued_batches.saturating_sub(1);
            }
        }
    }
    state.pending.retain(|_, q| !q.is_empty());
    if let Some(reply) = request.reply.take() {
        let _ = reply.send(outcome);
    }
}

/// A generous estimate of a batch's size on the wire, and of its results'.
#[derive(Debug, Clone, Copy)]
struct BatchBytes {
    /// Template and task text, and the message's own fields.
    fixed: usize,
    /// One genome: its genes and index.
    per_genome: usize,
    /// One sample of the batch: its seed and variant.
    per_sample: usize,
    /// One (genome, sample) result: the summary's fields and its node use.
    per_result: usize,
    /// The limit.
    limit: usize,
}

impl BatchBytes {
    fn of(shared: &RequestShared, config: &DispatchConfig) -> BatchBytes {
        BatchBytes {
            fixed: 4096 + shared.text_bytes,
            per_genome: 16 + 5 * shared.n_genes,
            per_sample: 24,
            per_result: 64 + 12 * shared.n_nodes,
            limit: config.max_batch_bytes.max(1),
        }
    }

    /// The most whole genomes (each with all `n_samples` samples) a batch may hold, or 0 when
    /// not even one fits and its samples must be split.
    fn genomes_per_batch(&self, n_samples: usize) -> usize {
        let room = self
            .limit
            .saturating_sub(self.fixed + self.per_sample * n_samples);
        room / (self.per_genome + self.per_result * n_samples).max(1)
    }

    /// The most samples of one genome a batch may hold (at least one).
    fn samples_per_batch(&self) -> usize {
        let room = self.limit.saturating_sub(self.fixed + self.per_genome);
        (room / (self.per_sample + self.per_result).max(1)).max(1)
    }
}

/// Splits genomes x samples into about `target` batches, none larger than `bytes` allows:
/// whole genomes when there are enough of them, otherwise each genome's samples in contiguous
/// pieces (post-evaluation of one genome, or genomes too large for one batch).
fn split(
    n_genomes: usize,
    n_samples: usize,
    target: usize,
    bytes: &BatchBytes,
) -> Vec<(Vec<u32>, std::ops::Range<usize>)> {
    let fitting = bytes.genomes_per_batch(n_samples);
    if fitting > 0 && n_genomes >= target {
        let per_batch = n_genomes.div_ceil(target).min(fitting);
        (0..n_genomes)
            .collect::<Vec<_>>()
            .chunks(per_batch)
            .map(|chunk| (chunk.iter().map(|&g| g as u32).collect(), 0..n_samples))
            .collect()
    } else {
        let pieces = target.div_ceil(n_genomes).min(n_samples);
        let per_piece = n_samples
            .div_ceil(pieces)
            .min(bytes.samples_per_batch())
            .max(1);
        (0..n_genomes)
            .flat_map(|g| {
                (0..n_samples)
                    .step_by(per_piece)
                    .map(move |start| (vec![g as u32], start..(start + per_piece).min(n_samples)))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::NodeSpec;
    use hevo_sim_core::TaskConfig;

    fn request(job: &str, n_genomes: usize, n_samples: usize) -> EvaluationRequest {
        let template = ControllerFile::new(NodeSpec::primitive("p", vec![InputGroup::IR], 1));
        let task = TaskConfig::shipped("follow_wall").unwrap();
        EvaluationRequest {
            job: job.into(),
            shared: Arc::new(RequestShared::new(template, task)),
            genomes: (0..n_genomes)
                .map(|g| Arc::from(vec![g as f32; 3]))
                .collect(),
            samples: (0..n_samples).map(|s| Sample::seeded(s as u64)).collect(),
        }
    }

    /// A fake evaluation, within follow wall's fitness range: a hundredth of the genome's first
    /// gene plus a thousandth of the sample's seed.
    fn fake(batch: &Batch) -> Vec<Vec<SampleSummary>> {
        batch
            .genomes
            .iter()
            .map(|(_, genes)| {
                batch
                    .samples
                    .iter()
                    .map(|s| SampleSummary {
                        fitness: expected_fitness(genes[0], s.seed),
                        solved: false,
                        collided: false,
                        stage: 0,
                        variant: 0,
                        cycles: 10,
                        descriptor: vec![0.0; hevo_sim_core::DEFAULT_DESCRIPTOR.len()],
                        ..SampleSummary::default()
                    })
                    .collect()
            })
            .collect()
    }

    fn expected_fitness(first_gene: f32, seed: u64) -> f32 {
        first_gene * 0.01 + seed as f32 * 0.001
    }

    /// No byte limit worth the name: batches are cut by count alone.
    fn unlimited() -> BatchBytes {
        BatchBytes {
            fixed: 0,
            per_genome: 1,
            per_sample: 1,
            per_result: 1,
            limit: usize::MAX,
        }
    }

    #[test]
    fn split_covers_everything_once() {
        for (g, s, t) in [
            (100, 50, 12),
            (1, 400, 12),
            (3, 7, 20),
            (5, 1, 3),
            (7, 3, 7),
        ] {
            let pieces = split(g, s, t, &unlimited());
            let mut seen = vec![vec![0; s]; g];
            for (genomes, range) in pieces {
                for genome in genomes {
                    for sample in range.clone() {
                        seen[genome as usize][sample] += 1;
                    }
                }
            }
            assert!(seen.iter().flatten().all(|&n| n == 1), "{g} {s} {t}");
        }
    }

    /// Leases and completes every batch there is at `now`, as one worker.
    fn drain(dispatcher: &Dispatcher, worker: &str, now: Instant) -> usize {
        let mut n_batches = 0;
        while let Some(batch) = dispatcher.try_lease(worker, 1, now) {
            assert_eq!(
                dispatcher.complete(batch.lease_id, batch.batch_id, worker, fake(&batch)),
                Ok(())
            );
            n_batches += 1;
        }
        n_batches
    }

    #[test]
    fn a_request_completes_through_leases() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 10, 4), now);
        assert!(pending.try_result().is_none());
        assert!(drain(&dispatcher, "w", now) > 0);
        let results = pending.try_result().expect("complete").unwrap();
        assert_eq!(results.len(), 10);
        for (g, genome) in results.iter().enumerate() {
            for (s, summary) in genome.iter().enumerate() {
                assert_eq!(summary.fitness, expected_fitness(g as f32, s as u64));
            }
        }
        assert_eq!(dispatcher.stats(now).evaluations, 40);
    }

    #[test]
    fn leases_expire_after_the_timeout_unless_extended() {
        let timeout = Duration::from_secs(30);
        let dispatcher = Dispatcher::new(DispatchConfig {
            lease_timeout: timeout,
            ..DispatchConfig::default()
        });
        let t0 = Instant::now();
        let mut pending = dispatcher.submit(request("j", 1, 3), t0);
        // A worker takes every batch and "dies"; another keeps its one lease alive.
        let mut dead = Vec::new();
        while let Some(batch) = dispatcher.try_lease("dead", 1, t0) {
            dead.push(batch);
        }
        assert!(dead.len() >= 2);
        let kept = dead.pop().unwrap();
        let just_before = t0 + timeout - Duration::from_millis(1);
        assert_eq!(
            dispatcher.extend(kept.lease_id, "dead", just_before),
            Ok(())
        );
        assert!(dispatcher.try_lease("alive", 1, just_before).is_none());
        // At the deadline the others are leased again; the extended one is not.
        let expired = t0 + timeout;
        let mut redone = Vec::new();
        while let Some(batch) = dispatcher.try_lease("alive", 1, expired) {
            redone.push(batch);
        }
        assert_eq!(
            redone.iter().map(|b| b.batch_id).collect::<Vec<_>>(),
            dead.iter().map(|b| b.batch_id).collect::<Vec<_>>(),
            "re-queued at the front in lease order, each once"
        );
        assert_eq!(dispatcher.stats(expired).lease_expiries, dead.len() as u64);
        for batch in &redone {
            dispatcher
                .complete(batch.lease_id, batch.batch_id, "alive", fake(batch))
                .unwrap();
        }
        dispatcher
            .complete(kept.lease_id, kept.batch_id, "dead", fake(&kept))
            .unwrap();
        assert_eq!(pending.try_result().expect("complete").unwrap()[0].len(), 3);
        // The dead worker comes back late: its expired leases are not live, nothing changes.
        for batch in &dead {
            assert_eq!(
                dispatcher.complete(batch.lease_id, batch.batch_id, "dead", fake(batch)),
                Err(CompleteError::Lease(LeaseError::NotLive(batch.lease_id)))
            );
        }
        assert_eq!(
            dispatcher.stats(expired).refused_lease_calls,
            dead.len() as u64
        );
    }

    #[test]
    fn malformed_results_are_refused_and_the_batch_requeued() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 2, 2), now);
        let batch = dispatcher.try_lease("bad", 1, now).unwrap();
        let mut wrong = fake(&batch);
        wrong[0].pop();
        assert!(matches!(
            dispatcher.complete(batch.lease_id, batch.batch_id, "bad", wrong),
            Err(CompleteError::Malformed { .. })
        ));
        let mut nan = fake(&batch);
        nan[0][0].fitness = f32::NAN;
        let again = dispatcher.try_lease("bad", 1, now).unwrap();
        assert_eq!(again.batch_id, batch.batch_id);
        assert!(
            dispatcher
                .complete(again.lease_id, again.batch_id, "bad", nan)
                .is_err()
        );
        drain(&dispatcher, "good", now);
        let results = pending.try_result().expect("complete").unwrap();
        assert_eq!(results[1][1].fitness, expected_fitness(1.0, 1));
        assert_eq!(dispatcher.stats(now).malformed_results, 2);
    }

    #[test]
    fn a_batch_refused_for_the_same_reason_again_and_again_fails_its_request() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 1, 1), now);
        // Refusals for different reasons do not count towards each other.
        let batch = dispatcher.try_lease("w", 1, now).unwrap();
        let mut short = fake(&batch);
        short[0].pop();
        assert!(
            dispatcher
                .complete(batch.lease_id, batch.batch_id, "w", short)
                .is_err()
        );
        for attempt in 1..=MAX_SAME_REFUSALS {
            assert!(
                pending.try_result().is_none(),
                "failed after {attempt} refusals"
            );
            let batch = dispatcher.try_lease("w", 1, now).expect("re-queued");
            let mut nan = fake(&batch);
            nan[0][0].fitness = f32::NAN;
            assert!(
                dispatcher
                    .complete(batch.lease_id, batch.batch_id, "w", nan)
                    .is_err()
            );
        }
        match pending.try_result() {
            Some(Err(DispatchError::Failed(message))) => {
                assert!(message.contains("refused 3 times"), "{message}");
                assert!(message.contains("fitness NaN"), "{message}");
            }
            other => panic!("expected the request to fail, got {other:?}"),
        }
        assert!(dispatcher.try_lease("w", 1, now).is_none());
        assert_eq!(dispatcher.stats(now).leased_batches, 0);
        assert_eq!(dispatcher.stats(now).queued_batches, 0);
    }

    #[tokio::test]
    async fn a_spot_check_refuses_a_worker_whose_results_differ_from_the_masters() {
        let dispatcher = Dispatcher::new(DispatchConfig {
            verify_share: 1.0,
            ..DispatchConfig::default()
        });
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 2, 2), now);
        // An honest worker's result is held, checked, and then accepted.
        let batch = dispatcher.try_lease("honest", 1, now).unwrap();
        dispatcher
            .complete(batch.lease_id, batch.batch_id, "honest", fake(&batch))
            .unwrap();
        assert!(pending.try_result().is_none(), "held for its check");
        let check = dispatcher.next_spot_check().await.unwrap();
        assert_eq!(check.batch_id, batch.batch_id);
        assert_eq!(
            dispatcher.settle_spot_check(check.batch_id, fake(&check)),
            None
        );
        // A liar's plausible result (in range, one fitness a little off) is caught.
        let forged_batch = dispatcher.try_lease("liar", 1, now).unwrap();
        let mut forged = fake(&forged_batch);
        forged[0][0].fitness += 0.001;
        dispatcher
            .complete(forged_batch.lease_id, forged_batch.batch_id, "liar", forged)
            .unwrap();
        let check = dispatcher.next_spot_check().await.unwrap();
        let caught = dispatcher
            .settle_spot_check(check.batch_id, fake(&check))
            .expect("caught");
        assert_eq!(caught.worker, "liar");
        assert_eq!(caught.jobs, ["j"]);
        assert!(
            dispatcher.try_lease("liar", 1, now).is_none(),
            "refused from now on"
        );
        // The rest, each held for its check and settled with the master's own results.
        loop {
            drain(&dispatcher, "honest", now);
            let next =
                tokio::time::timeout(Duration::from_millis(20), dispatcher.next_spot_check());
            match next.await {
                Ok(Some(check)) => {
                    assert_eq!(
                        dispatcher.settle_spot_check(check.batch_id, fake(&check)),
                        None
                    );
                }
                _ => break,
            }
        }
        // Every result is the true one.
        let results = pending.try_result().expect("complete").unwrap();
        for (genome_idx, genome) in results.iter().enumerate() {
            for (sample_idx, summary) in genome.iter().enumerate() {
                assert_eq!(
                    summary.fitness,
                    expected_fitness(genome_idx as f32, sample_idx as u64)
                );
            }
        }
        let stats = dispatcher.stats(now);
        assert!(stats.spot_checks >= 2, "{stats:?}");
        assert_eq!(stats.lying_workers, 1);
    }

    #[test]
    fn without_spot_checks_nothing_is_held() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 1, 1), now);
        let batch = dispatcher.try_lease("w", 1, now).unwrap();
        dispatcher
            .complete(batch.lease_id, batch.batch_id, "w", fake(&batch))
            .unwrap();
        assert!(pending.try_result().is_some());
        assert_eq!(dispatcher.stats(now).spot_checks, 0);
    }

    #[test]
    fn a_fixed_share_of_batches_is_chosen_for_checks() {
        let chosen = (0..100_000u64)
            .filter(|&id| chosen_for_check(id, 0.1))
            .count();
        assert!((9_000..11_000).contains(&chosen), "{chosen}");
        assert!(!(0..1000u64).any(|id| chosen_for_check(id, 0.0)));
    }

    #[test]
    fn jobs_are_served_round_robin() {
        let dispatcher = Dispatcher::new(DispatchConfig {
            expected_workers: 4,
            ..DispatchConfig::default()
        });
        let now = Instant::now();
        let mut job_a = dispatcher.submit(request("a", 12, 1), now);
        let mut job_b = dispatcher.submit(request("b", 12, 1), now);
        let mut order = Vec::new();
        while let Some(batch) = dispatcher.try_lease("w", 1, now) {
            order.push(batch.job.clone());
            dispatcher
                .complete(batch.lease_id, batch.batch_id, "w", fake(&batch))
                .unwrap();
        }
        // Alternating while both have work.
        assert!(order.windows(2).take(8).all(|w| w[0] != w[1]), "{order:?}");
        job_a.try_result().unwrap().unwrap();
        job_b.try_result().unwrap().unwrap();
    }

    #[test]
    fn batches_are_sized_by_the_active_workers_threads() {
        let window = Duration::from_secs(30);
        let dispatcher = Dispatcher::new(DispatchConfig {
            worker_window: window,
            ..DispatchConfig::default()
        });
        let t0 = Instant::now();
        // One worker with 4 threads: 4 x 3 batches for 24 genomes.
        assert!(dispatcher.try_lease("big", 4, t0).is_none());
        let mut pending = dispatcher.submit(request("j", 24, 1), t0);
        let mut sizes = Vec::new();
        while let Some(batch) = dispatcher.try_lease("big", 4, t0) {
            sizes.push(batch.genomes.len());
            assert_eq!(dispatcher.extend(batch.lease_id, "big", t0), Ok(()));
            assert!(dispatcher.leased_request(batch.lease_id, "big").is_ok());
            dispatcher
                .complete(batch.lease_id, batch.batch_id, "big", fake(&batch))
                .unwrap();
        }
        assert_eq!(sizes, vec![2; 12]);
        pending.try_result().unwrap().unwrap();
        let stats = dispatcher.stats(t0);
        assert_eq!((stats.active_workers, stats.active_threads), (1, 4));
        // A worker not seen for the window no longer counts: batches are sized for one.
        let later = t0 + window;
        assert_eq!(dispatcher.stats(later).active_workers, 0);
        let _pending = dispatcher.submit(request("j", 24, 1), later);
        assert_eq!(dispatcher.stats(later).queued_batches, 3);
    }

    #[tokio::test]
    async fn shutting_down_answers_long_polls_at_once() {
        let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
        let d = dispatcher.clone();
        let poll = tokio::spawn(async move { d.lease("w", 1, Duration::from_secs(30)).await });
        tokio::task::yield_now().await;
        dispatcher.shut_down();
        let answered = tokio::time::timeout(Duration::from_secs(5), poll).await;
        assert!(matches!(answered, Ok(Ok(None))));
    }

    #[tokio::test]
    async fn a_long_poll_wakes_when_work_arrives() {
        let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
        let d = dispatcher.clone();
        let poll = tokio::spawn(async move { d.lease("w", 1, Duration::from_secs(30)).await });
        tokio::task::yield_now().await;
        let _pending = dispatcher.submit(request("j", 1, 1), Instant::now());
        let answered = tokio::time::timeout(Duration::from_secs(5), poll).await;
        assert!(matches!(answered, Ok(Ok(Some(_)))), "{answered:?}");
    }

    #[test]
    fn cancelling_a_job_fails_its_requests() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 2, 2), now);
        dispatcher.cancel_job("j");
        assert_eq!(
            pending.try_result(),
            Some(Err(DispatchError::Cancelled("j".into())))
        );
        assert!(dispatcher.try_lease("w", 1, now).is_none());
    }

    #[test]
    fn an_empty_request_or_a_stopped_dispatcher_answers_at_once() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut empty = dispatcher.submit(request("j", 0, 5), now);
        assert_eq!(empty.try_result(), Some(Ok(Vec::new())));
        dispatcher.shut_down();
        let mut refused = dispatcher.submit(request("j", 2, 2), now);
        assert_eq!(refused.try_result(), Some(Err(DispatchError::ShuttingDown)));
    }

    #[test]
    fn only_the_holder_of_a_live_lease_can_act_on_it() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        // One genome on one sample: one batch.
        let mut pending = dispatcher.submit(request("j", 1, 1), now);
        let batch = dispatcher.try_lease("owner", 1, now).unwrap();
        let before = dispatcher.stats(now);
        let (lease, id) = (batch.lease_id, batch.batch_id);
        // Another worker, a forged lease id, or the right lease named for another batch.
        let forged = [
            (lease, id, "thief", LeaseError::NotYours(lease)),
            (lease + 1000, id, "owner", LeaseError::NotLive(lease + 1000)),
            (
                lease,
                id + 1,
                "owner",
                LeaseError::OtherBatch {
                    lease_id: lease,
                    leased: id,
                    named: id + 1,
                },
            ),
        ];
        for (lease_id, batch_id, worker, error) in forged {
            assert_eq!(
                dispatcher.complete(lease_id, batch_id, worker, fake(&batch)),
                Err(CompleteError::Lease(error))
            );
        }
        assert_eq!(
            dispatcher.extend(lease, "thief", now),
            Err(LeaseError::NotYours(lease))
        );
        assert_eq!(
            dispatcher.release(lease, "thief"),
            Err(LeaseError::NotYours(lease))
        );
        assert_eq!(
            dispatcher.fail(lease, "thief", "no".into()),
            Err(LeaseError::NotYours(lease))
        );
        assert!(dispatcher.leased_request(lease, "thief").is_err());
        // Nothing changed: the batch is still out on its lease, the request still waiting.
        let after = dispatcher.stats(now);
        assert_eq!(
            (
                after.leased_batches,
                after.queued_batches,
                after.evaluations
            ),
            (
                before.leased_batches,
                before.queued_batches,
                before.evaluations
            )
        );
        assert_eq!(after.refused_lease_calls, 7);
        assert!(pending.try_result().is_none());
        assert!(dispatcher.try_lease("thief", 1, now).is_none());
        dispatcher
            .complete(lease, id, "owner", fake(&batch))
            .unwrap();
        assert!(pending.try_result().unwrap().is_ok());
    }

    #[test]
    fn results_outside_what_the_task_can_give_are_refused() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let _pending = dispatcher.submit(request("j", 1, 1), now);
        let forgeries: [fn(&mut SampleSummary); 5] = [
            |s| s.fitness = 1e30,
            |s| s.variant = 4_000_000_000,
            |s| s.stage = 7,
            |s| s.cycles = 1_000_000,
            |s| {
                s.node_use.active_cycles = vec![5, 5];
                s.node_use.activations = vec![1, 1];
            },
        ];
        for forge in forgeries {
            let batch = dispatcher.try_lease("w", 1, now).unwrap();
            let mut results = fake(&batch);
            forge(&mut results[0][0]);
            assert!(
                matches!(
                    dispatcher.complete(batch.lease_id, batch.batch_id, "w", results),
                    Err(CompleteError::Malformed { .. })
                ),
                "accepted {:?}",
                batch.batch_id
            );
        }
        assert_eq!(dispatcher.stats(now).malformed_results, 5);
    }

    #[test]
    fn a_lease_cannot_be_extended_past_its_lifetime() {
        let lifetime = Duration::from_secs(600);
        let dispatcher = Dispatcher::new(DispatchConfig {
            max_lease_lifetime: lifetime,
            ..DispatchConfig::default()
        });
        let t0 = Instant::now();
        let _pending = dispatcher.submit(request("j", 1, 1), t0);
        let batch = dispatcher.try_lease("stuck", 1, t0).unwrap();
        // Heartbeats every 20 s keep it alive, up to the lifetime.
        let mut t = t0;
        while t + Duration::from_secs(20) < t0 + lifetime {
            t += Duration::from_secs(20);
            assert_eq!(dispatcher.extend(batch.lease_id, "stuck", t), Ok(()));
        }
        let end = t0 + lifetime;
        assert_eq!(
            dispatcher.extend(batch.lease_id, "stuck", end),
            Err(LeaseError::NotLive(batch.lease_id))
        );
        let again = dispatcher.try_lease("other", 1, end).unwrap();
        assert_eq!(again.batch_id, batch.batch_id);
        assert_eq!(dispatcher.stats(end).lease_revocations, 1);
    }

    #[test]
    fn a_gone_workers_leases_are_queued_again_at_once() {
        let dispatcher = Dispatcher::new(DispatchConfig::default());
        let now = Instant::now();
        let mut pending = dispatcher.submit(request("j", 4, 1), now);
        let mut held = Vec::new();
        while let Some(batch) = dispatcher.try_lease("gone", 1, now) {
            held.push(batch);
        }
        assert!(held.len() >= 2);
        assert_eq!(dispatcher.revoke_worker("gone"), held.len());
        assert_eq!(dispatcher.stats(now).active_workers, 0);
        // Without waiting for any deadline, another worker gets them, in their first order.
        let mut again = Vec::new();
        while let Some(batch) = dispatcher.try_lease("alive", 1, now) {
            again.push(batch.batch_id);
            dispatcher
                .complete(batch.lease_id, batch.batch_id, "alive", fake(&batch))
                .unwrap();
        }
        assert_eq!(again, held.iter().map(|b| b.batch_id).collect::<Vec<_>>());
        assert!(pending.try_result().unwrap().is_ok());
        assert_eq!(dispatcher.revoke_worker("nobody"), 0);
    }

    #[test]
    fn batches_stay_under_the_byte_limit() {
        let bytes = BatchBytes {
            fixed: 1000,
            per_genome: 100,
            per_sample: 10,
            per_result: 50,
            limit: 10_000,
        };
        // 4,000 genomes x 2 samples in 3 batches would be far over the limit.
        let pieces = split(4_000, 2, 3, &bytes);
        for (genomes, samples) in &pieces {
            let size = bytes.fixed
                + genomes.len() * (bytes.per_genome + samples.len() * bytes.per_result)
                + samples.len() * bytes.per_sample;
            assert!(size <= bytes.limit, "{size} bytes");
        }
        assert_eq!(pieces.iter().map(|(g, _)| g.len()).sum::<usize>(), 4_000);
        // One genome on more samples than one batch may carry: its samples are cut.
        let pieces = split(1, 1_000, 3, &bytes);
        assert!(pieces.len() > 3);
        assert!(pieces.iter().all(|(_, samples)| {
            bytes.fixed + bytes.per_genome + samples.len() * (bytes.per_sample + bytes.per_result)
                <= bytes.limit
        }));
        assert_eq!(pieces.iter().map(|(_, s)| s.len()).sum::<usize>(), 1_000);
    }
}
