//! `hevo serve`: the master, its job and worker services (gRPC), the metrics and the dashboard,
//! with the tokens, limits and retention its flags give.

use crate::runtime::runtime;
use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::time::Duration;

/// `hevo serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address for the gRPC services, e.g. 0.0.0.0:7700 (port 0: any free port; the bound
    /// address is printed first on stdout as `listening on ADDR`).
    #[arg(long)]
    pub listen: String,
    /// Directory of the job store (hevo.redb) and the jobs' outputs.
    #[arg(long)]
    pub state_dir: PathBuf,
    /// The token clients (submit, watch, jobs, fetch, cancel) must send.
    #[arg(long, env = "HEVO_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Read the clients' tokens from this file, one per line (wins over --token and
    /// HEVO_TOKEN; several lines during a rotation; re-read on SIGHUP).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// The token workers must send: a credential of its own, so a client cannot act as a
    /// worker nor a worker submit or read jobs.
    #[arg(long, env = "HEVO_WORKER_TOKEN", hide_env_values = true)]
    pub worker_token: Option<String>,
    /// Read the workers' tokens from this file, one per line (wins over --worker-token and
    /// HEVO_WORKER_TOKEN; re-read on SIGHUP).
    #[arg(long)]
    pub worker_token_file: Option<PathBuf>,
    /// Run without tokens (only on a network you trust).
    #[arg(long)]
    pub insecure_no_token: bool,
    /// TLS certificate chain (PEM); needs --tls-key.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// TLS private key (PEM); needs --tls-cert.
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Serve Prometheus metrics at http://ADDR/metrics (printed as `metrics on ADDR`).
    #[arg(long)]
    pub metrics_listen: Option<String>,
    /// Serve the live dashboard at http://ADDR/ (port 0: any free port; printed after the
    /// other addresses as `dashboard on http://ADDR`): the jobs and workers, each job's fitness
    /// curves growing as generations finish, its post-evaluation tables, the best controllers'
    /// replays with a cycle slider, and a cancel button. The clients' tokens guard every page
    /// (a login form, or `Authorization: Bearer TOKEN`). Plain HTTP: put it behind a TLS proxy
    /// off this machine.
    #[arg(long, value_name = "ADDR")]
    pub http_listen: Option<String>,
    /// A batch whose worker sends no heartbeat for this long is given to another worker.
    #[arg(long, default_value_t = 30)]
    pub lease_seconds: u64,
    /// A batch held this long is given to another worker even if its worker still sends
    /// heartbeats (a worker that never returns its batch cannot hold a job forever).
    #[arg(long, default_value_t = 900)]
    pub max_lease_seconds: u64,
    /// Rebuild the job store from the copies of the job records in STATE_DIR/jobs/*/job.json
    /// (after the store was lost or damaged; the old file is moved aside), then serve.
    #[arg(long)]
    pub rebuild_store: bool,
    /// The most connections the gRPC port keeps open at once; one more is closed as soon as
    /// it is accepted. Both ports' limits are lowered to fit the open-file limit (raised to its
    /// hard limit at start), with 64 descriptors to spare.
    #[arg(long, default_value_t = 1024)]
    pub max_connections: usize,
    /// The most connections the dashboard's port keeps open at once.
    #[arg(long, default_value_t = 256)]
    pub http_max_connections: usize,
    /// A connection (on either port) that has made no request this long after it was accepted
    /// is closed: an idle or slow client, or a TLS handshake never finished.
    #[arg(long, default_value_t = 10)]
    pub first_request_timeout_seconds: u64,
    /// A connection (on either port) with no traffic for this long is closed.
    #[arg(long, default_value_t = 120)]
    pub idle_timeout_seconds: u64,
    /// The most event streams open at once, per port: `hevo watch` streams on the gRPC port,
    /// the job pages' live updates on the dashboard's. One more is refused (gRPC
    /// RESOURCE_EXHAUSTED, HTTP 503).
    #[arg(long, default_value_t = 256)]
    pub max_event_streams: usize,
    /// Spot checks: the share of batches (0 to 1) whose results the master evaluates itself
    /// and compares bit for bit before accepting them; every worker's first result is checked
    /// too. A worker whose results differ is refused from then on, and the unfinished jobs it
    /// worked on are evaluated again from the start. 0 (the default) checks none.
    #[arg(long, default_value_t = 0.0)]
    pub verify_share: f64,
    /// Delete a finished job (succeeded, failed or cancelled), its record and its files, this
    /// many hours after it finished, as `hevo delete` would; fetch its results before then.
    /// Unset (the default), finished jobs are kept until deleted.
    #[arg(long)]
    pub retain_finished_hours: Option<f64>,
}

/// `hevo serve`.
pub fn serve(args: ServeArgs) -> Result<()> {
    let tokens = |token: &Option<String>, file: &Option<PathBuf>| -> Result<Vec<String>> {
        Ok(match file {
            Some(file) => hevo_proto::auth::read_token_file(file)?,
            None => hevo_proto::auth::resolve_token(token.as_deref(), None)?
                .into_iter()
                .collect(),
        })
    };
    let client_tokens = tokens(&args.token, &args.token_file)?;
    let worker_tokens = tokens(&args.worker_token, &args.worker_token_file)?;
    let credentials = match (client_tokens.is_empty(), worker_tokens.is_empty()) {
        (true, true) if args.insecure_no_token => None,
        (true, true) => bail!(
            "no tokens: give clients' (--token-file, --token or HEVO_TOKEN) and workers' (--worker-token-file, --worker-token or HEVO_WORKER_TOKEN), or --insecure-no-token on a trusted network"
        ),
        (true, false) => bail!("no client token: give --token-file, --token or HEVO_TOKEN"),
        (false, true) => bail!(
            "no worker token: workers need a credential of their own; give --worker-token-file, --worker-token or HEVO_WORKER_TOKEN"
        ),
        (false, false) => Some(hevo_service::Credentials {
            client_tokens,
            worker_tokens,
            client_token_file: args.token_file.clone(),
            worker_token_file: args.worker_token_file.clone(),
        }),
    };
    if args.max_connections == 0 || args.http_max_connections == 0 || args.max_event_streams == 0 {
        bail!(
            "--max-connections, --http-max-connections and --max-event-streams must be at least 1"
        );
    }
    if !(0.0..=1.0).contains(&args.verify_share) {
        bail!("--verify-share must be a share from 0 to 1");
    }
    let retain_finished = match args.retain_finished_hours {
        None => None,
        // A century at most: beyond that a duration is no setting but a typo.
        Some(hours) if hours.is_finite() && hours > 0.0 && hours <= 876_000.0 => {
            Some(Duration::from_secs_f64(hours * 3600.0))
        }
        Some(hours) => {
            bail!("--retain-finished-hours must be a number of hours above 0, got {hours}")
        }
    };
    if args.first_request_timeout_seconds == 0 || args.idle_timeout_seconds == 0 {
        bail!("--first-request-timeout-seconds and --idle-timeout-seconds must be at least 1");
    }
    let connection_limits = |max_connections: usize| hevo_service::ConnectionLimits {
        max_connections,
        first_request_timeout: Duration::from_secs(args.first_request_timeout_seconds),
        idle_timeout: Duration::from_secs(args.idle_timeout_seconds),
    };
    let config = hevo_service::ServeConfig {
        listen: args.listen,
        state_dir: args.state_dir,
        credentials,
        tls: args.tls_cert.zip(args.tls_key),
        metrics_listen: args.metrics_listen,
        http_listen: args.http_listen,
        lease: Duration::from_secs(args.lease_seconds),
        max_lease: Duration::from_secs(args.max_lease_seconds),
        rebuild_store: args.rebuild_store,
        grpc_limits: connection_limits(args.max_connections),
        http_limits: connection_limits(args.http_max_connections),
        max_event_streams: args.max_event_streams,
        verify_share: args.verify_share,
        retain_finished,
    };
    let runtime = runtime()?;
    let served = runtime.block_on(hevo_service::serve(config));
    // Work still on a blocking thread (a submission being checked, say) must not keep a
    // stopped master alive: what it would have stored is stored again by the retry.
    runtime.shutdown_timeout(SHUTDOWN_GRACE);
    served
}

/// How long a stopping master waits for work still on its blocking threads.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(1);
