//! `hevo serve`: the master as a service. One port carries the job service (clients), the
//! worker service (workers connect out to it), the standard gRPC health service and server
//! reflection; an optional second port serves Prometheus metrics. Jobs run on one shared
//! dispatcher, so concurrent jobs share the workers round-robin, and live in a durable store
//! in the state directory, so a restarted master resumes them.
//!
//! Health and reflection need no token (load balancers and `grpcurl` probe them); the job and
//! worker services refuse calls without it. A master without a token refuses to start unless
//! told `--insecure-no-token`.

pub mod conn;
pub mod convert;
pub mod dashboard;
pub mod db;
pub mod evaluations;
pub mod grpc;
pub mod jobs;
pub mod load;
pub mod metrics;

use anyhow::{Context, Result, bail};
pub use hevo_dashboard::ConnectionLimits;
use hevo_dashboard::connections::ConnectionGate;
use hevo_engine::dispatch::{DispatchConfig, Dispatcher};
use hevo_proto::auth::{Role, Roles, ServerAuth, TokenSet};
use hevo_proto::v1::job_service_server::JobServiceServer;
use hevo_proto::v1::worker_service_server::WorkerServiceServer;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Identity, Server, ServerTlsConfig};

/// How `hevo serve` runs.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// The gRPC address (port 0 picks a free port).
    pub listen: String,
    /// Where the job store and job outputs live.
    pub state_dir: PathBuf,
    /// Who may call: clients' and workers' tokens; `None` runs without any (trusted networks
    /// only).
    pub credentials: Option<Credentials>,
    /// PEM certificate chain and key for TLS.
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Where to serve metrics.
    pub metrics_listen: Option<String>,
    /// Where to serve the dashboard (plain HTTP; the clients' tokens guard it).
    pub http_listen: Option<String>,
    /// Lease duration without a heartbeat.
    pub lease: Duration,
    /// The longest a lease may last, heartbeats or not.
    pub max_lease: Duration,
    /// Rebuild the job store from `jobs/*/job.json` before starting (the old file is moved
    /// aside).
    pub rebuild_store: bool,
    /// Connection limits of the gRPC port.
    pub grpc_limits: ConnectionLimits,
    /// Connection limits of the dashboard's port.
    pub http_limits: ConnectionLimits,
    /// The most event streams open at once, per port (gRPC watches, the dashboard's pages).
    pub max_event_streams: usize,
    /// The share of batches the master evaluates itself to check the worker's results (0:
    /// none); see [`spot_checks`].
    pub verify_share: f64,
    /// How long a finished job is kept before it is deleted as `hevo delete` would (`None`:
    /// for ever).
    pub retain_finished: Option<Duration>,
}

/// Deletes the finished jobs older than `retention`, now and then: often enough that a job
/// outlives its retention by at most a quarter of it (or a minute), rarely enough to cost
/// nothing.
async fn forget_finished(manager: jobs::JobManager, retention: Duration) {
    let period = (retention / 4).clamp(Duration::from_millis(100), Duration::from_secs(60));
    loop {
        let deleted = manager.delete_expired(retention);
        if deleted > 0 {
            tracing::info!(
                deleted,
                ?retention,
                "deleted finished jobs past their retention"
            );
        }
        tokio::time::sleep(period).await;
    }
}

/// File descriptors kept for the master's own use beyond its connections: the store, the
/// listeners, the runtime, job files being written.
pub const RESERVED_DESCRIPTORS: u64 = 64;

/// Raises the process's open-file limit to its hard limit, and lowers the two ports'
/// connection limits, in proportion, until they fit under it with
/// [`RESERVED_DESCRIPTORS`] to spare: a master out of descriptors can neither accept a health
/// check nor open its store. Returns the descriptor limit in force.
pub fn fit_connections_to_descriptors(
    grpc: &mut ConnectionLimits,
    http: Option<&mut ConnectionLimits>,
) -> u64 {
    let limit = match rlimit::increase_nofile_limit(u64::MAX) {
        Ok(limit) => limit,
        Err(error) => {
            tracing::warn!(%error, "cannot read or raise the open-file limit");
            return u64::MAX;
        }
    };
    let available = limit.saturating_sub(RESERVED_DESCRIPTORS).max(2);
    let http_wanted = http.as_ref().map_or(0, |h| h.max_connections as u64);
    let wanted = grpc.max_connections as u64 + http_wanted;
    if wanted > available {
        let grpc_share = (grpc.max_connections as u64 * available / wanted).max(1);
        tracing::warn!(
            open_file_limit = limit,
            wanted,
            "connection limits lowered to fit the open-file limit"
        );
        grpc.max_connections = grpc_share as usize;
        if let Some(http) = http {
            http.max_connections = (available - grpc_share).max(1) as usize;
        }
    }
    limit
}

/// The two roles' tokens, and the files they came from (re-read on SIGHUP, for a rotation).
#[derive(Debug, Clone)]
pub struct Credentials {
    /// Tokens of people and scripts (the job service).
    pub client_tokens: Vec<String>,
    /// Tokens of workers (the worker service).
    pub worker_tokens: Vec<String>,
    /// Where `client_tokens` came from, when from a file.
    pub client_token_file: Option<PathBuf>,
    /// Where `worker_tokens` came from, when from a file.
    pub worker_token_file: Option<PathBuf>,
}

/// The longest a worker's lease request is held open.
pub const MAX_LEASE_WAIT: Duration = Duration::from_secs(20);

/// The worker service and its dispatcher, with hevo's limits (also used by the load benchmark).
pub fn worker_service(
    api: grpc::WorkerApi,
    auth: ServerAuth,
) -> InterceptedService<WorkerServiceServer<grpc::WorkerApi>, ServerAuth> {
    let server = WorkerServiceServer::new(api)
        .max_decoding_message_size(hevo_proto::MAX_MESSAGE_BYTES)
        .max_encoding_message_size(hevo_proto::MAX_MESSAGE_BYTES);
    InterceptedService::new(server, auth)
}

/// Accepted connections with Nagle's algorithm off (leases and results are small messages
/// whose latency matters more than packet count), admitted by `gate` (those over its limit are
/// closed at once), each reporting its peer on `closed` when it closes. With `tls`, a client
/// that speaks plain text is answered in words and closed. A failed accept (out
/// of descriptors, say) is logged and retried after a pause, never a busy loop nor the end of
/// the server.
pub fn incoming(
    listener: tokio::net::TcpListener,
    gate: Arc<ConnectionGate>,
    closed: tokio::sync::mpsc::UnboundedSender<std::net::SocketAddr>,
    tls: bool,
) -> impl tokio_stream::Stream<Item = std::io::Result<conn::TrackedStream>> {
    let (sender, receiver) = tokio::sync::mpsc::channel(64);
    tokio::spawn(async move {
        loop {
            let accepted = tokio::select! {
                accepted = listener.accept() => accepted,
                () = sender.closed() => return,
            };
            match accepted {
                Ok((stream, _)) => {
                    let _ = stream.set_nodelay(true);
                    let Some(guarded) = gate.admit(stream, false) else {
                        continue;
                    };
                    if tls {
                        // A client speaking plain text to the TLS port is told so, in words.
                        let (sender, closed) = (sender.clone(), closed.clone());
                        let wait = gate.limits().first_request_timeout;
                        tokio::spawn(async move {
                            match conn::starts_tls(&guarded, wait).await {
                                Some(true) => {
                                    let tracked = conn::TrackedStream::new(guarded, closed);
                                    let _ = sender.send(Ok(tracked)).await;
                                }
                                Some(false) => conn::refuse_plain_text(guarded).await,
                                None => {}
                            }
                        });
                        continue;
                    }
                    let tracked = conn::TrackedStream::new(guarded, closed.clone());
                    if sender.send(Ok(tracked)).await.is_err() {
                        return;
                    }
                }
                Err(error) => {
                    tracing::debug!(%error, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    });
    tokio_stream::wrappers::ReceiverStream::new(receiver)
}

/// A request layer that marks the connection a request came on as having made one, for its
/// gate's first-request timeout.
pub fn mark_served_layer(
    gate: Arc<ConnectionGate>,
) -> tower::util::MapRequestLayer<
    impl Fn(http::Request<tonic::body::Body>) -> http::Request<tonic::body::Body> + Clone,
> {
    tower::util::MapRequestLayer::new(move |request: http::Request<tonic::body::Body>| {
        let extensions = request.extensions();
        let peer = extensions
            .get::<tonic::transport::server::TcpConnectInfo>()
            .and_then(|info| info.remote_addr())
            .or_else(|| {
                extensions
                    .get::<tonic::transport::server::TlsConnectInfo<
                        tonic::transport::server::TcpConnectInfo,
                    >>()
                    .and_then(|info| info.get_ref().remote_addr())
            });
        if let Some(peer) = peer {
            gate.mark_served(peer);
        }
        request
    })
}

/// Runs the master until SIGTERM/SIGINT.
pub async fn serve(config: ServeConfig) -> Result<()> {
    let roles = match &config.credentials {
        Some(credentials) => {
            let roles = Roles {
                clients: TokenSet::new(&credentials.client_tokens),
                workers: TokenSet::new(&credentials.worker_tokens),
            };
            if credentials.client_tokens.is_empty() || credentials.worker_tokens.is_empty() {
                bail!(
                    "clients and workers each need a token: --token-file (clients) and --worker-token-file (workers)"
                );
            }
            if roles.clients.overlaps(&roles.workers) {
                bail!(
                    "a token is both a client's and a worker's: give workers tokens of their own (--worker-token-file), so a client cannot act as a worker"
                );
            }
            tokio::spawn(reload_tokens_on_hangup(credentials.clone(), roles.clone()));
            Some(roles)
        }
        None => {
            tracing::warn!(
                "running without tokens: anyone who can reach the port can submit jobs and act as a worker"
            );
            None
        }
    };
    let auth_for = |role: Role| match &roles {
        Some(roles) => ServerAuth::for_role(role, roles),
        None => ServerAuth::open(),
    };
    if config.lease < Duration::from_secs(1) {
        bail!("--lease-seconds must be at least 1");
    }
    if config.max_lease < config.lease {
        bail!("--max-lease-seconds must be at least --lease-seconds");
    }
    let mut grpc_limits = config.grpc_limits;
    let mut http_limits = config.http_limits;
    let open_files = fit_connections_to_descriptors(
        &mut grpc_limits,
        config.http_listen.is_some().then_some(&mut http_limits),
    );
    std::fs::create_dir_all(&config.state_dir).with_context(|| {
        format!(
            "cannot create the state directory {}",
            config.state_dir.display()
        )
    })?;
    let store_path = config.state_dir.join("hevo.redb");
    let jobs_dir = jobs::jobs_dir(&config.state_dir);
    let store = if config.rebuild_store {
        let rebuilt = db::JobStore::rebuild(&store_path, &jobs_dir)?;
        tracing::warn!(
            jobs = rebuilt.jobs,
            skipped = rebuilt.skipped.len(),
            store = %store_path.display(),
            "job store rebuilt from jobs/*/job.json"
        );
        for skipped in &rebuilt.skipped {
            tracing::warn!("not rebuilt: {skipped}");
        }
        rebuilt.store
    } else {
        db::JobStore::open(&store_path, &jobs_dir)?
    };
    let tls = match &config.tls {
        Some((cert, key)) => {
            let cert = std::fs::read(cert)
                .with_context(|| format!("cannot read the TLS certificate {}", cert.display()))?;
            let key = std::fs::read(key)
                .with_context(|| format!("cannot read the TLS key {}", key.display()))?;
            Some(ServerTlsConfig::new().identity(Identity::from_pem(cert, key)))
        }
        None => None,
    };

    let listener = tokio::net::TcpListener::bind(&config.listen)
        .await
        .with_context(|| format!("cannot listen on {}", config.listen))?;
    let address = listener.local_addr()?;
    let metrics_listener = match &config.metrics_listen {
        Some(listen) => Some(
            tokio::net::TcpListener::bind(listen)
                .await
                .with_context(|| format!("cannot listen on {listen} for metrics"))?,
        ),
        None => None,
    };
    let http_listener = match &config.http_listen {
        Some(listen) => Some(
            tokio::net::TcpListener::bind(listen)
                .await
                .with_context(|| format!("cannot listen on {listen} for the dashboard"))?,
        ),
        None => None,
    };
    // The first lines on stdout tell scripts (and tests binding port 0) where we are.
    {
        let mut stdout = std::io::stdout().lock();
        writeln!(stdout, "listening on {address}")?;
        if let Some(metrics) = &metrics_listener {
            writeln!(stdout, "metrics on {}", metrics.local_addr()?)?;
        }
        if let Some(http) = &http_listener {
            writeln!(stdout, "dashboard on http://{}", http.local_addr()?)?;
        }
        stdout.flush()?;
    }

    let dispatcher = Arc::new(Dispatcher::new(DispatchConfig {
        lease_timeout: config.lease,
        max_lease_lifetime: config.max_lease,
        // A quarter of the message limit: the estimate is generous, and a worker's reply
        // carries its results alongside.
        max_batch_bytes: hevo_proto::MAX_MESSAGE_BYTES / 4,
        verify_share: config.verify_share,
        ..DispatchConfig::default()
    }));
    let manager = jobs::JobManager::start(store, dispatcher.clone(), config.state_dir.clone())?;
    // Evaluations are streams: as many at once as event streams.
    let evaluations = evaluations::Evaluations::new(dispatcher.clone(), config.max_event_streams);
    if config.verify_share > 0.0 {
        tokio::spawn(spot_checks(
            dispatcher.clone(),
            manager.clone(),
            evaluations.clone(),
        ));
    }
    if let Some(retention) = config.retain_finished {
        tokio::spawn(forget_finished(manager.clone(), retention));
    }
    let worker_api = grpc::WorkerApi::new(dispatcher.clone(), config.lease, MAX_LEASE_WAIT);
    let (closed_connections, closed) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(worker_api.clone().revoke_on_close(closed));
    let metrics = metrics::Metrics::new(
        dispatcher.clone(),
        Some(manager.clone()),
        worker_api.counters(),
    );
    tokio::spawn(metrics.clone().sample_rates());

    let (health_reporter, health_service) = tonic_health::server::health_reporter();
    for name in ["", hevo_proto::JOB_SERVICE, hevo_proto::WORKER_SERVICE] {
        health_reporter
            .set_service_status(name, tonic_health::ServingStatus::Serving)
            .await;
    }
    let reflection_v1 = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(hevo_proto::FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1()?;
    let reflection_v1alpha = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(hevo_proto::FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1alpha()?;
    let job_service = InterceptedService::new(
        JobServiceServer::new(grpc::JobApi::new(
            manager.clone(),
            evaluations,
            config.max_event_streams,
        ))
        .max_decoding_message_size(hevo_proto::MAX_MESSAGE_BYTES)
        .max_encoding_message_size(hevo_proto::MAX_MESSAGE_BYTES),
        auth_for(Role::Client),
    );

    let (stop, stopped) = tokio::sync::watch::channel(false);
    tokio::spawn(async move {
        wait_for_signal().await;
        let _ = stop.send(true);
    });
    let until_stopped = |mut stopped: tokio::sync::watch::Receiver<bool>| async move {
        let _ = stopped.wait_for(|&s| s).await;
    };
    if let Some(listener) = metrics_listener {
        let metrics = metrics.clone();
        let stopped = until_stopped(stopped.clone());
        tokio::spawn(async move {
            if let Err(error) = metrics::serve(listener, metrics, stopped).await {
                tracing::error!(%error, "metrics server failed");
            }
        });
    }
    if let Some(listener) = http_listener {
        let access = match &roles {
            Some(roles) => {
                let clients = roles.clients.clone();
                hevo_dashboard::Access::Tokens(Arc::new(move |token: &str| clients.accepts(token)))
            }
            None => hevo_dashboard::Access::Open,
        };
        let board = hevo_dashboard::Dashboard::new(
            Arc::new(dashboard::JobsSource::new(manager.clone())),
            access,
        );
        board.set_max_streams(config.max_event_streams);
        // A master with TLS is reached over TLS; its dashboard, behind a TLS proxy, too.
        board.set_secure_cookies(config.tls.is_some());
        let stopped = until_stopped(stopped.clone());
        tokio::spawn(async move {
            if let Err(error) = hevo_dashboard::serve(listener, board, http_limits, stopped).await {
                tracing::error!(%error, "dashboard server failed");
            }
        });
    }

    let mut builder = Server::builder()
        .http2_keepalive_interval(Some(Duration::from_secs(20)))
        .http2_keepalive_timeout(Some(Duration::from_secs(10)));
    if let Some(tls) = tls {
        builder = builder
            .tls_config(tls)
            .context("invalid TLS certificate or key")?;
    }
    let gate = ConnectionGate::new("grpc", grpc_limits);
    let router = builder
        .layer(mark_served_layer(gate.clone()))
        .add_service(health_service)
        .add_service(reflection_v1)
        .add_service(reflection_v1alpha)
        .add_service(job_service)
        .add_service(worker_service(worker_api, auth_for(Role::Worker)));
    tracing::info!(
        %address,
        state_dir = %config.state_dir.display(),
        tls = config.tls.is_some(),
        open_files,
        max_connections = grpc_limits.max_connections,
        http_max_connections = http_limits.max_connections,
        "master started"
    );

    let shutdown_manager = manager.clone();
    let shutdown = {
        let stopped = stopped.clone();
        async move {
            until_stopped(stopped).await;
            tracing::info!("shutting down: unfinished jobs resume on the next start");
            // Ends long polls and watch streams, so the server can drain.
            shutdown_manager.shut_down();
            health_reporter
                .set_service_status("", tonic_health::ServingStatus::NotServing)
                .await;
        }
    };
    let serving = router.serve_with_incoming_shutdown(
        incoming(listener, gate, closed_connections, config.tls.is_some()),
        shutdown,
    );
    tokio::pin!(serving);
    tokio::select! {
        result = &mut serving => result.context("the server failed")?,
        // Streams of clients that do not go away must not hold the master up for long.
        _ = async { until_stopped(stopped.clone()).await; tokio::time::sleep(Duration::from_secs(10)).await } => {
            tracing::warn!("connections still open 10 s after the shutdown request; closing");
        }
    }
    Ok(())
}

/// Checks the batches the dispatcher holds for a spot check (every worker's first result, and
/// `--verify-share` of the rest) by evaluating each here, on a blocking thread: evaluation is
/// deterministic, so the master's results are the true ones. A worker whose results differ is
/// refused from then on by the dispatcher, and every job that accepted a result of its is
/// evaluated again from the start (a running remote evaluation ends, for its client to evaluate
/// again), so that no lie outlives its discovery.
pub async fn spot_checks(
    dispatcher: Arc<Dispatcher>,
    manager: jobs::JobManager,
    evaluations: evaluations::Evaluations,
) {
    let cache = Arc::new(hevo_engine::executor::EvaluatorCache::default());
    while let Some(batch) = dispatcher.next_spot_check().await {
        let batch_id = batch.batch_id;
        let cache = cache.clone();
        let truth = tokio::task::spawn_blocking(move || {
            let evaluator = hevo_engine::local::evaluator_for(&cache, &batch)?;
            hevo_engine::local::evaluate_batch(&evaluator, &batch)
        })
        .await;
        match truth {
            Ok(Ok(truth)) => {
                if let Some(liar) = dispatcher.settle_spot_check(batch_id, truth) {
                    tracing::warn!(worker = %liar.worker, jobs = ?liar.jobs, "a spot check caught a worker sending false results; it is refused, and the jobs it worked on start again");
                    for job in liar.jobs {
                        if !evaluations.caught_false_results(&job) {
                            manager.evaluate_again(&job).await;
                        }
                    }
                }
            }
            Ok(Err(error)) => {
                dispatcher.fail_spot_check(
                    batch_id,
                    format!("the master cannot evaluate the batch: {error}"),
                );
            }
            Err(error) => {
                dispatcher.fail_spot_check(batch_id, format!("the spot check failed: {error}"));
            }
        }
    }
}

/// Re-reads the token files on every SIGHUP and replaces the accepted tokens: an operator
/// rotates a token by adding the new one to the file, sending SIGHUP, moving clients or
/// workers over, removing the old one and sending SIGHUP again. A file that cannot be read
/// keeps the tokens in force.
async fn reload_tokens_on_hangup(credentials: Credentials, roles: Roles) {
    use tokio::signal::unix::{SignalKind, signal};
    let Ok(mut hangups) = signal(SignalKind::hangup()) else {
        return;
    };
    while hangups.recv().await.is_some() {
        for (file, set, role) in [
            (&credentials.client_token_file, &roles.clients, "client"),
            (&credentials.worker_token_file, &roles.workers, "worker"),
        ] {
            let Some(file) = file else { continue };
            match hevo_proto::auth::read_token_file(file) {
                Ok(tokens) => {
                    set.replace(&tokens);
                    tracing::info!(role, tokens = tokens.len(), file = %file.display(), "tokens reloaded");
                }
                Err(error) => {
                    tracing::error!(role, %error, "tokens not reloaded; the old ones stay in force")
                }
            }
        }
        if roles.clients.overlaps(&roles.workers) {
            tracing::error!("after the reload a token is both a client's and a worker's");
        }
    }
}

/// Resolves on the first SIGTERM or SIGINT.
async fn wait_for_signal() {
    use tokio::signal::unix::{SignalKind, signal};
    match (
        signal(SignalKind::terminate()),
        signal(SignalKind::interrupt()),
    ) {
        (Ok(mut term), Ok(mut int)) => {
            tokio::select! {
                _ = term.recv() => {}
                _ = int.recv() => {}
            }
        }
        _ => {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}
