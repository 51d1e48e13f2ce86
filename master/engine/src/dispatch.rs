//! The scheduler between the evolutionary loops and the workers. A loop hands it an evaluation
//! request (genomes x samples of one generation); it splits the request into batches sized so
//! that every worker stays busy, queues them per job, and leases them to workers that ask,
//! round-robin across jobs so concurrent jobs share the workers fairly. Every lease has a
//! deadline: a batch whose worker dies or stalls is leased again, and whichever copy of a result
//! arrives first is kept while late duplicates are ignored. Results are validated before they
//! are accepted, so a broken worker cannot corrupt a job.
//!
//! In-process workers (local mode) and remote gRPC workers use the same `lease` / `complete`
//! calls, so local mode runs exactly the service's path.
//!
//! Time is an argument, as in quinn-proto: every method that needs it takes `now`, so the
//! scheduling rules are tested with made-up instants and no sleeping. The two async entry
//! points, [`Dispatcher::evaluate`] and the long-polling [`Dispatcher::lease`], are the edge
//! where the clock is read.

use hevo_sim_core::Sample;
use hevo_sim_core::TaskConfig;
use hevo_sim_core::batch::SampleSummary;
use hevo_sim_core::controller::ControllerFile;
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

/// What happened to a returned result.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Completion {
    /// Accepted and recorded.
    Accepted,
    /// The batch was already complete (a late duplicate) or its job is gone: ignored.
    Ignored,
}

/// Why a returned result was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CompleteError {
    /// The result does not have the batch's shape or has non-finite values.
    #[error("malformed result for batch {batch_id}: {message}")]
    Malformed {
        /// The batch.
        batch_id: u64,
        /// What is wrong.
        message: String,
    },
    /// No such lease was ever given.
    #[error("unknown lease {0}")]
    UnknownLease(u64),
}

/// Tuning.
#[derive(Debug, Clone)]
pub struct DispatchConfig {
    /// How long a lease lasts without a heartbeat.
    pub lease_timeout: Duration,
    /// Batches per active worker a request is split into (more: better balance, more overhead).
    pub batches_per_worker: usize,
    /// Workers that asked for work within this window count as active.
    pub worker_window: Duration,
    /// The number of workers assumed before any has asked (local mode knows its threads).
    pub expected_workers: usize,
}

impl Default for DispatchConfig {
    fn default() -> Self {
        DispatchConfig {
            lease_timeout: Duration::from_secs(30),
            batches_per_worker: 3,
            worker_window: Duration::from_secs(30),
            expected_workers: 1,
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
    /// Late duplicate results ignored.
    pub duplicates_ignored: u64,
    /// Batches completed.
    pub batches_completed: u64,
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
}

/// The scheduler. Share it as `Arc<Dispatcher>`.
#[derive(Debug)]
pub struct Dispatcher {
    config: DispatchConfig,
    state: Mutex<State>,
    work_available: Notify,
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
    /// [genome][sample]. Waits for workers; never fails because a worker died.
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
            let pieces = split(n_genomes, n_samples, target);
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
        if state.shutting_down {
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

    /// Extends a lease (a worker's heartbeat). Returns false when the lease is gone, in which
    /// case the worker may stop: its batch was given to someone else or its job ended.
    pub fn extend(&self, lease_id: u64, now: Instant) -> bool {
        let mut state = self.lock();
        let timeout = self.config.lease_timeout;
        match state.leases.get_mut(&lease_id) {
            Some(lease) => {
                lease.deadline = now + timeout;
                // A worker busy with a long batch is still an active worker.
                let worker = lease.worker.clone();
                if let Some(seen) = state.workers.get_mut(&worker) {
                    seen.0 = now;
                }
                true
            }
            None => false,
        }
    }

    /// The template and task of the batch out on this lease (to check a worker's claim that
    /// they cannot be evaluated).
    pub fn leased_request(&self, lease_id: u64) -> Option<Arc<RequestShared>> {
        let state = self.lock();
        let batch_id = state.leases.get(&lease_id)?.batch_id;
        let request_id = state.batches.get(&batch_id)?.request_id;
        Some(state.requests.get(&request_id)?.request.shared.clone())
    }

    /// A worker hands a batch back unfinished (for example on SIGTERM): it is queued again at
    /// the front.
    pub fn release(&self, lease_id: u64) {
        let mut state = self.lock();
        if state.leases.remove(&lease_id).is_some() {
            state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
            let batch_id = state
                .batches
                .iter()
                .find(|(_, b)| b.lease == Some(lease_id))
                .map(|(&id, _)| id);
            if let Some(batch_id) = batch_id {
                requeue(&mut state, batch_id, lease_id);
            }
        }
        drop(state);
        self.work_available.notify_waiters();
    }

    /// A worker reports that a batch cannot be evaluated at all (its template or task is
    /// invalid): the whole request fails, since every worker would fail the same way.
    pub fn fail(&self, lease_id: u64, message: String) {
        let mut state = self.lock();
        let Some(lease) = state.leases.remove(&lease_id) else {
            return;
        };
        state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        let Some(request_id) = state.batches.get(&lease.batch_id).map(|b| b.request_id) else {
            return;
        };
        finish_request(&mut state, request_id, Err(DispatchError::Failed(message)));
    }

    /// A worker returns the summaries of a batch, indexed [genome of the batch][sample of the
    /// batch]. Results for a lease that expired are still accepted if the batch is not done yet
    /// (evaluation is deterministic, so any copy is right); duplicates are ignored.
    pub fn complete(
        &self,
        lease_id: u64,
        batch_id: u64,
        results: Vec<Vec<SampleSummary>>,
    ) -> Result<Completion, CompleteError> {
        let mut state = self.lock();
        let lease = state.leases.remove(&lease_id);
        if lease.is_some() {
            state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        }
        if let Some(lease) = &lease
            && lease.batch_id != batch_id
        {
            state.leases.insert(
                lease_id,
                LeaseEntry {
                    batch_id: lease.batch_id,
                    worker: lease.worker.clone(),
                    deadline: lease.deadline,
                },
            );
            state.stats.leased_batches += 1;
            return Err(CompleteError::Malformed {
                batch_id,
                message: format!("lease {lease_id} is for batch {}", lease.batch_id),
            });
        }
        let Some(entry) = state.batches.get(&batch_id) else {
            // The batch is gone: its request completed or was cancelled.
            if lease.is_none() && batch_id >= state.next_id {
                return Err(CompleteError::UnknownLease(lease_id));
            }
            state.stats.duplicates_ignored += 1;
            return Ok(Completion::Ignored);
        };
        if entry.done {
            state.stats.duplicates_ignored += 1;
            return Ok(Completion::Ignored);
        }
        // Validate the shape and values before touching the request.
        let n_samples = entry.sample_range.len();
        let problem = if results.len() != entry.genome_indices.len() {
            Some(format!(
                "{} genomes returned, batch has {}",
                results.len(),
                entry.genome_indices.len()
            ))
        } else if let Some((g, r)) = results
            .iter()
            .enumerate()
            .find(|(_, r)| r.len() != n_samples)
        {
            Some(format!(
                "genome {g} has {} samples, batch has {n_samples}",
                r.len()
            ))
        } else {
            results
                .iter()
                .flatten()
                .find(|s| !s.fitness.is_finite())
                .map(|s| format!("non-finite fitness {}", s.fitness))
        };
        if let Some(message) = problem {
            state.stats.malformed_results += 1;
            tracing::warn!(batch_id, %message, "refused a malformed result; batch re-queued");
            requeue(&mut state, batch_id, lease_id);
            drop(state);
            self.work_available.notify_waiters();
            return Err(CompleteError::Malformed { batch_id, message });
        }

        // Accept: a copy still out on another lease is cancelled, a queued copy dropped.
        let entry = state.batches.get_mut(&batch_id).expect("checked above");
        entry.done = true;
        let other_lease = entry.lease.take().filter(|&l| l != lease_id);
        let (request_id, job, genome_indices, range) = (
            entry.request_id,
            entry.job.clone(),
            entry.genome_indices.clone(),
            entry.sample_range.clone(),
        );
        if let Some(other) = other_lease
            && state.leases.remove(&other).is_some()
        {
            state.stats.leased_batches = state.stats.leased_batches.saturating_sub(1);
        }
        if let Some(queue) = state.pending.get_mut(&job)
            && let Some(pos) = queue.iter().position(|&b| b == batch_id)
        {
            queue.remove(pos);
            state.stats.queued_batches = state.stats.queued_batches.saturating_sub(1);
        }
        let mut cycles = 0u64;
        let mut evaluations = 0u64;
        let finished = {
            let Some(request) = state.requests.get_mut(&request_id) else {
                return Ok(Completion::Ignored);
            };
            for (genome_results, &genome_idx) in results.into_iter().zip(&genome_indices) {
                for (summary, sample_idx) in genome_results.into_iter().zip(range.clone()) {
                    cycles += u64::from(summary.cycles);
                    evaluations += 1;
                    request.results[genome_idx as usize][sample_idx] = Some(summary);
                }
            }
            request.remaining_batches -= 1;
            request.remaining_batches == 0
        };
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
            let outcome = results.ok_or_else(|| {
                DispatchError::Failed("internal: a finished request has holes".into())
            });
            finish_request(&mut state, request_id, outcome);
        }
        Ok(Completion::Accepted)
    }

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

/// Splits genomes x samples into about `target` batches: whole genomes when there are enough of
/// them, otherwise each genome's samples in contiguous pieces (post-evaluation of one genome).
fn split(
    n_genomes: usize,
    n_samples: usize,
    target: usize,
) -> Vec<(Vec<u32>, std::ops::Range<usize>)> {
    if n_genomes >= target {
        let per_batch = n_genomes.div_ceil(target);
        (0..n_genomes)
            .collect::<Vec<_>>()
            .chunks(per_batch)
            .map(|chunk| (chunk.iter().map(|&g| g as u32).collect(), 0..n_samples))
            .collect()
    } else {
        let pieces = target.div_ceil(n_genomes).min(n_samples);
        let per_piece = n_samples.div_ceil(pieces);
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
    use hevo_sim_core::controller::NodeSpec;
    use hevo_sim_core::frame::InputGroup;
    use hevo_sim_core::{TaskConfig, TaskKind};

    fn request(job: &str, n_genomes: usize, n_samples: usize) -> EvaluationRequest {
        let template = ControllerFile::new(NodeSpec::primitive("p", vec![InputGroup::Ir], 1));
        let task = TaskConfig::new(TaskKind::FollowWall);
        EvaluationRequest {
            job: job.into(),
            shared: Arc::new(RequestShared {
                template_hash: template.content_hash(),
                task_hash: hevo_sim_core::batch::task_content_hash(&task),
                template,
                task,
            }),
            genomes: (0..n_genomes)
                .map(|g| Arc::from(vec![g as f32; 3]))
                .collect(),
            samples: (0..n_samples).map(|s| Sample::seeded(s as u64)).collect(),
        }
    }

    /// A fake evaluation: fitness = genome's first gene * 1000 + sample seed.
    fn fake(batch: &Batch) -> Vec<Vec<SampleSummary>> {
        batch
            .genomes
            .iter()
            .map(|(_, genes)| {
                batch
                    .samples
                    .iter()
                    .map(|s| SampleSummary {
                        fitness: genes[0] * 1000.0 + s.seed as f32,
                        solved: false,
                        collided: false,
                        stage: 0,
                        variant: 0,
                        cycles: 10,
                        ..SampleSummary::default()
                    })
                    .collect()
            })
            .collect()
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
            let pieces = split(g, s, t);
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
                dispatcher.complete(batch.lease_id, batch.batch_id, fake(&batch)),
                Ok(Completion::Accepted)
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
                assert_eq!(summary.fitness, g as f32 * 1000.0 + s as f32);
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
        assert!(dispatcher.extend(kept.lease_id, just_before));
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
                .complete(batch.lease_id, batch.batch_id, fake(batch))
                .unwrap();
        }
        // The first copy back of the extended batch wins; the late dead worker is ignored.
        dispatcher
            .complete(kept.lease_id, kept.batch_id, fake(&kept))
            .unwrap();
        assert_eq!(pending.try_result().expect("complete").unwrap()[0].len(), 3);
        for batch in &dead {
            assert_eq!(
                dispatcher.complete(batch.lease_id, batch.batch_id, fake(batch)),
                Ok(Completion::Ignored)
            );
        }
        assert_eq!(
            dispatcher.stats(expired).duplicates_ignored,
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
            dispatcher.complete(batch.lease_id, batch.batch_id, wrong),
            Err(CompleteError::Malformed { .. })
        ));
        let mut nan = fake(&batch);
        nan[0][0].fitness = f32::NAN;
        let again = dispatcher.try_lease("bad", 1, now).unwrap();
        assert_eq!(again.batch_id, batch.batch_id);
        assert!(
            dispatcher
                .complete(again.lease_id, again.batch_id, nan)
                .is_err()
        );
        drain(&dispatcher, "good", now);
        let results = pending.try_result().expect("complete").unwrap();
        assert_eq!(results[1][1].fitness, 1001.0);
        assert_eq!(dispatcher.stats(now).malformed_results, 2);
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
                .complete(batch.lease_id, batch.batch_id, fake(&batch))
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
            assert!(dispatcher.extend(batch.lease_id, t0));
            assert!(dispatcher.leased_request(batch.lease_id).is_some());
            dispatcher
                .complete(batch.lease_id, batch.batch_id, fake(&batch))
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
}
