//! The remote worker loop. A worker connects out to the master (so it needs no inbound port),
//! asks for a batch with a long poll, evaluates it on all its threads while heartbeating the
//! lease, and returns the results; then asks again. It keeps nothing between batches but its
//! evaluator cache, whose keys it lists with every request so the master sends a template and
//! task only once. When the master is unreachable it retries with exponential backoff (capped)
//! and carries on when the master is back. A refused token is fatal: retrying cannot fix it.
//!
//! Shutdown comes in two levels: the first SIGTERM/SIGINT lets the current batch finish within
//! a grace period (and hands it back if it does not), a second one hands it back at once.

use hevo_engine::executor::{EvaluatorCache, ExecError, evaluate_genomes};
use hevo_proto::client::{AuthChannel, ClientOptions, describe_status, worker_client};
use hevo_proto::convert;
use hevo_proto::v1;
use hevo_proto::v1::worker_service_client::WorkerServiceClient;
use hevo_sim_core::Sample;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// How a worker runs.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    /// The master.
    pub client: ClientOptions,
    /// The worker's name, unique per process (the master counts workers by name).
    pub name: String,
    /// Threads to evaluate with.
    pub threads: usize,
    /// How long one lease request may wait for work.
    pub lease_wait: Duration,
    /// On the first shutdown request, how long the current batch may take to finish before it
    /// is handed back.
    pub grace: Duration,
    /// The longest pause between reconnection attempts.
    pub max_backoff: Duration,
}

impl WorkerConfig {
    /// Defaults for everything but where to connect.
    pub fn new(client: ClientOptions, name: String, threads: usize) -> WorkerConfig {
        WorkerConfig {
            client,
            name,
            threads: threads.max(1),
            lease_wait: Duration::from_secs(10),
            grace: Duration::from_secs(30),
            max_backoff: Duration::from_secs(5),
        }
    }
}

/// Shutdown requests, as sent through the worker's watch channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Shutdown {
    /// Keep working.
    Running,
    /// Finish the current batch within the grace period, then stop.
    Graceful,
    /// Hand the current batch back now and stop.
    Now,
}

/// What evaluates a batch: sim-core normally, a fixed-cost fake in load tests.
pub trait Executor: Send + Sync + 'static {
    /// Cache keys (`<template_hash>/<task_hash>`) the executor holds.
    fn cached(&self) -> Vec<String>;
    /// Evaluates a batch on `threads` threads (blocking); stops early when `abort` is set.
    fn execute(
        &self,
        batch: &v1::Batch,
        threads: usize,
        abort: &AtomicBool,
    ) -> Result<Vec<v1::GenomeResult>, ExecError>;
}

/// The real executor: sim-core through [`evaluate_genomes`], evaluators cached by hash.
#[derive(Debug, Default)]
pub struct SimExecutor {
    cache: EvaluatorCache,
}

impl Executor for SimExecutor {
    fn cached(&self) -> Vec<String> {
        self.cache
            .keys()
            .iter()
            .map(|(template, task)| hevo_proto::convert::cache_key(template, task))
            .collect()
    }

    fn execute(
        &self,
        batch: &v1::Batch,
        threads: usize,
        abort: &AtomicBool,
    ) -> Result<Vec<v1::GenomeResult>, ExecError> {
        let evaluator = self
            .cache
            .get_or_build(&batch.template_hash, &batch.task_hash, || {
                if batch.template_json.is_empty() || batch.task_json.is_empty() {
                    return Err(ExecError::Missing);
                }
                let template =
                    convert::template_from_json(&batch.template_json, &batch.template_hash)
                        .map_err(|e| ExecError::Invalid(e.to_string()))?;
                let task = convert::task_from_json(&batch.task_json, &batch.task_hash)
                    .map_err(|e| ExecError::Invalid(e.to_string()))?;
                Ok((template, task))
            })?;
        let samples: Vec<Sample> = batch
            .samples
            .iter()
            .map(convert::sample_from_proto)
            .collect();
        let genomes: Vec<&[f32]> = batch.genomes.iter().map(|g| g.genes.as_slice()).collect();
        let results = evaluate_genomes(&evaluator, &genomes, &samples, threads, Some(abort))?;
        Ok(convert::results_to_proto(&results))
    }
}

/// Why a worker stopped other than by a shutdown request.
#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    /// Bad settings (URL, TLS files, token).
    #[error(transparent)]
    Setup(#[from] hevo_proto::client::ConnectError),
    /// The master refused the worker for good (wrong token, incompatible master).
    #[error("the master refused this worker: {0}")]
    Refused(String),
}

/// What a worker did, for its final log line.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WorkerReport {
    /// Batches whose results the master accepted.
    pub batches: u64,
    /// (genome, sample) evaluations in those batches.
    pub evaluations: u64,
    /// Batches handed back unfinished.
    pub released: u64,
}

/// Exponential backoff with a cap: 100 ms, 200 ms, ... up to `max`.
#[derive(Debug)]
struct Backoff {
    next: Duration,
    max: Duration,
}

impl Backoff {
    const START: Duration = Duration::from_millis(100);

    fn new(max: Duration) -> Backoff {
        Backoff {
            next: Self::START,
            max,
        }
    }

    fn reset(&mut self) {
        self.next = Self::START;
    }

    fn next_delay(&mut self) -> Duration {
        let delay = self.next.min(self.max);
        self.next = (self.next * 2).min(self.max);
        delay
    }
}

/// Errors after which retrying cannot help.
fn is_fatal(status: &tonic::Status) -> bool {
    matches!(
        status.code(),
        tonic::Code::Unauthenticated | tonic::Code::PermissionDenied | tonic::Code::Unimplemented
    )
}

/// Resolves once the shutdown level reaches `level` (never if the sender is gone).
async fn reached(shutdown: &mut watch::Receiver<Shutdown>, level: Shutdown) {
    loop {
        if *shutdown.borrow_and_update() >= level {
            return;
        }
        if shutdown.changed().await.is_err() {
            std::future::pending::<()>().await;
        }
    }
}

struct Worker {
    config: WorkerConfig,
    client: WorkerServiceClient<AuthChannel>,
    executor: Arc<dyn Executor>,
    shutdown: watch::Receiver<Shutdown>,
    report: WorkerReport,
}

/// Runs a worker until a shutdown request (Ok) or a fatal refusal (Err).
pub async fn run(
    config: WorkerConfig,
    executor: Arc<dyn Executor>,
    shutdown: watch::Receiver<Shutdown>,
) -> Result<WorkerReport, WorkerError> {
    let channel = config.client.lazy_channel().map_err(WorkerError::Setup)?;
    let client = worker_client(channel);
    let mut worker = Worker {
        config,
        client,
        executor,
        shutdown,
        report: WorkerReport::default(),
    };
    worker.run().await?;
    Ok(worker.report)
}

impl Worker {
    async fn run(&mut self) -> Result<(), WorkerError> {
        let mut backoff = Backoff::new(self.config.max_backoff);
        let mut connected = false;
        let mut failures = 0u32;
        // A lease request waits for work, so "connected" may come much later: say at once that
        // the worker is up and where it looks.
        tracing::info!(master = %self.config.client.url, worker = %self.config.name, threads = self.config.threads, "asking the master for work");
        loop {
            if *self.shutdown.borrow() != Shutdown::Running {
                return Ok(());
            }
            let request = v1::LeaseBatchRequest {
                worker: self.config.name.clone(),
                threads: u32::try_from(self.config.threads).unwrap_or(u32::MAX),
                wait_ms: u32::try_from(self.config.lease_wait.as_millis()).unwrap_or(u32::MAX),
                cached: self.executor.cached(),
            };
            let mut client = self.client.clone();
            let mut shutdown = self.shutdown.clone();
            let response = tokio::select! {
                response = client.lease_batch(request) => response,
                _ = reached(&mut shutdown, Shutdown::Graceful) => return Ok(()),
            };
            let batch = match response {
                Ok(response) => {
                    if !connected {
                        tracing::info!(master = %self.config.client.url, worker = %self.config.name, threads = self.config.threads, "connected to the master");
                        connected = true;
                    }
                    failures = 0;
                    backoff.reset();
                    response.into_inner().batch
                }
                Err(status) => {
                    if is_fatal(&status) {
                        return Err(WorkerError::Refused(describe_status(&status)));
                    }
                    // Say it once per outage, not once per retry.
                    if connected || failures == 0 {
                        tracing::warn!(master = %self.config.client.url, error = %describe_status(&status), "master unreachable; retrying with backoff");
                    }
                    connected = false;
                    failures += 1;
                    let delay = backoff.next_delay();
                    tokio::select! {
                        _ = tokio::time::sleep(delay) => {}
                        _ = reached(&mut shutdown, Shutdown::Graceful) => return Ok(()),
                    }
                    continue;
                }
            };
            if let Some(batch) = batch {
                self.process(batch).await?;
            }
        }
    }

    async fn process(&mut self, batch: v1::Batch) -> Result<(), WorkerError> {
        tracing::debug!(
            batch_id = batch.batch_id,
            lease_id = batch.lease_id,
            genomes = batch.genomes.len(),
            samples = batch.samples.len(),
            "leased a batch"
        );
        let batch = Arc::new(batch);
        let abort = Arc::new(AtomicBool::new(false));
        let started = Instant::now();
        let (executor, work, flag, threads) = (
            self.executor.clone(),
            batch.clone(),
            abort.clone(),
            self.config.threads,
        );
        let mut evaluation =
            tokio::task::spawn_blocking(move || executor.execute(&work, threads, &flag));
        let lease_period = Duration::from_millis(u64::from(batch.lease_ms.max(1_000)));
        let beat = lease_period / 3;
        let mut heartbeat = tokio::time::interval_at(tokio::time::Instant::now() + beat, beat);
        let mut shutdown = self.shutdown.clone();
        let mut urgent = self.shutdown.clone();
        let mut grace_until: Option<tokio::time::Instant> = (*shutdown.borrow()
            != Shutdown::Running)
            .then(|| tokio::time::Instant::now() + self.config.grace);
        // Set once the batch is no longer ours (handed back, or the lease was lost).
        let mut given_up = false;
        let outcome = loop {
            let grace_sleep = tokio::time::sleep_until(
                grace_until
                    .unwrap_or_else(|| tokio::time::Instant::now() + Duration::from_secs(86_400)),
            );
            tokio::select! {
                joined = &mut evaluation => {
                    break joined.unwrap_or_else(|e| Err(ExecError::Invalid(format!("evaluation thread failed: {e}"))));
                }
                _ = heartbeat.tick(), if !given_up => {
                    let request = v1::ExtendLeaseRequest { epoch: batch.epoch, lease_id: batch.lease_id, worker: self.config.name.clone() };
                    match self.client.clone().extend_lease(request).await {
                        Ok(response) if !response.get_ref().valid => {
                            tracing::info!(batch_id = batch.batch_id, "lease lost (re-dispatched or job ended); dropping the batch");
                            abort.store(true, Ordering::Relaxed);
                            given_up = true;
                        }
                        Ok(_) => {}
                        Err(status) if is_fatal(&status) => {
                            abort.store(true, Ordering::Relaxed);
                            return Err(WorkerError::Refused(describe_status(&status)));
                        }
                        Err(status) => tracing::warn!(batch_id = batch.batch_id, error = %describe_status(&status), "heartbeat failed; still evaluating"),
                    }
                }
                _ = reached(&mut shutdown, Shutdown::Graceful), if grace_until.is_none() => {
                    tracing::info!(batch_id = batch.batch_id, grace_seconds = self.config.grace.as_secs_f64(), "shutting down: finishing the current batch");
                    grace_until = Some(tokio::time::Instant::now() + self.config.grace);
                }
                _ = async { tokio::select! { _ = grace_sleep => {}, _ = reached(&mut urgent, Shutdown::Now) => {} } }, if grace_until.is_some() && !given_up => {
                    abort.store(true, Ordering::Relaxed);
                    given_up = true;
                    self.release(&batch).await;
                }
            }
        };
        match outcome {
            Ok(results) if !given_up => self.complete(&batch, results, started.elapsed()).await,
            Ok(_) | Err(ExecError::Aborted) => Ok(()),
            Err(ExecError::Missing) => {
                tracing::warn!(
                    batch_id = batch.batch_id,
                    "batch came without its template; handing it back"
                );
                self.release(&batch).await;
                Ok(())
            }
            Err(ExecError::Invalid(message)) => {
                tracing::error!(batch_id = batch.batch_id, job = %batch.job_id, %message, "batch cannot be evaluated");
                let request = v1::FailBatchRequest {
                    epoch: batch.epoch,
                    lease_id: batch.lease_id,
                    worker: self.config.name.clone(),
                    message,
                };
                if let Err(status) = self.client.clone().fail_batch(request).await {
                    tracing::warn!(error = %describe_status(&status), "could not report the failure; the lease will expire");
                }
                Ok(())
            }
        }
    }

    async fn release(&mut self, batch: &v1::Batch) {
        let request = v1::ReleaseBatchRequest {
            epoch: batch.epoch,
            lease_id: batch.lease_id,
            worker: self.config.name.clone(),
        };
        match self.client.clone().release_batch(request).await {
            Ok(_) => {
                self.report.released += 1;
                tracing::info!(batch_id = batch.batch_id, "batch handed back");
            }
            Err(status) => {
                tracing::warn!(batch_id = batch.batch_id, error = %describe_status(&status), "could not hand the batch back; its lease will expire")
            }
        }
    }

    async fn complete(
        &mut self,
        batch: &v1::Batch,
        results: Vec<v1::GenomeResult>,
        elapsed: Duration,
    ) -> Result<(), WorkerError> {
        let evaluations: u64 = results.iter().map(|g| g.samples.len() as u64).sum();
        let request = v1::CompleteBatchRequest {
            epoch: batch.epoch,
            lease_id: batch.lease_id,
            batch_id: batch.batch_id,
            worker: self.config.name.clone(),
            genomes: results,
            elapsed_ms: u64::try_from(elapsed.as_millis()).unwrap_or(u64::MAX),
        };
        // Results stay useful while the batch is not done elsewhere, so delivery is retried
        // for a while (a master restarting quickly gets them); after that the batch has surely
        // been given to another worker.
        let give_up = Instant::now()
            + Duration::from_millis(u64::from(batch.lease_ms)).max(Duration::from_secs(30));
        let mut backoff = Backoff::new(self.config.max_backoff);
        loop {
            match self.client.clone().complete_batch(request.clone()).await {
                Ok(response) => {
                    if response.get_ref().accepted {
                        self.report.batches += 1;
                        self.report.evaluations += evaluations;
                        tracing::debug!(
                            batch_id = batch.batch_id,
                            evaluations,
                            ms = elapsed.as_millis() as u64,
                            "batch done"
                        );
                    } else {
                        tracing::debug!(
                            batch_id = batch.batch_id,
                            "result not needed any more (duplicate or job ended)"
                        );
                    }
                    return Ok(());
                }
                Err(status) if is_fatal(&status) => {
                    return Err(WorkerError::Refused(describe_status(&status)));
                }
                Err(status)
                    if matches!(
                        status.code(),
                        tonic::Code::InvalidArgument
                            | tonic::Code::FailedPrecondition
                            | tonic::Code::NotFound
                    ) =>
                {
                    tracing::warn!(batch_id = batch.batch_id, error = %describe_status(&status), "result refused");
                    return Ok(());
                }
                Err(status) => {
                    if Instant::now() >= give_up || *self.shutdown.borrow() == Shutdown::Now {
                        tracing::warn!(batch_id = batch.batch_id, error = %describe_status(&status), "giving up delivering a result");
                        return Ok(());
                    }
                    tracing::warn!(batch_id = batch.batch_id, error = %describe_status(&status), "could not deliver a result; retrying");
                    tokio::time::sleep(backoff.next_delay()).await;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backoff_doubles_up_to_its_cap_and_resets() {
        let mut backoff = Backoff::new(Duration::from_millis(500));
        let delays: Vec<u128> = (0..5).map(|_| backoff.next_delay().as_millis()).collect();
        assert_eq!(delays, [100, 200, 400, 500, 500]);
        backoff.reset();
        assert_eq!(backoff.next_delay().as_millis(), 100);
    }

    #[test]
    fn the_sim_executor_evaluates_and_refuses_what_it_cannot_trust() {
        use hevo_sim_core::InputGroup;
        use hevo_sim_core::{ControllerFile, NodeSpec};
        let template = ControllerFile::new(NodeSpec::primitive("p", vec![InputGroup::IR], 2));
        let mut task = hevo_sim_core::TaskConfig::shipped("follow_wall").unwrap();
        task.max_cycles = Some(30);
        let n = template.root.topology().n_genes();
        let mut batch = v1::Batch {
            template_hash: template.content_hash(),
            task_hash: hevo_sim_core::task_content_hash(&task),
            template_json: convert::template_to_json(&template),
            task_json: convert::task_to_json(&task),
            genomes: (0..3)
                .map(|g| v1::Genome {
                    index: g,
                    genes: vec![g as f32 * 0.5; n],
                })
                .collect(),
            samples: (0..2)
                .map(|s| convert::sample_to_proto(&Sample::seeded(s)))
                .collect(),
            ..v1::Batch::default()
        };
        let executor = SimExecutor::default();
        let flag = AtomicBool::new(false);
        let results = executor.execute(&batch, 2, &flag).unwrap();
        assert_eq!(results.len(), 3);
        assert!(results.iter().all(|g| g.samples.len() == 2));
        assert_eq!(executor.cached().len(), 1);
        // Cached now: the same batch without the texts still evaluates, identically.
        let (template_json, task_json) = (
            std::mem::take(&mut batch.template_json),
            std::mem::take(&mut batch.task_json),
        );
        assert_eq!(executor.execute(&batch, 1, &flag).unwrap(), results);
        // Unknown key without texts: missing; a tampered template: invalid.
        let fresh = SimExecutor::default();
        assert_eq!(fresh.execute(&batch, 1, &flag), Err(ExecError::Missing));
        batch.template_json = template_json.replace("\"hidden\":2", "\"hidden\":3");
        batch.task_json = task_json;
        assert!(
            matches!(fresh.execute(&batch, 1, &flag), Err(ExecError::Invalid(m)) if m.contains("template_hash"))
        );
    }
}
