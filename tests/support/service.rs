//! Helpers for the tests that treat a master as a hostile or unlucky user would: a master
//! started with separate client and worker tokens, gRPC clients holding either credential,
//! the master's metrics, a small experiment to submit, and a slow one (`tests/fixtures/`).

use crate::{Master, Scratch, start_master};
use hevo_proto::client::{AuthChannel, ClientOptions, job_client, worker_client};
use hevo_proto::v1;
use hevo_proto::v1::job_service_client::JobServiceClient;
use hevo_proto::v1::worker_service_client::WorkerServiceClient;
use std::time::Duration;

/// The clients' token of [`master_with_roles`].
pub const CLIENT_TOKEN: &str = "client-secret";
/// The workers' token of [`master_with_roles`].
pub const WORKER_TOKEN: &str = "worker-secret";

/// A one-node experiment small enough to run in a few seconds.
pub const SMALL: &str = r#"
[experiment]
name = "small"
seed = 3

[evolution]
population = 6
elites = 2
post_evaluation_samples = 2

[[node]]
name = "follow_wall"
kind = "primitive"
inputs = ["ir"]
hidden = 2
task = "follow_wall"
samples = 2
generations = 2
runs = 1
"#;

/// `tests/fixtures/exit_room_slow.toml`: exit-room samples that all run their 1000 cycles
/// (collisions do not end them), so batches take long enough to catch a worker holding one.
pub const SLOW_EXIT_ROOM: &str = include_str!("../fixtures/exit_room_slow.toml");

/// [`SLOW_EXIT_ROOM`] with its experiment's name, seed, population, elites and generations
/// changed: a job slow enough to watch its curve grow, or to cost a dashboard something.
#[derive(Debug, Clone, Copy)]
pub struct SlowExitRoom<'a> {
    /// The experiment's name.
    pub name: &'a str,
    /// Its seed.
    pub seed: u64,
    /// Genomes per generation.
    pub population: u32,
    /// Genomes kept as they are from one generation to the next.
    pub elites: u32,
    /// Generations of its one run.
    pub generations: u64,
}

impl SlowExitRoom<'_> {
    /// The experiment file's text.
    pub fn toml(&self) -> String {
        let mut text = SLOW_EXIT_ROOM.to_string();
        for (line, value) in [
            ("name = \"slow\"", format!("name = \"{}\"", self.name)),
            ("seed = 5", format!("seed = {}", self.seed)),
            (
                "population = 20",
                format!("population = {}", self.population),
            ),
            ("elites = 4", format!("elites = {}", self.elites)),
            (
                "generations = 2",
                format!("generations = {}", self.generations),
            ),
        ] {
            let line = format!("\n{line}\n");
            assert_eq!(
                text.matches(&line).count(),
                1,
                "tests/fixtures/exit_room_slow.toml has no single line {line:?}"
            );
            text = text.replacen(&line, &format!("\n{value}\n"), 1);
        }
        text
    }
}

/// The token-file flags of a master whose clients and workers have tokens of their own.
pub fn role_args(scratch: &Scratch) -> Vec<String> {
    let clients = scratch.join("client-tokens");
    let workers = scratch.join("worker-tokens");
    std::fs::write(&clients, format!("{CLIENT_TOKEN}\n")).unwrap();
    std::fs::write(&workers, format!("{WORKER_TOKEN}\n")).unwrap();
    vec![
        "--token-file".into(),
        clients.to_string_lossy().into_owned(),
        "--worker-token-file".into(),
        workers.to_string_lossy().into_owned(),
    ]
}

/// A master on port 0 with separate tokens, metrics, its state in `scratch/state`, and `extra`
/// flags.
pub fn master_with_roles(scratch: &Scratch, extra: &[&str]) -> Master {
    let mut args = role_args(scratch);
    args.extend(
        [
            "--state-dir",
            &scratch.join("state").to_string_lossy(),
            "--metrics-listen",
            "127.0.0.1:0",
        ]
        .map(str::to_string),
    );
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    start_master(&args, &scratch.join("master.log"))
}

/// A single-threaded runtime for a test's gRPC calls.
pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

fn channel(url: &str, token: &str) -> AuthChannel {
    ClientOptions {
        url: url.to_string(),
        token: Some(token.to_string()),
        tls_ca: None,
    }
    .lazy_channel()
    .unwrap()
}

/// The job service, holding `token`.
pub fn jobs(url: &str, token: &str) -> JobServiceClient<AuthChannel> {
    job_client(channel(url, token))
}

/// The worker service, holding `token`.
pub fn workers(url: &str, token: &str) -> WorkerServiceClient<AuthChannel> {
    worker_client(channel(url, token))
}

/// A submission of `toml`.
pub fn submission(toml: &str) -> v1::SubmitJobRequest {
    v1::SubmitJobRequest {
        experiment_toml: toml.to_string(),
        file_name: "small.toml".into(),
        ..v1::SubmitJobRequest::default()
    }
}

/// Leases a batch as `worker`, waiting up to `wait`.
pub async fn lease(
    client: &mut WorkerServiceClient<AuthChannel>,
    worker: &str,
    wait: Duration,
) -> Option<v1::Batch> {
    client
        .lease_batch(v1::LeaseBatchRequest {
            worker: worker.into(),
            threads: 1,
            wait_ms: wait.as_millis() as u32,
            cached: Vec::new(),
        })
        .await
        .unwrap()
        .into_inner()
        .batch
}

/// Waits until the job reaches a final state; returns it.
pub async fn wait_until_final(
    client: &mut JobServiceClient<AuthChannel>,
    job_id: &str,
    timeout: Duration,
) -> v1::JobInfo {
    let deadline = std::time::Instant::now() + timeout;
    loop {
        let info = client
            .get_job(v1::GetJobRequest {
                job_id: job_id.into(),
                include_files: false,
            })
            .await
            .unwrap()
            .into_inner()
            .job
            .unwrap();
        let state = v1::JobState::try_from(info.state).unwrap();
        if matches!(
            state,
            v1::JobState::Succeeded | v1::JobState::Failed | v1::JobState::Cancelled
        ) {
            return info;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "job {job_id} still {state:?} after {timeout:?}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The master's metrics as text.
pub fn metrics_text(master: &Master) -> String {
    let address = master
        .metrics
        .as_deref()
        .expect("the master serves metrics");
    let response = crate::http_get(address, "/metrics");
    assert!(response.starts_with("HTTP/1.1 200"), "{response}");
    response
        .split_once("\r\n\r\n")
        .map(|(_, body)| body.to_string())
        .unwrap_or_default()
}

/// One metric's value.
pub fn metric(text: &str, name: &str) -> f64 {
    text.lines()
        .find_map(|line| {
            line.strip_prefix(name)
                .and_then(|rest| rest.strip_prefix(' '))
        })
        .and_then(|value| value.trim().parse().ok())
        .unwrap_or_else(|| panic!("no metric {name} in:\n{text}"))
}

/// The status the master at `address` (`127.0.0.1:PORT`, plain gRPC) gives `service` on the
/// standard health service, asked without a token; an error names what failed. Each attempt
/// is bounded by 5 s.
pub fn health_status(
    runtime: &tokio::runtime::Runtime,
    address: &str,
    service: &str,
) -> Result<i32, String> {
    runtime.block_on(async {
        let channel = tonic::transport::Endpoint::from_shared(format!("http://{address}"))
            .map_err(|e| e.to_string())?
            .connect_timeout(Duration::from_secs(5))
            .timeout(Duration::from_secs(5))
            .connect()
            .await
            .map_err(|e| e.to_string())?;
        let mut client = tonic_health::pb::health_client::HealthClient::new(channel);
        let response = client
            .check(tonic_health::pb::HealthCheckRequest {
                service: service.to_string(),
            })
            .await
            .map_err(|status| format!("{}: {}", status.code(), status.message()))?;
        Ok(response.into_inner().status)
    })
}
