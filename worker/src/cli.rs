//! The `hevo-worker` command line. The master's address and the token can come from the
//! environment (`HEVO_MASTER`, `HEVO_TOKEN`), as containers prefer.

use crate::remote::{self, Shutdown, SimExecutor, WorkerConfig};
use anyhow::{Context, Result};
use clap::Parser;
use hevo_proto::client::MasterArgs;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;

/// Evaluate genomes for a hevo master: connect out to it, lease batches of evaluations, return
/// the results. Keeps no state, so it can be killed or started at any time; start as many as
/// there are machines.
#[derive(Debug, Parser)]
#[command(name = "hevo-worker", version)]
pub struct Args {
    #[command(flatten)]
    pub master: MasterArgs,
    /// Threads to evaluate with (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// The worker's name in the master's logs (default: host name and process id).
    #[arg(long)]
    pub name: Option<String>,
    /// On SIGTERM/SIGINT, how long the current batch may run before it is handed back
    /// (a second signal hands it back at once).
    #[arg(long, default_value_t = 30.0)]
    pub grace_seconds: f64,
}

/// Parses the command line and runs the worker; the exit code.
pub fn main() -> std::process::ExitCode {
    let args = Args::parse();
    init_tracing();
    match execute(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn init_tracing() {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::stderr().is_terminal())
        .with_writer(std::io::stderr)
        .try_init();
}

fn default_name() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "worker".into());
    format!("{host}-{}", std::process::id())
}

/// Runs a parsed command line.
pub fn execute(args: Args) -> Result<()> {
    let options = args.master.options()?;
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    if !(args.grace_seconds.is_finite() && args.grace_seconds >= 0.0) {
        anyhow::bail!("--grace-seconds must be a non-negative number");
    }
    let name = args.name.clone().unwrap_or_else(default_name);
    if name.is_empty() || name.len() > 128 {
        anyhow::bail!("--name must be 1 to 128 characters");
    }
    let mut config = WorkerConfig::new(options, name, threads);
    config.grace = Duration::from_secs_f64(args.grace_seconds);
    // The async side only waits on the network; evaluation runs on blocking threads.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let report = runtime.block_on(async move {
        let (stop, stopped) = watch::channel(Shutdown::Running);
        tokio::spawn(async move {
            if let Err(error) = forward_signals(stop).await {
                tracing::error!(%error, "cannot listen for signals");
            }
        });
        remote::run(config, Arc::new(SimExecutor::default()), stopped).await
    })?;
    tracing::info!(
        batches = report.batches,
        evaluations = report.evaluations,
        released = report.released,
        "worker stopped"
    );
    Ok(())
}

/// First SIGTERM/SIGINT: graceful; second: now.
async fn forward_signals(stop: watch::Sender<Shutdown>) -> std::io::Result<()> {
    use tokio::signal::unix::{SignalKind, signal};
    let mut term = signal(SignalKind::terminate())?;
    let mut int = signal(SignalKind::interrupt())?;
    for level in [Shutdown::Graceful, Shutdown::Now] {
        tokio::select! {
            _ = term.recv() => {}
            _ = int.recv() => {}
        }
        tracing::info!(?level, "shutdown requested");
        let _ = stop.send(level);
    }
    Ok(())
}
