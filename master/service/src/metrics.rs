//! Prometheus metrics over plain HTTP (`GET /metrics` on `--metrics-listen`): connected
//! workers and their threads, queued and leased batches, evaluations and simulated cycles (as
//! totals and as per-second rates over the last few seconds), lease expiries, refused and
//! duplicate results, and jobs per state. Rates are sampled in the background so every scrape
//! sees the same window, whoever scrapes how often.

use crate::db::JobState;
use crate::grpc::WorkerCounters;
use crate::jobs::JobManager;
use hevo_engine::dispatch::Dispatcher;
use std::collections::VecDeque;
use std::fmt::Write;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often rates are sampled, and how many samples span the window.
const SAMPLE_EVERY: Duration = Duration::from_secs(2);
const WINDOW_SAMPLES: usize = 6;

/// What the metrics are read from.
#[derive(Clone)]
pub struct Metrics {
    dispatcher: Arc<Dispatcher>,
    jobs: Option<JobManager>,
    counters: Arc<WorkerCounters>,
    samples: Arc<Mutex<VecDeque<(Instant, u64, u64)>>>,
}

impl std::fmt::Debug for Metrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Metrics").finish_non_exhaustive()
    }
}

impl Metrics {
    /// Metrics of a dispatcher, its worker service and (for a master) its jobs.
    pub fn new(
        dispatcher: Arc<Dispatcher>,
        jobs: Option<JobManager>,
        counters: Arc<WorkerCounters>,
    ) -> Metrics {
        Metrics {
            dispatcher,
            jobs,
            counters,
            samples: Arc::default(),
        }
    }

    /// Samples the counters for the rates, forever (spawn it).
    pub async fn sample_rates(self) {
        let mut tick = tokio::time::interval(SAMPLE_EVERY);
        loop {
            tick.tick().await;
            let stats = self.dispatcher.stats(Instant::now());
            let mut samples = self.samples.lock().unwrap_or_else(|p| p.into_inner());
            samples.push_back((Instant::now(), stats.evaluations, stats.cycles));
            while samples.len() > WINDOW_SAMPLES {
                samples.pop_front();
            }
        }
    }

    fn rates(&self) -> (f64, f64) {
        let samples = self.samples.lock().unwrap_or_else(|p| p.into_inner());
        match (samples.front(), samples.back()) {
            (Some(first), Some(last)) if last.0 > first.0 => {
                let seconds = last.0.duration_since(first.0).as_secs_f64();
                (
                    (last.1 - first.1) as f64 / seconds,
                    (last.2 - first.2) as f64 / seconds,
                )
            }
            _ => (0.0, 0.0),
        }
    }

    /// The Prometheus text exposition.
    pub fn render(&self) -> String {
        let stats = self.dispatcher.stats(Instant::now());
        let (evaluations_rate, cycles_rate) = self.rates();
        let mut out = String::new();
        let mut metric = |name: &str, kind: &str, help: &str, value: String| {
            let _ = writeln!(
                out,
                "# HELP {name} {help}\n# TYPE {name} {kind}\n{name} {value}"
            );
        };
        metric(
            "hevo_workers_connected",
            "gauge",
            "Workers that asked for work or sent a heartbeat recently.",
            stats.active_workers.to_string(),
        );
        metric(
            "hevo_worker_threads",
            "gauge",
            "Evaluation threads of the connected workers.",
            stats.active_threads.to_string(),
        );
        metric(
            "hevo_batches_queued",
            "gauge",
            "Batches waiting for a worker.",
            stats.queued_batches.to_string(),
        );
        metric(
            "hevo_batches_leased",
            "gauge",
            "Batches out on lease.",
            stats.leased_batches.to_string(),
        );
        metric(
            "hevo_batches_completed_total",
            "counter",
            "Batches whose results were accepted.",
            stats.batches_completed.to_string(),
        );
        metric(
            "hevo_evaluations_total",
            "counter",
            "(genome, sample) evaluations accepted.",
            stats.evaluations.to_string(),
        );
        metric(
            "hevo_cycles_total",
            "counter",
            "Simulated control cycles accepted.",
            stats.cycles.to_string(),
        );
        metric(
            "hevo_evaluations_per_second",
            "gauge",
            "Evaluations accepted per second, recent window.",
            format!("{evaluations_rate:.1}"),
        );
        metric(
            "hevo_cycles_per_second",
            "gauge",
            "Simulated control cycles per second, recent window.",
            format!("{cycles_rate:.1}"),
        );
        metric(
            "hevo_lease_expiries_total",
            "counter",
            "Leases that ran out and were re-queued.",
            stats.lease_expiries.to_string(),
        );
        let refused =
            stats.malformed_results + self.counters.refused_results.load(Ordering::Relaxed);
        metric(
            "hevo_results_refused_total",
            "counter",
            "Results refused as malformed (batch re-queued).",
            refused.to_string(),
        );
        metric(
            "hevo_spot_checks_total",
            "counter",
            "Batches whose results were checked against the master's own evaluation (--verify-share).",
            stats.spot_checks.to_string(),
        );
        metric(
            "hevo_lying_workers_total",
            "counter",
            "Workers refused because a spot check found their results differ from the master's.",
            stats.lying_workers.to_string(),
        );
        metric(
            "hevo_lease_calls_refused_total",
            "counter",
            "Worker calls naming no live lease of the caller's (late duplicates, revoked or foreign leases): nothing changed.",
            stats.refused_lease_calls.to_string(),
        );
        metric(
            "hevo_lease_revocations_total",
            "counter",
            "Leases taken back before their deadline: the worker's connection closed, or the lease reached its maximum lifetime.",
            stats.lease_revocations.to_string(),
        );
        metric(
            "hevo_results_stale_total",
            "counter",
            "Results for leases of an earlier master process, ignored.",
            self.counters
                .stale_results
                .load(Ordering::Relaxed)
                .to_string(),
        );
        if let Some(jobs) = &self.jobs {
            let _ = writeln!(
                out,
                "# HELP hevo_jobs Jobs by state.\n# TYPE hevo_jobs gauge"
            );
            for (state, count) in jobs.counts() {
                let _ = writeln!(
                    out,
                    "hevo_jobs{{state=\"{}\"}} {count}",
                    JobState::name(state)
                );
            }
        }
        out
    }
}

/// Serves `GET /metrics` until `shutdown` resolves.
pub async fn serve(
    listener: tokio::net::TcpListener,
    metrics: Metrics,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    use axum::routing::get;
    let router = axum::Router::new().route(
        "/metrics",
        get(move || {
            let metrics = metrics.clone();
            async move {
                (
                    [(
                        axum::http::header::CONTENT_TYPE,
                        "text/plain; version=0.0.4",
                    )],
                    metrics.render(),
                )
            }
        }),
    );
    axum::serve(listener, router)
        .with_graceful_shutdown(shutdown)
        .await
}
