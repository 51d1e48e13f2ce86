//! `hevo bench --dispatch-load N`: the master's dispatch capacity under many workers. A real
//! worker service (the one `hevo serve` runs, with token checks and message limits) listens on
//! 127.0.0.1; N lightweight fake workers, each with its own connection, lease batches, "evaluate"
//! them by sleeping a fixed time, and return results of the right shape; a few synthetic jobs
//! keep the queue full. Measured: batches and evaluations per second through the master, and
//! the latency of lease calls that returned a batch (percentiles). Everything runs in this one
//! process on loopback and stops by itself after the given time.

use crate::grpc::WorkerApi;
use crate::{MAX_LEASE_WAIT, incoming, worker_service};
use hevo_engine::dispatch::{DispatchConfig, Dispatcher, EvaluationRequest, RequestShared};
use hevo_proto::auth::{Role, Roles, ServerAuth, TokenSet};
use hevo_proto::client::{ClientOptions, worker_client};
use hevo_proto::v1;
use hevo_sim_core::InputGroup;
use hevo_sim_core::{ControllerFile, NodeSpec};
use hevo_sim_core::{Sample, TaskConfig};
use serde::Serialize;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What to measure.
#[derive(Debug, Clone)]
pub struct LoadConfig {
    /// Concurrent fake workers.
    pub workers: usize,
    /// Measurement time (after a one-second warm-up).
    pub seconds: f64,
    /// What one batch "costs" a fake worker.
    pub batch_cost: Duration,
    /// Concurrent synthetic jobs.
    pub jobs: usize,
    /// Genomes per generation of a synthetic job.
    pub genomes: usize,
    /// Samples per genome.
    pub samples: usize,
}

/// The result.
#[derive(Debug, Clone, Serialize)]
pub struct LoadReport {
    /// Fake workers.
    pub workers: usize,
    /// Seconds measured.
    pub seconds: f64,
    /// Fixed cost of a batch, ms.
    pub batch_cost_ms: f64,
    /// Batches completed in the window.
    pub batches: u64,
    /// Batches per second through the master.
    pub batches_per_second: f64,
    /// (genome, sample) results per second.
    pub evaluations_per_second: f64,
    /// Lease call latency when a batch was handed out, ms: 50th, 90th, 99th percentile, max.
    pub lease_latency_ms: [f64; 4],
    /// Lease calls that returned a batch, in the window.
    pub leases: usize,
    /// Times a fake worker's connection broke and it reconnected.
    pub reconnects: usize,
    /// The rate a master with zero overhead would reach: workers / batch cost.
    pub ideal_batches_per_second: f64,
}

fn template() -> (ControllerFile, TaskConfig) {
    let template = ControllerFile::new(NodeSpec::primitive("p", vec![InputGroup::IR], 3));
    (
        template,
        TaskConfig::shipped("follow_wall").expect("a shipped task"),
    )
}

/// Why the load benchmark did not finish.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The benchmark's own master could not listen.
    #[error("cannot listen on 127.0.0.1: {0}")]
    Listen(std::io::Error),
    /// Fake workers gave up.
    #[error("{failed} of {workers} fake workers failed; first: {first}")]
    Workers {
        /// How many failed.
        failed: usize,
        /// How many there were.
        workers: usize,
        /// The first one's reason.
        first: String,
    },
}

/// Why one fake worker gave up.
#[derive(Debug, thiserror::Error)]
enum FakeWorkerError {
    #[error(transparent)]
    Connect(#[from] hevo_proto::client::ConnectError),
    #[error("{0}")]
    Refused(String),
}

/// Runs the load benchmark.
pub async fn run(config: LoadConfig) -> Result<LoadReport, LoadError> {
    let token = "dispatch-load-benchmark";
    let lease = Duration::from_secs(30);
    let dispatcher = Arc::new(Dispatcher::new(DispatchConfig {
        lease_timeout: lease,
        ..DispatchConfig::default()
    }));
    let api = WorkerApi::new(dispatcher.clone(), lease, MAX_LEASE_WAIT);
    let (closed_connections, closed) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(api.clone().revoke_on_close(closed));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .map_err(LoadError::Listen)?;
    let address = listener.local_addr().map_err(LoadError::Listen)?;
    let (stop, stopped) = tokio::sync::watch::channel(false);
    let server = {
        let mut stopped = stopped.clone();
        let gate = hevo_dashboard::connections::ConnectionGate::new(
            "grpc",
            crate::ConnectionLimits::DEFAULT,
        );
        tokio::spawn(
            tonic::transport::Server::builder()
                .layer(crate::mark_served_layer(gate.clone()))
                .add_service(worker_service(
                    api,
                    ServerAuth::for_role(
                        Role::Worker,
                        &Roles {
                            workers: TokenSet::new(&[token.to_string()]),
                            ..Roles::default()
                        },
                    ),
                ))
                .serve_with_incoming_shutdown(
                    incoming(listener, gate, closed_connections, false),
                    async move {
                        let _ = stopped.wait_for(|&s| s).await;
                    },
                ),
        )
    };

    let (template, task) = template();
    let shared = Arc::new(RequestShared::new(template, task));
    let warm_up = Duration::from_secs(1);
    let started = Instant::now();
    let measure_from = started + warm_up;
    let end = measure_from + Duration::from_secs_f64(config.seconds);

    // Synthetic jobs: generation after generation until the end.
    let feeders: Vec<_> = (0..config.jobs.max(1))
        .map(|job| {
            let (dispatcher, shared) = (dispatcher.clone(), shared.clone());
            let (genomes, samples) = (config.genomes.max(1), config.samples.max(1));
            tokio::spawn(async move {
                let mut generation = 0u64;
                while Instant::now() < end {
                    let request = EvaluationRequest {
                        job: format!("load-{job}"),
                        shared: shared.clone(),
                        genomes: (0..genomes).map(|g| Arc::from(vec![g as f32; 3])).collect(),
                        samples: (0..samples)
                            .map(|s| Sample::seeded(generation * 1_000 + s as u64))
                            .collect(),
                    };
                    if dispatcher.evaluate(request).await.is_err() {
                        break;
                    }
                    generation += 1;
                }
            })
        })
        .collect();

    let options = ClientOptions {
        url: format!("http://{address}"),
        token: Some(token.into()),
        tls_ca: None,
    };
    let workers: Vec<_> = (0..config.workers.max(1))
        .map(|w| {
            let options = options.clone();
            let cost = config.batch_cost;
            tokio::spawn(async move {
                fake_worker(options, format!("fake-{w}"), cost, measure_from, end).await
            })
        })
        .collect();

    let mut latencies = Vec::new();
    let mut reconnects = 0;
    let mut failures = Vec::new();
    let before = loop {
        // Counters at the start of the measurement window.
        let now = Instant::now();
        if now >= measure_from {
            break dispatcher.stats(Instant::now());
        }
        tokio::time::sleep(measure_from - now).await;
    };
    for worker in workers {
        match worker.await {
            Ok(Ok(mut log)) => {
                latencies.append(&mut log.latencies);
                reconnects += log.reconnects;
            }
            Ok(Err(error)) => failures.push(error.to_string()),
            Err(error) => failures.push(error.to_string()),
        }
    }
    let after = dispatcher.stats(Instant::now());
    let measured = Instant::now().duration_since(measure_from).as_secs_f64();
    dispatcher.shut_down();
    for feeder in feeders {
        let _ = feeder.await;
    }
    let _ = stop.send(true);
    let _ = server.await;
    if let Some(first) = failures.first() {
        return Err(LoadError::Workers {
            failed: failures.len(),
            workers: config.workers,
            first: first.clone(),
        });
    }
    latencies.sort_by(f64::total_cmp);
    let percentile = |p: f64| {
        latencies
            .get(((latencies.len() as f64 - 1.0) * p).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let batches = after.batches_completed - before.batches_completed;
    Ok(LoadReport {
        workers: config.workers,
        seconds: measured,
        batch_cost_ms: config.batch_cost.as_secs_f64() * 1e3,
        batches,
        batches_per_second: batches as f64 / measured,
        evaluations_per_second: (after.evaluations - before.evaluations) as f64 / measured,
        lease_latency_ms: [
            percentile(0.5),
            percentile(0.9),
            percentile(0.99),
            percentile(1.0),
        ],
        leases: latencies.len(),
        reconnects,
        ideal_batches_per_second: config.workers as f64 / config.batch_cost.as_secs_f64().max(1e-9),
    })
}

/// What one fake worker saw.
struct FakeWorkerLog {
    /// Lease latencies (ms) inside the measurement window.
    latencies: Vec<f64>,
    /// Times its connection failed and it reconnected.
    reconnects: usize,
}

/// Connects, retrying a few times: hundreds of simultaneous connects on a busy machine may
/// time out or be reset, and a real worker retries too.
async fn connect_with_retry(
    options: &ClientOptions,
) -> Result<hevo_proto::client::AuthChannel, hevo_proto::client::ConnectError> {
    let mut attempt = 0;
    loop {
        match options.connect().await {
            Ok(channel) => return Ok(channel),
            Err(error) if attempt >= 5 => return Err(error),
            Err(_) => {
                attempt += 1;
                tokio::time::sleep(Duration::from_millis(200 * attempt)).await;
            }
        }
    }
}

/// Leases, sleeps `cost`, returns constant results; records lease latencies (ms) inside the
/// measurement window. Like a real worker it reconnects when its connection breaks (counted,
/// because a master that drops connections under load is part of what is measured), and a
/// batch it could not return is simply re-leased by another after its lease expires.
async fn fake_worker(
    options: ClientOptions,
    name: String,
    cost: Duration,
    measure_from: Instant,
    end: Instant,
) -> Result<FakeWorkerLog, FakeWorkerError> {
    let mut log = FakeWorkerLog {
        latencies: Vec::new(),
        reconnects: 0,
    };
    let mut client = worker_client(connect_with_retry(&options).await?);
    while Instant::now() < end {
        match lease_and_complete(&mut client, &name, cost, measure_from).await {
            Ok(Some(latency)) => log.latencies.extend(latency),
            Ok(None) => {}
            Err(status)
                if matches!(
                    status.code(),
                    tonic::Code::Unknown | tonic::Code::Cancelled | tonic::Code::Unavailable
                ) =>
            {
                // A transport error (the connection was reset or closed): reconnect, as a
                // real worker does, instead of giving up.
                log.reconnects += 1;
                if log.reconnects > 20 {
                    return Err(FakeWorkerError::Refused(
                        hevo_proto::client::describe_status(&status),
                    ));
                }
                client = worker_client(connect_with_retry(&options).await?);
            }
            Err(status) => {
                return Err(FakeWorkerError::Refused(
                    hevo_proto::client::describe_status(&status),
                ));
            }
        }
    }
    Ok(log)
}

/// One lease, the fake evaluation, and the result. Returns the lease latency when a batch was
/// handed out inside the measurement window.
async fn lease_and_complete(
    client: &mut hevo_proto::client::WorkerClient,
    name: &str,
    cost: Duration,
    measure_from: Instant,
) -> Result<Option<Option<f64>>, tonic::Status> {
    let asked = Instant::now();
    let request = v1::LeaseBatchRequest {
        worker: name.to_string(),
        threads: 1,
        wait_ms: 1_000,
        cached: Vec::new(),
    };
    let Some(batch) = client.lease_batch(request).await?.into_inner().batch else {
        return Ok(None);
    };
    let latency = (asked >= measure_from).then(|| asked.elapsed().as_secs_f64() * 1e3);
    tokio::time::sleep(cost).await;
    let result = v1::SampleResult {
        fitness: 0.5,
        solved: false,
        collided: false,
        stage: 0,
        variant: 0,
        cycles: 100,
        sub_task_cycles: Vec::new(),
        sub_task_correct: Vec::new(),
        node_active_cycles: vec![100],
        node_activations: vec![1],
        // The final position, every shipped task's descriptor.
        descriptor: vec![0.0; hevo_sim_core::DEFAULT_DESCRIPTOR.len()],
        ending: v1::SampleEnding::Timeout.into(),
    };
    let genomes = batch
        .genomes
        .iter()
        .map(|_| v1::GenomeResult {
            samples: vec![result.clone(); batch.samples.len()],
        })
        .collect();
    let request = v1::CompleteBatchRequest {
        epoch: batch.epoch,
        lease_id: batch.lease_id,
        batch_id: batch.batch_id,
        worker: name.to_string(),
        genomes,
        elapsed_ms: cost.as_millis() as u64,
    };
    client.complete_batch(request).await?;
    Ok(Some(latency))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_short_load_run_moves_batches_as_its_configuration_implies() {
        let config = LoadConfig {
            workers: 8,
            seconds: 0.5,
            batch_cost: Duration::from_millis(2),
            jobs: 2,
            genomes: 40,
            samples: 2,
        };
        let report = run(config).await.unwrap();
        let r = &report;
        eprintln!("{report:?}");
        assert_eq!(r.workers, 8);
        assert_eq!(r.batch_cost_ms, 2.0);
        assert_eq!(r.ideal_batches_per_second, 4000.0, "8 workers / 2 ms");
        // The window lasts the time asked for, plus the batches in hand at its end.
        assert!((0.5..2.0).contains(&r.seconds), "{report:?}");
        assert_eq!(r.batches_per_second, r.batches as f64 / r.seconds);
        // Once the 8 workers have asked for work (in the one-second warm-up), a generation of
        // 40 genomes x 2 samples is split for 8 x 3 = 24 batches: 20 batches of 2 genomes x 2
        // samples, so every batch completed in the window holds 4 evaluations.
        let evaluations = (r.evaluations_per_second * r.seconds).round() as u64;
        assert_eq!(evaluations, 4 * r.batches, "{report:?}");
        // No faster than a master without overhead: a worker completes at most one batch per
        // 2 ms of the window, and the one it held when the window began.
        let ceiling = (r.ideal_batches_per_second * r.seconds) as u64 + 8;
        // And at least a generation of each job: 40 batches in half a second, where a
        // master without overhead does 2000.
        assert!(
            (40..=ceiling).contains(&r.batches),
            "{} batches, at most {ceiling}: {report:?}",
            r.batches
        );
        // Every batch completed in the window was leased in it, but for at most one per worker
        // leased before it; and at most one per worker was leased and not completed in it.
        let batches = r.batches as usize;
        assert!(
            r.leases + 8 >= batches && r.leases <= batches + 8,
            "{report:?}"
        );
        let [p50, p90, p99, max] = r.lease_latency_ms;
        assert!(
            0.0 < p50 && p50 <= p90 && p90 <= p99 && p99 <= max,
            "{report:?}"
        );
        // The lease waits at most one second for work (plus the round trip).
        assert!(max < 1_500.0, "{report:?}");
        assert_eq!(r.reconnects, 0, "a loopback connection broke: {report:?}");
    }
}
